//! Scenes and variants in a DATA folder: `DATA/variants/<name>.toml` (one variant's
//! description), `DATA/stats/materials.json` (the material statistics retexturing draws
//! from), and [`DataDir::load_scene`], which reads a compiled scene and applies the variant its
//! reference names (`<scene>@<variant>`): the one way every command loads a scene.

use crate::file_error::FileError;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use super::manifest::ManifestError;
use super::scene_file::{read_scene, SceneFileError, SceneHeader};
use super::DataDir;
use crate::atomic::write_bytes_atomic;
use crate::invalid::SettingsCause;
use crate::navmesh::file::NavFileError;
use crate::scene::variants::{
    apply_variant, validate_name, MaterialStats, VariantError, VariantReport, VariantSpec,
};
use crate::scene::{Scene, SceneRef};

/// Errors reading or writing a DATA folder: its files, variants and grids.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// File system error.
    #[error(transparent)]
    Io(#[from] FileError),
    /// A variant or statistics file that does not parse or breaks a rule.
    #[error("{path}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong (the TOML or JSON parser's error, or the rule).
        #[source]
        source: SettingsCause,
    },
    /// A variant name that cannot be used.
    #[error(transparent)]
    Name(crate::invalid::Invalid),
    /// The compiled scene could not be read.
    #[error("{0}")]
    Scene(#[from] SceneFileError),
    /// The variant could not be applied.
    #[error(transparent)]
    Apply(#[from] VariantError),
    /// The manifest could not be read or written.
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    /// A navigation grid could not be read.
    #[error("{0}")]
    Grid(#[from] NavFileError),
    /// The DATA folder has no readable manifest: nothing was ingested into it.
    #[error("{}: cannot read the manifest", path.display())]
    NoManifest {
        /// The manifest.
        path: PathBuf,
        /// Why.
        source: ManifestError,
    },
    /// The DATA folder does not define the variant.
    #[error("{}: no variant `{name}`", path.display())]
    NoVariant {
        /// The variant's name.
        name: String,
        /// Where its definition would be.
        path: PathBuf,
    },
    /// The material statistics are of another format version.
    #[error("{}: version {version} (this minos reads {expected})", path.display())]
    StaleStats {
        /// The statistics file.
        path: PathBuf,
        /// Its version.
        version: u32,
        /// The version this minos reads.
        expected: u32,
    },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> StoreError + '_ {
    move |source| StoreError::Io(FileError::new(path, source))
}

impl DataDir {
    /// Reads scene `id`'s compiled file (without applying any variant).
    pub fn read_scene(&self, id: &str) -> Result<(SceneHeader, Scene), SceneFileError> {
        read_scene(&self.scene_path(id))
    }

    /// Writes variant `name` atomically.
    pub fn write_variant(&self, name: &str, spec: &VariantSpec) -> Result<PathBuf, StoreError> {
        validate_name(name).map_err(StoreError::Name)?;
        let path = self.variant_path(name);
        let text = format!(
        "# minos variant `{name}` (scene ids `<scene>@{name}`); written by `minos variants`.\n{}",
        spec.to_toml()
    );
        write_bytes_atomic(&path, text.as_bytes()).map_err(io_err(&path))?;
        Ok(path)
    }

    /// Reads variant `name`.
    pub fn read_variant(&self, name: &str) -> Result<VariantSpec, StoreError> {
        validate_name(name).map_err(StoreError::Name)?;
        let path = self.variant_path(name);
        let text = std::fs::read_to_string(&path).map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => StoreError::NoVariant {
                name: name.to_string(),
                path: path.clone(),
            },
            _ => StoreError::Io(FileError::new(path.clone(), e)),
        })?;
        VariantSpec::from_toml(&text).map_err(|source| StoreError::Format { path, source })
    }

    /// The names of every variant defined in `data`, sorted.
    pub fn list_variants(&self) -> Vec<String> {
        let Ok(dir) = std::fs::read_dir(self.variants_dir()) else {
            return Vec::new();
        };
        let mut names: Vec<String> = dir
            .filter_map(|e| e.ok())
            .filter_map(|e| {
                let p = e.path();
                (p.extension()? == "toml").then(|| p.file_stem()?.to_str().map(String::from))?
            })
            .collect();
        names.sort();
        names
    }

    /// Writes the material statistics atomically.
    pub fn write_material_stats(&self, stats: &MaterialStats) -> Result<PathBuf, StoreError> {
        let path = self.material_stats_path();
        let text = serde_json::to_string_pretty(stats).map_err(|e| StoreError::Format {
            path: path.clone(),
            source: e.into(),
        })?;
        write_bytes_atomic(&path, text.as_bytes()).map_err(io_err(&path))?;
        Ok(path)
    }

    /// Reads the material statistics.
    pub fn read_material_stats(&self) -> Result<MaterialStats, StoreError> {
        let path = self.material_stats_path();
        let text = std::fs::read_to_string(&path).map_err(io_err(&path))?;
        let stats: MaterialStats = serde_json::from_str(&text).map_err(|e| StoreError::Format {
            path: path.clone(),
            source: e.into(),
        })?;
        if stats.version != crate::scene::variants::STATS_VERSION {
            return Err(StoreError::StaleStats {
                path,
                version: stats.version,
                expected: crate::scene::variants::STATS_VERSION,
            });
        }
        stats.validate().map_err(|e| StoreError::Format {
            path,
            source: e.into(),
        })?;
        Ok(stats)
    }

    /// Loads scene `scene_ref` (`<scene>` or `<scene>@<variant>`) from `data`, applying the variant.
    pub fn load_scene(
        &self,
        scene_ref: &SceneRef,
    ) -> Result<(Scene, Option<VariantReport>), StoreError> {
        let (_, mut scene) = self.read_scene(&scene_ref.scene)?;
        let Some(name) = scene_ref.variant.as_deref() else {
            return Ok((scene, None));
        };
        let spec = self.read_variant(name)?;
        let stats = match spec.retexture {
            Some(_) => Some(self.read_material_stats()?),
            None => None,
        };
        let report = apply_variant(&mut scene, name, &spec, stats.as_ref())?;
        Ok((scene, Some(report)))
    }

    /// The files `scene_ref` is made from: the compiled scene, and for a variant its description
    /// (and the statistics when it retextures). Outputs older than any of them are stale.
    pub fn inputs_of(&self, scene_ref: &SceneRef) -> Vec<PathBuf> {
        let mut files = vec![self.scene_path(&scene_ref.scene)];
        if let Some(name) = scene_ref.variant.as_deref() {
            files.push(self.variant_path(name));
            if self.read_variant(name).is_ok_and(|s| s.retexture.is_some()) {
                files.push(self.material_stats_path());
            }
        }
        files
    }

    /// The newest modification time of [`Self::inputs_of`], or `None` when one is missing.
    pub fn newest_input(&self, scene_ref: &SceneRef) -> Option<SystemTime> {
        self.inputs_of(scene_ref)
            .iter()
            .map(|p| std::fs::metadata(p).and_then(|m| m.modified()).ok())
            .try_fold(SystemTime::UNIX_EPOCH, |acc, t| t.map(|t| acc.max(t)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_broken_variant_file_names_it_and_keeps_the_parsers_error() {
        let dir = tempfile::tempdir().expect("tempdir");
        let data = DataDir::new(dir.path());
        let path = data.variant_path("bare");
        std::fs::create_dir_all(path.parent().expect("a folder")).expect("variants folder");
        std::fs::write(&path, "empty = true\nremove = [\n").expect("write");
        let e = data.read_variant("bare").expect_err("broken TOML");
        let StoreError::Format { path: p, source } = &e else {
            panic!("not a format error: {e:?}");
        };
        assert_eq!(p, &path);
        let SettingsCause::Toml(t) = source else {
            panic!("not a TOML error: {source:?}");
        };
        assert!(t.line.is_some(), "{t}");
        let line = crate::escape::error_line(&e);
        assert!(
            line.starts_with(&format!("{}: line ", path.display())),
            "{line}"
        );
        // A rule broken, not the syntax: the rule, as the cause.
        std::fs::write(&path, "clutter = 1\n").expect("write");
        let e = data.read_variant("bare").expect_err("a bad field");
        assert!(matches!(&e, StoreError::Format { .. }), "{e:?}");
    }
}
