//! The DATA folder: compiled scenes, the manifest, variants and their statistics, splits and
//! navigation grids, behind one type, [`DataDir`], which owns every path and lookup.
//!
//! ```text
//! DATA/houses.parquet            manifest, one row per scene (errors included)
//! DATA/scenes/<scene>.mscene     compiled scenes
//! DATA/splits/<name>/{train,val,test}.txt
//! DATA/variants/<name>.toml      variant descriptions (applied on load)
//! DATA/stats/materials.json      material statistics retexturing draws from
//! DATA/nav/<scene>[@variant].nav navigation grids, and their .L<n>.png previews
//! ```
//!
//! Algorithms never see this module: the batch drivers (`crate::pipeline`) and the command
//! line read scenes and grids through a [`DataDir`] and hand them over.

mod grids;
pub mod manifest;
internal! {
    pub mod provenance;
}
pub mod remedy;
pub mod scene_file;
mod variants;

use std::path::{Path, PathBuf};

use crate::lock::{DirLock, LockError, LockMode};
use crate::scene::SceneRef;

use manifest::{ManifestError, ManifestRow};
use scene_file::SceneFileError;
pub use variants::StoreError;

/// File name of the manifest in a DATA folder.
pub const MANIFEST_FILE: &str = "houses.parquet";

/// A DATA folder: where everything `ingest`, `split`, `variants` and `bake` write lives, and
/// the one place that knows its layout.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DataDir {
    root: PathBuf,
}

impl DataDir {
    /// The DATA folder at `root` (nothing is read or created).
    pub fn new(root: impl Into<PathBuf>) -> Self {
        DataDir { root: root.into() }
    }

    /// The folder itself.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// `DATA/houses.parquet`.
    pub fn manifest_path(&self) -> PathBuf {
        self.root.join(MANIFEST_FILE)
    }

    /// `DATA/scenes/`.
    pub fn scenes_dir(&self) -> PathBuf {
        self.root.join("scenes")
    }

    /// `DATA/scenes/<id>.mscene`: scene `id`'s compiled file.
    pub fn scene_path(&self, id: &str) -> PathBuf {
        self.scenes_dir()
            .join(format!("{id}.{}", scene_file::EXTENSION))
    }

    /// `DATA/nav/`.
    pub fn nav_dir(&self) -> PathBuf {
        self.root.join("nav")
    }

    /// `DATA/nav/<scene>[@variant].nav`: where the grid baked for `scene` itself lives (see
    /// [`DataDir::grid_ref`] for the grid that serves it).
    pub fn nav_path(&self, scene: &SceneRef) -> PathBuf {
        self.nav_dir().join(format!("{scene}.nav"))
    }

    /// `DATA/variants/`.
    pub fn variants_dir(&self) -> PathBuf {
        self.root.join("variants")
    }

    /// `DATA/variants/<name>.toml`.
    pub fn variant_path(&self, name: &str) -> PathBuf {
        self.variants_dir().join(format!("{name}.toml"))
    }

    /// `DATA/stats/`.
    pub fn stats_dir(&self) -> PathBuf {
        self.root.join("stats")
    }

    /// `DATA/stats/materials.json`.
    pub fn material_stats_path(&self) -> PathBuf {
        self.stats_dir().join("materials.json")
    }

    /// `DATA/splits/`.
    pub fn splits_dir(&self) -> PathBuf {
        self.root.join("splits")
    }

    /// `DATA/splits/<name>/`, or `None` when `name` is not a plain folder name (so a split
    /// can never be read or written outside `DATA/splits/`).
    pub fn split_dir(&self, name: &str) -> Option<PathBuf> {
        let plain = !name.is_empty()
            && name != "."
            && name != ".."
            && !name.contains(['/', '\\'])
            && !name.chars().any(char::is_control);
        plain.then(|| self.splits_dir().join(name))
    }

    /// Takes the folder's writer lock (`DATA/.minos.lock`, the folder created if missing) for
    /// `command`; every command that writes the folder holds it until it ends, and readers
    /// never take it (see [`crate::lock`]).
    pub fn lock(&self, command: &str, mode: LockMode) -> Result<DirLock, LockError> {
        DirLock::acquire(&self.root, command, mode)
    }

    /// Takes the folder's writer lock shared with the other shards of a sharded command
    /// (`bake --shard`), which write disjoint files; exclusive writers wait for all of them
    /// (see [`DirLock::acquire_shared`]).
    pub fn lock_shared(&self, mode: LockMode) -> Result<DirLock, LockError> {
        DirLock::acquire_shared(&self.root, mode)
    }

    /// Every row of the manifest.
    pub fn read_manifest(&self) -> Result<Vec<ManifestRow>, ManifestError> {
        manifest::read_manifest(&self.manifest_path())
    }

    /// Every row of the manifest of a folder scenes were ingested into: a folder without a
    /// readable manifest is [`StoreError::NoManifest`] (nothing ingested yet).
    pub fn ingested_rows(&self) -> Result<Vec<ManifestRow>, StoreError> {
        self.read_manifest()
            .map_err(|source| StoreError::NoManifest {
                path: self.manifest_path(),
                source,
            })
    }

    /// Ids of the scenes `minos ingest` compiled without error, in manifest order.
    pub fn ingested_ids(&self) -> Result<Vec<String>, StoreError> {
        Ok(self
            .ingested_rows()?
            .into_iter()
            .filter(|r| r.error.is_none())
            .map(|r| r.id)
            .collect())
    }

    /// References to variant `variant` of each scene of `ids` (replacing any variant they
    /// name), after checking that the variant is defined; without a variant, the scenes
    /// themselves.
    pub fn refs(&self, ids: &[String], variant: Option<&str>) -> Result<Vec<SceneRef>, StoreError> {
        if let Some(name) = variant {
            self.read_variant(name)?;
        }
        Ok(ids
            .iter()
            .map(|id| match variant {
                Some(name) => SceneRef::parse(id).with_variant(Some(name)),
                None => SceneRef::parse(id),
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_follow_the_documented_layout() {
        let data = DataDir::new("/d");
        let v = SceneRef::parse("h1@empty");
        assert_eq!(data.manifest_path(), Path::new("/d/houses.parquet"));
        assert_eq!(data.scene_path("h1"), Path::new("/d/scenes/h1.mscene"));
        assert_eq!(data.nav_path(&v), Path::new("/d/nav/h1@empty.nav"));
        assert_eq!(
            data.variant_path("empty"),
            Path::new("/d/variants/empty.toml")
        );
        assert_eq!(
            data.material_stats_path(),
            Path::new("/d/stats/materials.json")
        );
        assert_eq!(data.split_dir("a"), Some(PathBuf::from("/d/splits/a")));
        for bad in ["", ".", "..", "../x", "a/b", "a\\b", "a\nb"] {
            assert_eq!(data.split_dir(bad), None, "{bad:?}");
        }
    }
}
