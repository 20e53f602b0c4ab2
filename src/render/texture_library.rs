//! Loading the textures a scene's materials name, once per file.
//!
//! Where a name may be on disk is the loaders' knowledge of their datasets' layouts
//! ([`texture_candidates`]: beside the mesh, then SUNCG's shared `texture/` folder); this
//! library loads the first candidate that exists. A texture that cannot be found or decoded
//! is recorded once and its triangles keep their flat material colour, so a missing file
//! never fails rendering.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use super::texture::Texture;
use crate::scene::formats::texture_candidates;

/// Textures loaded for one scene, indexed by the ids [`TextureLibrary::resolve`] hands out.
#[derive(Debug, Default)]
pub struct TextureLibrary {
    /// The loaded textures.
    pub textures: Vec<Texture>,
    /// (mesh folder, name) → texture id, or `None` when it failed.
    by_name: HashMap<(PathBuf, String), Option<u32>>,
    /// Resolved file → texture id (two names for one file load it once).
    by_file: HashMap<PathBuf, u32>,
    /// Texture name → why it is not used.
    missing: BTreeMap<String, String>,
}

impl TextureLibrary {
    /// An empty library.
    pub fn new() -> Self {
        TextureLibrary::default()
    }

    /// The id of texture `name` as used by the mesh loaded from `mesh_file`, loading it on
    /// first use; `None` when it cannot be found or decoded (recorded in [`Self::missing`]).
    pub fn resolve(&mut self, name: &str, mesh_file: &str) -> Option<u32> {
        let dir = Path::new(mesh_file)
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        let key = (dir, name.to_string());
        if let Some(&id) = self.by_name.get(&key) {
            return id;
        }
        let id = self.load(name, &key.0);
        self.by_name.insert(key, id);
        id
    }

    fn load(&mut self, name: &str, dir: &Path) -> Option<u32> {
        let Some(file) = texture_candidates(name, dir)
            .into_iter()
            .find(|p| p.is_file())
        else {
            self.missing.insert(
                name.to_string(),
                format!("not found beside {} or in its ../../texture", dir.display()),
            );
            return None;
        };
        // One file reached by several relative paths is loaded once.
        let file = std::fs::canonicalize(&file).unwrap_or(file);
        if let Some(&id) = self.by_file.get(&file) {
            return Some(id);
        }
        match Texture::load(&file) {
            Ok(t) => {
                let id = self.textures.len() as u32;
                self.textures.push(t);
                self.by_file.insert(file, id);
                Some(id)
            }
            Err(e) => {
                self.missing
                    .insert(name.to_string(), crate::escape::error_line(&e));
                None
            }
        }
    }

    /// Texture names that could not be used and why, sorted by name.
    pub fn missing(&self) -> impl Iterator<Item = (&str, &str)> {
        self.missing.iter().map(|(k, v)| (k.as_str(), v.as_str()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png(path: &Path, rgb: [u8; 3]) {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        image::RgbImage::from_pixel(4, 4, image::Rgb(rgb))
            .save(path)
            .unwrap();
    }

    #[test]
    fn names_resolve_beside_the_mesh_then_in_the_suncg_texture_folder() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path();
        png(&root.join("object/m1/local.png"), [1, 2, 3]);
        png(&root.join("texture/wood_1.jpg"), [200, 100, 50]);
        let mesh = root.join("object/m1/m1.obj").display().to_string();
        let mut lib = TextureLibrary::new();
        let local = lib.resolve("local.png", &mesh).expect("beside the mesh");
        assert_eq!(lib.textures[local as usize].texels[0], [1, 2, 3]);
        let wood = lib
            .resolve("wood_1", &mesh)
            .expect("SUNCG name without extension");
        assert_ne!(local, wood);
        let again = lib.resolve("../../texture/wood_1.jpg", &mesh);
        assert_eq!(again, Some(wood), "one file is loaded once");
        std::fs::create_dir_all(root.join("room/h")).unwrap();
        let other_mesh = root.join("room/h/f.obj").display().to_string();
        assert_eq!(
            lib.resolve("wood_1", &other_mesh),
            Some(wood),
            "whichever mesh names it"
        );
        assert_eq!(lib.textures.len(), 2);
        assert_eq!(lib.resolve("nope", &mesh), None);
        assert_eq!(lib.resolve("nope", &mesh), None);
        let missing: Vec<_> = lib.missing().collect();
        assert_eq!(missing.len(), 1, "{missing:?}");
        assert_eq!(missing[0].0, "nope");
    }

    #[test]
    fn a_corrupt_texture_is_recorded_not_fatal() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("bad.png"), b"garbage").unwrap();
        let mesh = dir.path().join("m.obj").display().to_string();
        let mut lib = TextureLibrary::new();
        assert_eq!(lib.resolve("bad.png", &mesh), None);
        assert!(lib.missing().next().unwrap().1.contains("bad.png"));
    }
}
