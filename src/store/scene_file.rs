//! The compiled scene file `DATA/scenes/<scene>.mscene` (layout in `docs/FORMATS.md`).
//!
//! ```text
//! magic   8 bytes  "MINOSSCN"
//! version u32 LE   FORMAT_VERSION
//! hlen    u32 LE   length of the header that follows
//! header  hlen     postcard(SceneHeader): id, dataset, source files
//! body    rest     postcard(Scene)
//! ```
//! The header can be read without the body, so `ingest` decides whether a scene is
//! up to date by reading a few hundred bytes.

use std::fs::File;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::atomic::write_atomic;
use crate::scene::Scene;

/// First bytes of every compiled scene.
pub const MAGIC: &[u8; 8] = b"MINOSSCN";
/// Bumped whenever the encoding of [`Scene`] changes; older files are rebuilt by ingest.
pub const FORMAT_VERSION: u32 = 1;
/// File extension of compiled scenes.
pub const EXTENSION: &str = "mscene";

/// What a compiled scene says about itself before its body.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneHeader {
    /// Scene id.
    pub id: String,
    /// The main source file (e.g. `house.json`).
    pub source: String,
    /// Every file the scene was built from (for freshness checks).
    pub sources: Vec<String>,
}

/// Errors reading or writing compiled scenes.
#[derive(Debug, thiserror::Error)]
pub enum SceneFileError {
    /// File system error.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: io::Error,
    },
    /// Not a compiled scene, another format version, or corrupt.
    #[error("{path}: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// The path of a scene's compiled file in a DATA folder.
pub fn scene_path(data: &Path, id: &str) -> PathBuf {
    data.join("scenes").join(format!("{id}.{EXTENSION}"))
}

/// Encodes a scene (header and body) into bytes.
pub fn encode(header: &SceneHeader, scene: &Scene) -> Result<Vec<u8>, postcard::Error> {
    let h = postcard::to_stdvec(header)?;
    let body = postcard::to_stdvec(scene)?;
    let mut out = Vec::with_capacity(16 + h.len() + body.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&(h.len() as u32).to_le_bytes());
    out.extend_from_slice(&h);
    out.extend_from_slice(&body);
    Ok(out)
}

/// Writes a compiled scene atomically.
pub fn write_scene(path: &Path, header: &SceneHeader, scene: &Scene) -> Result<(), SceneFileError> {
    let bytes = encode(header, scene).map_err(|e| SceneFileError::Format {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    write_atomic(path, |w| w.write_all(&bytes)).map_err(|source| SceneFileError::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn split_prefix<'a>(path: &Path, bytes: &'a [u8]) -> Result<(&'a [u8], &'a [u8]), SceneFileError> {
    let bad = |m: &str| SceneFileError::Format {
        path: path.to_path_buf(),
        message: m.to_string(),
    };
    if bytes.len() < 16 || &bytes[..8] != MAGIC {
        return Err(bad("not a minos compiled scene (bad magic)"));
    }
    let version = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
    if version != FORMAT_VERSION {
        return Err(bad(&format!(
            "format version {version}, this minos reads {FORMAT_VERSION} (re-run ingest)"
        )));
    }
    let hlen = u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]) as usize;
    if bytes.len() < 16 + hlen {
        return Err(bad("truncated header"));
    }
    Ok((&bytes[16..16 + hlen], &bytes[16 + hlen..]))
}

/// Decodes a whole compiled scene from bytes; `path` names it in errors.
pub fn decode(path: &Path, bytes: &[u8]) -> Result<(SceneHeader, Scene), SceneFileError> {
    let (h, body) = split_prefix(path, bytes)?;
    let corrupt = |e: postcard::Error| SceneFileError::Format {
        path: path.to_path_buf(),
        message: format!("corrupt: {e}"),
    };
    let header: SceneHeader = postcard::from_bytes(h).map_err(corrupt)?;
    let scene: Scene = postcard::from_bytes(body).map_err(corrupt)?;
    Ok((header, scene))
}

/// Reads a whole compiled scene.
pub fn read_scene(path: &Path) -> Result<(SceneHeader, Scene), SceneFileError> {
    let bytes = std::fs::read(path).map_err(|source| SceneFileError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    decode(path, &bytes)
}

/// Reads only the header of a compiled scene.
pub fn read_header(path: &Path) -> Result<SceneHeader, SceneFileError> {
    let io_err = |source| SceneFileError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut f = File::open(path).map_err(io_err)?;
    let mut prefix = [0u8; 16];
    f.read_exact(&mut prefix).map_err(io_err)?;
    let hlen = u32::from_le_bytes([prefix[12], prefix[13], prefix[14], prefix[15]]) as usize;
    let mut bytes = prefix.to_vec();
    bytes.resize(16 + hlen.min(1 << 24), 0);
    f.read_exact(&mut bytes[16..]).map_err(io_err)?;
    let (h, _) = split_prefix(path, &bytes)?;
    postcard::from_bytes(h).map_err(|e| SceneFileError::Format {
        path: path.to_path_buf(),
        message: format!("corrupt header: {e}"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Aabb, Dataset, Level, Material, Mesh};

    fn scene() -> Scene {
        let mut mesh = Mesh {
            name: "m".into(),
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]],
            indices: vec![0, 1, 2],
            face_materials: vec![0],
            materials: vec![Material::solid("a", [0.5, 0.25, 1.0])],
            ..Default::default()
        };
        mesh.compute_normals();
        Scene {
            id: "h".into(),
            dataset: Dataset::Suncg,
            levels: vec![Level {
                index: 0,
                bbox: Aabb::from_corners(glam::Vec3::ZERO, glam::Vec3::ONE),
                floor_heights: vec![0.0],
                rooms: vec![],
                objects: vec![],
                ground: vec![0],
            }],
            meshes: vec![mesh],
        }
    }

    #[test]
    fn compiled_scene_round_trips_and_header_reads_alone() {
        let dir = tempfile::tempdir().unwrap();
        let path = scene_path(dir.path(), "h");
        let header = SceneHeader {
            id: "h".into(),
            source: "house.json".into(),
            sources: vec!["house.json".into(), "a.obj".into()],
        };
        write_scene(&path, &header, &scene()).unwrap();
        let (h, s) = read_scene(&path).unwrap();
        assert_eq!(h, header);
        assert_eq!(s, scene());
        assert_eq!(read_header(&path).unwrap(), header);
    }

    #[test]
    fn wrong_magic_version_and_truncation_are_errors_naming_the_file() {
        let p = Path::new("x.mscene");
        let good = encode(
            &SceneHeader {
                id: "h".into(),
                source: String::new(),
                sources: vec![],
            },
            &scene(),
        )
        .unwrap();
        let mut bad_magic = good.clone();
        bad_magic[0] = b'X';
        assert!(decode(p, &bad_magic)
            .unwrap_err()
            .to_string()
            .contains("bad magic"));
        let mut old = good.clone();
        old[8] = 99;
        assert!(decode(p, &old)
            .unwrap_err()
            .to_string()
            .contains("version 99"));
        let cut = &good[..good.len() - 5];
        let err = decode(p, cut).unwrap_err().to_string();
        assert!(err.starts_with("x.mscene: corrupt"), "{err}");
    }
}
