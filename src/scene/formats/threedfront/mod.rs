//! 3D-FRONT scenes: a folder of scene JSON files (`<root>/<scene uid>.json`, the download
//! layout), furniture meshes optionally from a 3D-FUTURE folder (`<models>/<jid>/raw_model.obj`).
//!
//! What becomes what (3D-FRONT is y-up, metres, so no axis change):
//! - each `scene.room[]` is a [`Room`](crate::scene::Room) (id `instanceid`, raw type `type`,
//!   class from `data/taxonomy/3dfront_room_types.csv`); all rooms share one level;
//! - architecture meshes (`mesh[]`, inline `xyz`/`normal`/`uv`/`faces`) referenced by a room's
//!   children become that room's surfaces, placed by the child's transform: `Floor` → floor,
//!   ceilings → ceiling, walls, baseboards, door/window pockets (casings) and the like → wall
//!   (see [`arch_role`]); the room's floor area comes from its floor triangles;
//! - `Door`, `Window` and `Hole` meshes (the reveal of an opening and, for doors and holes, the
//!   threshold that floors the doorway) become objects flagged door / window / arch, one per
//!   child, so the bake fills them as solids: a window blocks, a doorway stays open under its
//!   header and its threshold is walkable; fixed furniture, platforms and stairs are objects too;
//! - `furniture[]` children become objects with the child's `instanceid` as id: the 3D-FUTURE
//!   mesh when `--models` has it, else the unit box scaled to the furniture's `size` (read as
//!   length x, depth z, height y) or `bbox` (x, y, z), standing on the child's position; without
//!   either the object has no geometry. Fine category: the furniture's `category` or `title`,
//!   else the 3D-FUTURE category; coarse: the 3D-FUTURE super-category. Furniture listed in
//!   `extension.door` is flagged door. `valid: false` furniture is skipped, as the 3D-FRONT
//!   ToolBox does;
//! - transforms are translate(`pos`) · rotate(`rot`, quaternion x y z w) · scale(`scale`);
//!   negative scales mirror and get their winding fixed when placed. Room-level `pos`/`rot`/
//!   `scale` are not applied (children are in world space, as the ToolBox reads them).
//!
//! Bad values (syntax, non-finite numbers, a zero quaternion or scale, face indices out of
//! range) fail the scene with one line naming the file, the record and the field. Children whose
//! `ref` matches no uid are common in the real data (door and window models that were not
//! released): they are skipped with one warning line per kind of remark, naming the first.
//!
//! The 3D-FUTURE category table is the `--categories` file, else the first found of
//! `model_info.json` or `*ModelCategoryMapping.csv` in `<models>`, `<models>/metadata`, `<root>`,
//! `<root>/metadata` and `<root>/../metadata`.

mod assemble;
mod geometry;
mod json;
mod tables;

use crate::file_error::FileError;
use std::path::{Path, PathBuf};

use crate::scene::Dataset;
use crate::scene::FlagTable;

use super::{DatasetLoader, LoadError, LoadedScene, SceneEntry};

pub use tables::{FrontRoomTypes, FutureCategories};
// What `FutureCategories` hands out, named for the tests (the module is internal).
#[cfg(feature = "internals")]
pub use tables::FutureCategory;

/// Loads 3D-FRONT scenes from one folder of scene JSON files.
pub struct ThreeDFrontLoader {
    root: PathBuf,
    models: Option<PathBuf>,
    categories: FutureCategories,
    mapping_path: Option<PathBuf>,
    room_types: FrontRoomTypes,
    flags: FlagTable,
}

impl ThreeDFrontLoader {
    /// A loader for the scene files in `root`, furniture meshes from the 3D-FUTURE folder
    /// `models` (boxes when `None`), and categories from `mapping` or, when `None`, from the
    /// first table found (see the module docs). Fails when `models` is not a folder or the
    /// table cannot be read.
    pub fn open(
        root: &Path,
        models: Option<&Path>,
        mapping: Option<&Path>,
    ) -> Result<Self, LoadError> {
        if let Some(m) = models.filter(|m| !m.is_dir()) {
            return Err(LoadError::Io(FileError {
                path: m.to_path_buf(),
                source: std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    "3D-FUTURE model folder not found",
                ),
            }));
        }
        let mapping_path = match mapping {
            Some(p) => Some(p.to_path_buf()),
            None => find_mapping(root, models),
        };
        let categories = match &mapping_path {
            Some(p) => read_categories(p)?,
            None => FutureCategories::default(),
        };
        Ok(ThreeDFrontLoader {
            root: root.to_path_buf(),
            models: models.map(Path::to_path_buf),
            categories,
            mapping_path,
            room_types: FrontRoomTypes::builtin(),
            flags: FlagTable::builtin(),
        })
    }

    /// The 3D-FUTURE category table in use, if one was found.
    #[cfg(feature = "internals")]
    pub fn mapping_path(&self) -> Option<&Path> {
        self.mapping_path.as_deref()
    }

    /// The 3D-FUTURE categories in use (empty without a table).
    #[cfg(feature = "internals")]
    pub fn categories(&self) -> &FutureCategories {
        &self.categories
    }

    /// Loads a scene from the bytes of its file; `path` names it in messages and `id` is the
    /// scene id. Reads no file except 3D-FUTURE meshes under the model folder.
    pub fn load_bytes(
        &self,
        id: &str,
        path: &Path,
        bytes: &[u8],
    ) -> Result<LoadedScene, LoadError> {
        let json = json::FrontJson::parse(bytes).map_err(|m| LoadError::parse(path, m))?;
        assemble::assemble(
            &json,
            &assemble::Inputs {
                path,
                id,
                models: self.models.as_deref(),
                categories: &self.categories,
                room_types: &self.room_types,
                flags: &self.flags,
            },
        )
    }
}

/// Parses one scene file's bytes without a model folder or category table (furniture as boxes,
/// categories from the file only). `path` names the file in messages; `id` is the scene id.
#[cfg(feature = "internals")]
pub fn parse_scene(bytes: &[u8], path: &Path, id: &str) -> Result<LoadedScene, LoadError> {
    ThreeDFrontLoader {
        root: PathBuf::new(),
        models: None,
        categories: FutureCategories::default(),
        mapping_path: None,
        room_types: FrontRoomTypes::builtin(),
        flags: FlagTable::builtin(),
    }
    .load_bytes(id, path, bytes)
}

impl DatasetLoader for ThreeDFrontLoader {
    fn dataset(&self) -> Dataset {
        Dataset::ThreeDFront
    }
    /// Every `*.json` file directly in the root (except `model_info.json`), id = file stem,
    /// sorted by id.
    fn discover(&self) -> Result<Vec<SceneEntry>, LoadError> {
        let entries = std::fs::read_dir(&self.root).map_err(|source| LoadError::Io(FileError::new(self.root.clone(), source)))?;
        let mut scenes = Vec::new();
        for e in entries.flatten() {
            let path = e.path();
            let is_json = path
                .extension()
                .is_some_and(|x| x.eq_ignore_ascii_case("json"));
            let name = e.file_name().to_string_lossy().into_owned();
            if !is_json || name.starts_with('.') || name == "model_info.json" || !path.is_file() {
                continue;
            }
            if let Some(stem) = path.file_stem() {
                scenes.push(SceneEntry {
                    id: stem.to_string_lossy().into_owned(),
                    path,
                });
            }
        }
        scenes.sort();
        Ok(scenes)
    }
    /// Loads one scene file. Every failure names the file and the record.
    fn load(&self, entry: &SceneEntry) -> Result<LoadedScene, LoadError> {
        let bytes = std::fs::read(&entry.path).map_err(|source| LoadError::Io(FileError::new(entry.path.clone(), source)))?;
        let mut loaded = self.load_bytes(&entry.id, &entry.path, &bytes)?;
        if let Some(m) = &self.mapping_path {
            loaded.sources.push(m.clone());
        }
        Ok(loaded)
    }
    fn scene_layout(&self) -> &'static str {
        "<scene uid>.json files (model_info.json aside)"
    }
    fn root_warning(&self) -> Option<String> {
        let mut remarks = Vec::new();
        if self.mapping_path.is_none() {
            remarks.push(
                "no 3D-FUTURE category table (model_info.json or *ModelCategoryMapping.csv): \
                 objects get no super-category (give a category mapping file)",
            );
        }
        if self.models.is_none() {
            remarks.push("no 3D-FUTURE model folder: furniture are oriented boxes");
        }
        (!remarks.is_empty()).then(|| format!("{}: {}", self.root.display(), remarks.join("; ")))
    }
}

/// The first category table in the usual places (see the module docs).
fn find_mapping(root: &Path, models: Option<&Path>) -> Option<PathBuf> {
    let mut dirs: Vec<PathBuf> = Vec::new();
    if let Some(m) = models {
        dirs.push(m.to_path_buf());
        dirs.push(m.join("metadata"));
    }
    dirs.push(root.to_path_buf());
    dirs.push(root.join("metadata"));
    if let Some(parent) = root.parent() {
        dirs.push(parent.join("metadata"));
    }
    dirs.into_iter().find_map(|dir| {
        let info = dir.join("model_info.json");
        if info.is_file() {
            return Some(info);
        }
        let mut found: Vec<PathBuf> = std::fs::read_dir(&dir)
            .ok()?
            .flatten()
            .map(|e| e.path())
            .filter(|p| {
                p.is_file()
                    && p.file_name()
                        .is_some_and(|n| n.to_string_lossy().ends_with("ModelCategoryMapping.csv"))
            })
            .collect();
        found.sort();
        found.into_iter().next()
    })
}

/// Reads a category table: JSON (`model_info.json`) by extension, CSV otherwise.
fn read_categories(path: &Path) -> Result<FutureCategories, LoadError> {
    let text = std::fs::read_to_string(path).map_err(|source| LoadError::Io(FileError::new(path, source)))?;
    let is_json = path
        .extension()
        .is_some_and(|x| x.eq_ignore_ascii_case("json"));
    let parsed = if is_json {
        FutureCategories::parse_model_info(&text)
    } else {
        FutureCategories::parse_csv(&text)
    };
    parsed.map_err(|m| LoadError::parse(path, m))
}
