//! Dataset loaders: each turns one on-disk format into the canonical [`Scene`].
//!
//! Loaders never panic on data: every problem becomes a [`LoadError`] whose one-line message
//! names the file, the record (node id, line) and what is wrong.

mod gltf_hierarchy;
internal! {
    pub mod gltf_mesh;
}
internal! {
    pub mod gltf_scene;
}
internal! {
    pub mod mp3d;
}
internal! {
    pub mod obj_mesh;
}
internal! {
    pub mod suncg;
}
internal! {
    pub mod threedfront;
}

pub use mp3d::house_file::HouseError;

use crate::file_error::FileError;
use std::path::{Path, PathBuf};

use super::mesh::Mesh;
use super::model::{Dataset, Scene};

/// Extensions tried after a bare texture name (SUNCG's `wood_1`).
const TEXTURE_EXTENSIONS: [&str; 3] = ["png", "jpg", "jpeg"];

/// The files a material's texture `name` may denote for a mesh in `mesh_dir`, in order of
/// preference: relative to the mesh's folder (where OBJ `map_Kd` paths and glTF image URIs
/// point), then in SUNCG's shared `texture/` folder two levels up (`room/<house>/` and
/// `object/<model>/` sit beside `texture/`); a name without an extension also tries `.png`,
/// `.jpg` and `.jpeg`. An absolute name is itself; an empty or `data:` name has none.
pub fn texture_candidates(name: &str, mesh_dir: &Path) -> Vec<PathBuf> {
    let name = name.trim().replace('\\', "/");
    if name.is_empty() || name.starts_with("data:") {
        return Vec::new();
    }
    let rel = Path::new(&name);
    let bases: Vec<PathBuf> = if rel.is_absolute() {
        vec![rel.to_path_buf()]
    } else {
        vec![mesh_dir.join(rel), mesh_dir.join("../../texture").join(rel)]
    };
    let mut out = Vec::new();
    for b in bases {
        if b.extension().is_none() {
            out.extend(TEXTURE_EXTENSIONS.iter().map(|e| b.with_extension(e)));
        }
        out.push(b);
    }
    out
}

/// One scene found under a dataset root.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct SceneEntry {
    /// Scene id (SUNCG house id, scan id, file stem).
    pub id: String,
    /// The scene's main source file.
    pub path: PathBuf,
}

/// A loaded scene with the files it was built from.
#[derive(Debug)]
pub struct LoadedScene {
    /// The canonical scene.
    pub scene: Scene,
    /// Every file read (for freshness checks).
    pub sources: Vec<PathBuf>,
    /// Non-fatal remarks, one line each.
    pub warnings: Vec<String>,
}

/// What every dataset loader offers `ingest`: find the scenes under a root, load one.
pub trait DatasetLoader: Sync {
    /// The dataset this loader reads.
    fn dataset(&self) -> Dataset;
    /// Every scene under the root, sorted by id.
    fn discover(&self) -> Result<Vec<SceneEntry>, LoadError>;
    /// Loads one scene; every failure names the file and the record.
    fn load(&self, entry: &SceneEntry) -> Result<LoadedScene, LoadError>;
    /// Where [`DatasetLoader::discover`] looks for scenes, relative to the root, in words (for
    /// the error of a root that holds none).
    fn scene_layout(&self) -> &'static str;
    /// A remark about the whole root (e.g. a missing category table), if any.
    fn root_warning(&self) -> Option<String> {
        None
    }
}

/// A failure to load a scene or one of its files.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read.
    #[error(transparent)]
    Io(#[from] FileError),
    /// The file is not valid for its format.
    #[error("{}: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// Where (line, field) and what is wrong.
        message: String,
    },
    /// A Matterport3D `.house` file breaks its format (the line and what is wrong).
    #[error("{}", path.display())]
    House {
        /// The file.
        path: PathBuf,
        /// The line and the problem.
        #[source]
        source: mp3d::house_file::HouseError,
    },
    /// One record of a valid file refers to another file (a template, a mesh) that cannot
    /// be used.
    #[error("{}: node {node}", path.display())]
    Referenced {
        /// The file holding the record.
        path: PathBuf,
        /// The record's id.
        node: String,
        /// Why the referenced file cannot be used.
        #[source]
        source: Box<LoadError>,
    },
    /// One record (node, object) of a valid file is wrong.
    #[error("{}: node {node}: {message}", path.display())]
    Node {
        /// The file holding the record.
        path: PathBuf,
        /// The record's id.
        node: String,
        /// What is wrong.
        message: String,
    },
}

impl LoadError {
    /// A parse error; newlines in `message` are folded so the error stays one line.
    pub fn parse(path: &Path, message: impl Into<String>) -> Self {
        LoadError::Parse {
            path: path.to_path_buf(),
            message: one_line(message.into()),
        }
    }

    /// A record error caused by another file's.
    pub fn referenced(path: &Path, node: impl Into<String>, source: LoadError) -> Self {
        LoadError::Referenced {
            path: path.to_path_buf(),
            node: node.into(),
            source: Box::new(source),
        }
    }

    /// A record error.
    pub fn node(path: &Path, node: impl Into<String>, message: impl Into<String>) -> Self {
        LoadError::Node {
            path: path.to_path_buf(),
            node: node.into(),
            message: one_line(message.into()),
        }
    }
}

/// Runs `f`, a call into a dependency's reader (tobj, gltf), turning a panic inside it into
/// an error naming `path`: a dependency's panic on bad data must not take a batch down.
pub fn guarded<T>(path: &Path, f: impl FnOnce() -> T) -> Result<T, LoadError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|p| {
        let what = crate::escape::panic_message(p.as_ref());
        LoadError::parse(path, format!("the reader failed: {what}"))
    })
}

fn one_line(s: String) -> String {
    if s.contains('\n') {
        s.split_whitespace().collect::<Vec<_>>().join(" ")
    } else {
        s
    }
}

/// Loads a mesh file by extension: `.obj` (tobj) or `.gltf` / `.glb` (gltf).
pub fn load_mesh_file(path: &Path) -> Result<Mesh, LoadError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let mesh = match ext.as_str() {
        "obj" => obj_mesh::load_obj(path)?,
        "gltf" | "glb" => guarded(path, || gltf_mesh::load_gltf(path))??,
        other => {
            return Err(LoadError::parse(
                path,
                format!("unsupported mesh format `.{other}` (expected .obj, .gltf or .glb)"),
            ))
        }
    };
    mesh.validate().map_err(|m| LoadError::parse(path, m))?;
    Ok(mesh)
}

/// serde_json's message without its ` at line L column C` suffix (the loaders say where
/// themselves, see [`json_error_text`]).
pub fn json_message(e: &serde_json::Error) -> String {
    let s = e.to_string();
    match s.rfind(" at line ") {
        Some(i) => s[..i].to_string(),
        None => s,
    }
}

/// A JSON error as every loader words it: `line L column C: what` (one line).
pub fn json_error_text(e: &serde_json::Error) -> String {
    format!(
        "line {} column {}: {}",
        e.line(),
        e.column(),
        json_message(e)
    )
}

/// Replaces the bare tokens `NaN`, `Infinity` and `-Infinity` (which Python's json module
/// writes but JSON forbids) by `null` outside strings, so that the loader can report the node
/// holding them instead of a bare syntax error. Lines and columns before them are unchanged.
pub fn nan_tokens_to_null(bytes: &[u8]) -> std::borrow::Cow<'_, [u8]> {
    if !bytes.windows(3).any(|w| w == b"NaN") && !bytes.windows(8).any(|w| w == b"Infinity") {
        return std::borrow::Cow::Borrowed(bytes);
    }
    let mut out = Vec::with_capacity(bytes.len());
    let mut in_string = false;
    let mut i = 0;
    while i < bytes.len() {
        let b = bytes[i];
        if in_string {
            out.push(b);
            if b == b'\\' && i + 1 < bytes.len() {
                out.push(bytes[i + 1]);
                i += 2;
                continue;
            }
            if b == b'"' {
                in_string = false;
            }
            i += 1;
            continue;
        }
        if b == b'"' {
            in_string = true;
            out.push(b);
            i += 1;
            continue;
        }
        let rest = &bytes[i..];
        if let Some(len) = [&b"-Infinity"[..], b"Infinity", b"NaN"]
            .iter()
            .find(|t| rest.starts_with(t))
            .map(|t| t.len())
        {
            out.extend_from_slice(b"null");
            i += len;
            continue;
        }
        out.push(b);
        i += 1;
    }
    std::borrow::Cow::Owned(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nan_tokens_become_null_outside_strings_only() {
        let s = br#"{"a": [1, NaN, -Infinity], "b": "NaN"}"#;
        let out = nan_tokens_to_null(s);
        assert_eq!(&out[..], br#"{"a": [1, null, null], "b": "NaN"}"#);
    }

    #[test]
    fn texture_names_are_looked_for_beside_the_mesh_then_in_suncgs_texture_folder() {
        let dir = Path::new("/d/room/h1");
        let p = |s: &str| PathBuf::from(s);
        assert_eq!(
            texture_candidates("a\\b.png", dir),
            vec![
                p("/d/room/h1/a/b.png"),
                p("/d/room/h1/../../texture/a/b.png")
            ]
        );
        assert_eq!(
            texture_candidates(" wood_1 ", dir),
            vec![
                p("/d/room/h1/wood_1.png"),
                p("/d/room/h1/wood_1.jpg"),
                p("/d/room/h1/wood_1.jpeg"),
                p("/d/room/h1/wood_1"),
                p("/d/room/h1/../../texture/wood_1.png"),
                p("/d/room/h1/../../texture/wood_1.jpg"),
                p("/d/room/h1/../../texture/wood_1.jpeg"),
                p("/d/room/h1/../../texture/wood_1"),
            ]
        );
        assert_eq!(texture_candidates("/t/x.jpg", dir), vec![p("/t/x.jpg")]);
        assert!(texture_candidates("", dir).is_empty());
        assert!(texture_candidates("data:image/png;base64,AAAA", dir).is_empty());
    }
}
