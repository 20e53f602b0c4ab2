//! Variants on disk: `DATA/variants/<name>.toml` (one variant's description),
//! `DATA/stats/materials.json` (the material statistics retexturing draws from), and
//! [`load_scene`], which reads a compiled scene and applies a variant named in its reference
//! (`<scene>@<variant>`). Every command that takes `--variant` loads scenes through here.

use std::path::{Path, PathBuf};
use std::time::SystemTime;

use crate::io::atomic::write_bytes_atomic;
use crate::io::scene_file::{read_scene, scene_path, SceneFileError};
use crate::scene::variants::{
    apply_variant, split_ref, validate_name, MaterialStats, MaterialStatsBuilder, VariantError,
    VariantReport, VariantSpec,
};
use crate::scene::Scene;

/// Errors reading, writing or applying variants.
#[derive(Debug, thiserror::Error)]
pub enum VariantStoreError {
    /// File system error.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A file that does not parse or is inconsistent.
    #[error("{path}: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A variant name that cannot be used.
    #[error("{0}")]
    Name(String),
    /// The compiled scene could not be read.
    #[error(transparent)]
    Scene(#[from] SceneFileError),
    /// The variant could not be applied.
    #[error(transparent)]
    Apply(#[from] VariantError),
}

/// Where variant `name` is described.
pub fn variant_path(data: &Path, name: &str) -> PathBuf {
    data.join("variants").join(format!("{name}.toml"))
}

/// Where the material statistics live.
pub fn stats_path(data: &Path) -> PathBuf {
    data.join("stats").join("materials.json")
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> VariantStoreError + '_ {
    move |source| VariantStoreError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes variant `name` atomically.
pub fn write_variant(
    data: &Path,
    name: &str,
    spec: &VariantSpec,
) -> Result<PathBuf, VariantStoreError> {
    validate_name(name).map_err(VariantStoreError::Name)?;
    let path = variant_path(data, name);
    let text = format!(
        "# minos variant `{name}` (scene ids `<scene>@{name}`); written by `minos variants`.\n{}",
        spec.to_toml()
    );
    write_bytes_atomic(&path, text.as_bytes()).map_err(io_err(&path))?;
    Ok(path)
}

/// Reads variant `name`.
pub fn read_variant(data: &Path, name: &str) -> Result<VariantSpec, VariantStoreError> {
    validate_name(name).map_err(VariantStoreError::Name)?;
    let path = variant_path(data, name);
    let text = std::fs::read_to_string(&path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => VariantStoreError::Format {
            path: path.clone(),
            message: format!("no variant `{name}` (define it with `minos variants`)"),
        },
        _ => VariantStoreError::Io {
            path: path.clone(),
            source: e,
        },
    })?;
    VariantSpec::from_toml(&text).map_err(|message| VariantStoreError::Format { path, message })
}

/// The names of every variant defined in `data`, sorted.
pub fn list_variants(data: &Path) -> Vec<String> {
    let Ok(dir) = std::fs::read_dir(data.join("variants")) else {
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
pub fn write_stats(data: &Path, stats: &MaterialStats) -> Result<PathBuf, VariantStoreError> {
    let path = stats_path(data);
    let text = serde_json::to_string_pretty(stats).map_err(|e| VariantStoreError::Format {
        path: path.clone(),
        message: e.to_string(),
    })?;
    write_bytes_atomic(&path, text.as_bytes()).map_err(io_err(&path))?;
    Ok(path)
}

/// Reads the material statistics.
pub fn read_stats(data: &Path) -> Result<MaterialStats, VariantStoreError> {
    let path = stats_path(data);
    let text = std::fs::read_to_string(&path).map_err(io_err(&path))?;
    let stats: MaterialStats =
        serde_json::from_str(&text).map_err(|e| VariantStoreError::Format {
            path: path.clone(),
            message: e.to_string(),
        })?;
    stats
        .validate()
        .map_err(|message| VariantStoreError::Format { path, message })?;
    Ok(stats)
}

/// Loads scene `scene_ref` (`<scene>` or `<scene>@<variant>`) from `data`, applying the variant.
pub fn load_scene(
    data: &Path,
    scene_ref: &str,
) -> Result<(Scene, Option<VariantReport>), VariantStoreError> {
    let (id, variant) = split_ref(scene_ref);
    let (_, mut scene) = read_scene(&scene_path(data, id))?;
    let Some(name) = variant else {
        return Ok((scene, None));
    };
    let spec = read_variant(data, name)?;
    let stats = match spec.retexture {
        Some(_) => Some(read_stats(data)?),
        None => None,
    };
    let report = apply_variant(&mut scene, name, &spec, stats.as_ref())?;
    Ok((scene, Some(report)))
}

/// The files `scene_ref` is made from: the compiled scene, and for a variant its description
/// (and the statistics when it retextures). Outputs older than any of them are stale.
pub fn inputs_of(data: &Path, scene_ref: &str) -> Vec<PathBuf> {
    let (id, variant) = split_ref(scene_ref);
    let mut files = vec![scene_path(data, id)];
    if let Some(name) = variant {
        files.push(variant_path(data, name));
        if read_variant(data, name).is_ok_and(|s| s.retexture.is_some()) {
            files.push(stats_path(data));
        }
    }
    files
}

/// The newest modification time of [`inputs_of`], or `None` when one is missing.
pub fn newest_input(data: &Path, scene_ref: &str) -> Option<SystemTime> {
    inputs_of(data, scene_ref)
        .iter()
        .map(|p| std::fs::metadata(p).and_then(|m| m.modified()).ok())
        .try_fold(SystemTime::UNIX_EPOCH, |acc, t| t.map(|t| acc.max(t)))
}

/// The scene reference whose navigation grid serves `scene_ref`: itself, except for a variant
/// that keeps the geometry (retexture only) and has no grid of its own, which shares its
/// scene's grid. Commands look grids up through this, so a retextured variant needs no bake.
pub fn grid_ref(data: &Path, scene_ref: &str) -> String {
    let (id, variant) = split_ref(scene_ref);
    let Some(name) = variant else {
        return scene_ref.to_string();
    };
    let own = crate::navmesh::file::nav_path(data, scene_ref);
    let keeps_geometry = read_variant(data, name).is_ok_and(|s| !s.changes_geometry());
    if keeps_geometry && !own.is_file() {
        id.to_string()
    } else {
        scene_ref.to_string()
    }
}

/// Computes material statistics over the compiled scenes `ids` (in parallel; the result does
/// not depend on the order or thread count). Scenes that cannot be read are returned with
/// their error and left out.
pub fn collect_stats(
    data: &Path,
    ids: &[String],
    partition_seed: u64,
    fractions: [f64; 2],
    progress: &dyn crate::progress::Progress,
) -> (MaterialStats, Vec<(String, String)>) {
    use rayon::prelude::*;
    progress.set_total(ids.len() as u64);
    let mut builder = MaterialStatsBuilder::default();
    let mut failures = Vec::new();
    // Chunks bound how many scenes are held at once.
    for chunk in ids.chunks(64) {
        let loaded: Vec<(String, Result<Scene, String>)> = chunk
            .par_iter()
            .map(|id| {
                let r = read_scene(&scene_path(data, id))
                    .map(|(_, s)| s)
                    .map_err(|e| e.to_string());
                progress.advance(1);
                (id.clone(), r)
            })
            .collect();
        for (id, r) in loaded {
            match r {
                Ok(scene) => builder.add(&scene),
                Err(e) => failures.push((id, e)),
            }
        }
    }
    (builder.finish(partition_seed, fractions), failures)
}

/// Applies variant `name` to every scene of `ids` without writing anything, to report what it
/// does (and to find scenes it cannot be applied to).
pub fn dry_run(
    data: &Path,
    ids: &[String],
    name: &str,
    spec: &VariantSpec,
    stats: Option<&MaterialStats>,
    progress: &dyn crate::progress::Progress,
) -> Vec<(String, Result<VariantReport, String>)> {
    use rayon::prelude::*;
    progress.set_total(ids.len() as u64);
    ids.par_iter()
        .map(|id| {
            let r = read_scene(&scene_path(data, id))
                .map_err(|e| e.to_string())
                .and_then(|(_, mut scene)| {
                    apply_variant(&mut scene, name, spec, stats).map_err(|e| e.to_string())
                });
            progress.advance(1);
            (id.clone(), r)
        })
        .collect()
}
