//! The compiled scene file `DATA/scenes/<scene>.mscene` (layout in `docs/FORMATS.md`).
//!
//! ```text
//! magic   8 bytes  "MINOSSCN"
//! version u32 LE   FORMAT_VERSION
//! hlen    u32 LE   length of the header that follows
//! sum     u64 LE   checksum (navmesh::file::checksum) of header and body (since version 2)
//! header  hlen     postcard(SceneHeader): id, dataset, source files
//! body    rest     postcard(Scene)
//! ```
//! The header can be read without the body, so `ingest` decides whether a scene is
//! up to date by reading a few hundred bytes; a file of another version is never up to date,
//! so ingest rebuilds it. Decoding checks the checksum, then [`Scene::validate`] (every index
//! in range, finite numbers), so no later stage indexes out of bounds on a corrupt file.

use crate::file_error::FileError;
use std::fs::File;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::atomic::write_atomic;
use crate::navmesh::file::checksum;
use crate::scene::Scene;

/// First bytes of every compiled scene.
pub const MAGIC: &[u8; 8] = b"MINOSSCN";
/// Bumped whenever the encoding of [`Scene`] changes; older files are rebuilt by ingest.
/// (2: a checksum of header and body after the header length.)
pub const FORMAT_VERSION: u32 = 2;
/// Bytes before the header: magic, version, header length, checksum.
const PREFIX: usize = 24;
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
    #[error(transparent)]
    Io(#[from] FileError),
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
    let mut out = Vec::with_capacity(PREFIX + h.len() + body.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&(h.len() as u32).to_le_bytes());
    out.extend_from_slice(&[0; 8]);
    out.extend_from_slice(&h);
    out.extend_from_slice(&body);
    let sum = checksum(&out[PREFIX..]);
    out[16..PREFIX].copy_from_slice(&sum.to_le_bytes());
    Ok(out)
}

/// Writes a compiled scene atomically. A scene that fails [`Scene::validate`] is refused (its
/// file could not be read back).
pub fn write_scene(path: &Path, header: &SceneHeader, scene: &Scene) -> Result<(), SceneFileError> {
    scene.validate().map_err(|e| SceneFileError::Format {
        path: path.to_path_buf(),
        message: format!("invalid scene: {e}"),
    })?;
    let bytes = encode(header, scene).map_err(|e| SceneFileError::Format {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    write_atomic(path, |w| w.write_all(&bytes))
        .map_err(|source| SceneFileError::Io(FileError::new(path, source)))
}

/// Checks the magic and the format version at the start of `bytes`.
fn check_magic_version(path: &Path, bytes: &[u8]) -> Result<(), SceneFileError> {
    let bad = |m: &str| SceneFileError::Format {
        path: path.to_path_buf(),
        message: m.to_string(),
    };
    if bytes.len() < 12 || &bytes[..8] != MAGIC {
        return Err(bad("not a minos compiled scene (bad magic)"));
    }
    let version = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
    if version != FORMAT_VERSION {
        return Err(bad(&format!(
            "format version {version}, this minos reads {FORMAT_VERSION}"
        )));
    }
    Ok(())
}

fn split_prefix<'a>(path: &Path, bytes: &'a [u8]) -> Result<(&'a [u8], &'a [u8]), SceneFileError> {
    check_magic_version(path, bytes)?;
    let bad = |m: &str| SceneFileError::Format {
        path: path.to_path_buf(),
        message: m.to_string(),
    };
    if bytes.len() < PREFIX {
        return Err(bad("corrupt: truncated header"));
    }
    let hlen = u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]) as usize;
    if bytes.len() - PREFIX < hlen {
        return Err(bad("corrupt: truncated header"));
    }
    Ok((&bytes[PREFIX..PREFIX + hlen], &bytes[PREFIX + hlen..]))
}

/// Decodes a whole compiled scene from bytes; `path` names it in errors. The checksum, the
/// encoding and [`Scene::validate`] must all check out.
pub fn decode(path: &Path, bytes: &[u8]) -> Result<(SceneHeader, Scene), SceneFileError> {
    let (h, body) = split_prefix(path, bytes)?;
    // Names quoted from the file (mesh names, ids) may hold newlines: keep the error one line.
    let bad = |message: String| SceneFileError::Format {
        path: path.to_path_buf(),
        message: crate::escape::escape_controls(&message),
    };
    let stored = u64::from_le_bytes(bytes[16..PREFIX].try_into().unwrap_or([0; 8]));
    // Fuzzing skips the checksum so that the decoder and the validation behind it are reached.
    if !cfg!(fuzzing) && checksum(&bytes[PREFIX..]) != stored {
        return Err(bad("corrupt: checksum mismatch".into()));
    }
    let header: SceneHeader =
        postcard::from_bytes(h).map_err(|e| bad(format!("corrupt header: {e}")))?;
    let scene: Scene =
        postcard::from_bytes(body).map_err(|e| bad(format!("corrupt scene: {e}")))?;
    scene
        .validate()
        .map_err(|e| bad(format!("invalid scene: {e}")))?;
    Ok((header, scene))
}

/// Reads a whole compiled scene.
pub fn read_scene(path: &Path) -> Result<(SceneHeader, Scene), SceneFileError> {
    let bytes =
        std::fs::read(path).map_err(|source| SceneFileError::Io(FileError::new(path, source)))?;
    decode(path, &bytes)
}

/// Reads only the header of a compiled scene.
pub fn read_header(path: &Path) -> Result<SceneHeader, SceneFileError> {
    let io_err = |source| SceneFileError::Io(FileError::new(path, source));
    let mut f = File::open(path).map_err(io_err)?;
    let mut prefix = [0u8; PREFIX];
    let n = read_up_to(&mut f, &mut prefix).map_err(io_err)?;
    // Magic and version first, so an old or foreign file says so.
    check_magic_version(path, &prefix[..n])?;
    let hlen = u32::from_le_bytes([prefix[12], prefix[13], prefix[14], prefix[15]]) as usize;
    let mut bytes = prefix.to_vec();
    bytes.resize(PREFIX + hlen.min(1 << 24), 0);
    let got = read_up_to(&mut f, &mut bytes[PREFIX..]).map_err(io_err)?;
    bytes.truncate(PREFIX + got);
    let (h, _) = split_prefix(path, &bytes)?;
    postcard::from_bytes(h).map_err(|e| SceneFileError::Format {
        path: path.to_path_buf(),
        message: format!("corrupt header: {e}"),
    })
}

/// Reads as much of `buf` as the file holds; returns how many bytes were read.
fn read_up_to(f: &mut File, buf: &mut [u8]) -> io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match f.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
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

    fn good_bytes() -> Vec<u8> {
        let header = SceneHeader {
            id: "h".into(),
            source: "house.json".into(),
            sources: vec![],
        };
        encode(&header, &scene()).unwrap()
    }

    #[test]
    fn every_bit_flip_and_truncation_is_an_error_naming_the_file_never_a_panic() {
        let p = Path::new("x.mscene");
        let good = good_bytes();
        assert!(decode(p, &good).is_ok());
        for at in 0..good.len() {
            for bit in [0, 3, 7] {
                let mut b = good.clone();
                b[at] ^= 1 << bit;
                let r = std::panic::catch_unwind(|| decode(p, &b).map(|_| ()));
                let err = r
                    .unwrap_or_else(|_| panic!("panic at byte {at} bit {bit}"))
                    .expect_err("a flipped bit is caught");
                let msg = err.to_string();
                assert!(
                    msg.starts_with("x.mscene: ") && !msg.contains('\n'),
                    "{msg}"
                );
            }
        }
        for len in 0..good.len() {
            let r = std::panic::catch_unwind(|| decode(p, &good[..len]).map(|_| ()));
            assert!(r.expect("no panic").is_err(), "truncated to {len}");
        }
    }

    #[test]
    fn a_checksummed_file_with_an_index_out_of_range_is_refused_naming_the_field() {
        let mut s = scene();
        s.levels[0].ground = vec![7];
        // `encode` does not validate: this is a file a buggy or hostile writer made.
        let bytes = encode(
            &SceneHeader {
                id: "h".into(),
                source: String::new(),
                sources: vec![],
            },
            &s,
        )
        .unwrap();
        let err = decode(Path::new("x.mscene"), &bytes)
            .unwrap_err()
            .to_string();
        assert_eq!(
            err,
            "x.mscene: invalid scene: level 0: ground: mesh 7 out of range for 1 meshes"
        );
        let dir = tempfile::tempdir().unwrap();
        let err = write_scene(
            &dir.path().join("y.mscene"),
            &SceneHeader {
                id: "h".into(),
                source: String::new(),
                sources: vec![],
            },
            &s,
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("y.mscene: invalid scene: level 0: ground"),
            "{err}"
        );
        assert!(!dir.path().join("y.mscene").exists());
    }

    #[test]
    fn an_old_version_asks_for_a_reingest_even_from_the_header_alone() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("old.mscene");
        let mut b = good_bytes();
        b[8..12].copy_from_slice(&1u32.to_le_bytes());
        std::fs::write(&path, &b).unwrap();
        for err in [
            read_header(&path).unwrap_err().to_string(),
            read_scene(&path).unwrap_err().to_string(),
        ] {
            assert!(
                err.contains("format version 1, this minos reads 2"),
                "{err}"
            );
        }
    }

    #[test]
    fn an_error_quoting_a_name_with_a_newline_stays_one_line() {
        // Fuzzing regression (target `mscene`): a mesh name holding a newline was quoted into
        // the error.
        let mut s = scene();
        s.meshes[0].name = "a\nb".into();
        s.meshes[0].normals.clear();
        let header = SceneHeader {
            id: "h".into(),
            source: String::new(),
            sources: vec![],
        };
        let err = decode(Path::new("x.mscene"), &encode(&header, &s).unwrap())
            .unwrap_err()
            .to_string();
        assert_eq!(
            err,
            "x.mscene: invalid scene: mesh 0 (a\\nb): 0 normals for 3 vertices"
        );
    }
}
