//! Variants over many scenes: the material statistics retexturing draws from, a dry run
//! that applies a variant to every scene without writing anything, and [`define_variants`],
//! the driver `minos variants` and Python's `minos.variants` call.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::atomic::sweep_stale;
use crate::invalid::{read_settings, Invalid, SettingsFileError};
use crate::lock::{LockError, LockMode};
use crate::progress::Progress;
use crate::scene::variants::DEFAULT_FRACTIONS;
use crate::scene::variants::{
    apply_variant, parse_spec_file, validate_name, MaterialStats, MaterialStatsBuilder, TextureSet,
    VariantError, VariantReport, VariantSpec,
};
use crate::scene::Scene;
use crate::store::provenance::write_data_record;
use crate::store::scene_file::SceneFileError;
use crate::store::{DataDir, StoreError};

/// Computes material statistics over the compiled scenes `ids` (in parallel; the result does
/// not depend on the order or thread count). Scenes that cannot be read are returned with
/// their error and left out.
pub fn collect_stats(
    data: &DataDir,
    ids: &[String],
    partition_seed: u64,
    fractions: [f64; 2],
    progress: &dyn Progress,
) -> (MaterialStats, Vec<(String, String)>) {
    progress.set_total(ids.len() as u64);
    let mut builder = MaterialStatsBuilder::default();
    let mut failures = Vec::new();
    // Chunks bound how many scenes are held at once.
    for chunk in ids.chunks(64) {
        let loaded: Vec<(String, Result<Scene, SceneFileError>)> = chunk
            .par_iter()
            .map(|id| {
                let r = data.read_scene(id).map(|(_, s)| s);
                progress.advance(1);
                (id.clone(), r)
            })
            .collect();
        for (id, r) in loaded {
            match r {
                Ok(scene) => builder.add(&scene),
                Err(e) => failures.push((id, crate::escape::error_line(&e))),
            }
        }
    }
    (builder.finish(partition_seed, fractions), failures)
}

/// Why a variant's dry run failed on a scene.
#[derive(Debug, thiserror::Error)]
pub enum DryRunError {
    /// The scene could not be read.
    #[error(transparent)]
    Read(SceneFileError),
    /// The variant could not be applied to it.
    #[error(transparent)]
    Apply(VariantError),
}

/// Applies variant `name` to every scene of `ids` without writing anything, to report what it
/// does (and to find scenes it cannot be applied to).
pub fn dry_run(
    data: &DataDir,
    ids: &[String],
    name: &str,
    spec: &VariantSpec,
    stats: Option<&MaterialStats>,
    progress: &dyn Progress,
) -> Vec<(String, Result<VariantReport, DryRunError>)> {
    progress.set_total(ids.len() as u64);
    ids.par_iter()
        .map(|id| {
            let r = data
                .read_scene(id)
                .map_err(DryRunError::Read)
                .and_then(|(_, mut scene)| {
                    apply_variant(&mut scene, name, spec, stats).map_err(DryRunError::Apply)
                });
            progress.advance(1);
            (id.clone(), r)
        })
        .collect()
}

/// Reads a spec file of named variants (one TOML table per variant, by name).
pub fn read_spec_file(path: &Path) -> Result<Vec<(String, VariantSpec)>, SettingsFileError> {
    read_settings(path, parse_spec_file)
}

/// Variants to define in a DATA folder.
#[derive(Debug, Clone)]
pub struct VariantsJob {
    /// The DATA folder (its scenes must be ingested).
    pub data: DataDir,
    /// The variants, by name, in order.
    pub variants: Vec<(String, VariantSpec)>,
    /// Recompute the material statistics even when they exist.
    pub refresh_stats: bool,
    /// Seed of the train/val/test partition of materials, when the statistics are computed.
    pub partition_seed: u64,
}

/// Material statistics computed by [`define_variants`].
#[derive(Debug, Clone)]
pub struct StatsSummary {
    /// Where they were written.
    pub path: PathBuf,
    /// Scenes they were computed over.
    pub scenes: usize,
    /// Materials observed.
    pub materials: usize,
    /// Categories with materials.
    pub categories: usize,
    /// Materials in each texture set, in [`TextureSet::ALL`]'s order.
    pub per_set: [usize; 3],
    /// Scenes left out (they could not be read), with the reason.
    pub left_out: Vec<(String, String)>,
}

/// What one variant does to the DATA folder's scenes (from a dry run over all of them).
#[derive(Debug, Clone)]
pub struct VariantSummary {
    /// The variant's name.
    pub name: String,
    /// Its definition's file, `DATA/variants/<name>.toml`.
    pub path: PathBuf,
    /// Scenes it was tried on.
    pub scenes: usize,
    /// Objects removed over all scenes.
    pub removed: usize,
    /// Doors swapped to their counterpart model.
    pub swapped: usize,
    /// Doors opened by clearing them.
    pub cleared: usize,
    /// Material slots given a drawn material.
    pub redrawn: usize,
    /// Material slots kept (no material of their category in the set).
    pub kept: usize,
    /// Whether it changes doors, or retextures (so a report says what it counted).
    pub changes_doors: bool,
    /// Whether it retextures.
    pub retextures: bool,
    /// Whether it changes geometry (its scenes need their own grids) or only appearance.
    pub changes_geometry: bool,
    /// Scenes it cannot be applied to, with the reason.
    pub failures: Vec<(String, String)>,
    /// Per-door entries that matched no door, by scene.
    pub unmatched: Vec<(String, String)>,
}

/// What [`define_variants`] did.
#[derive(Debug, Clone, Default)]
pub struct VariantsReport {
    /// The material statistics, when they were computed now.
    pub stats: Option<StatsSummary>,
    /// One summary per variant, in the job's order.
    pub variants: Vec<VariantSummary>,
}

impl VariantsReport {
    /// Whether some variant could not be applied to some scene.
    pub fn any_failed(&self) -> bool {
        self.variants.iter().any(|v| !v.failures.is_empty())
    }
}

/// Why variants could not be defined.
#[derive(Debug, thiserror::Error)]
pub enum VariantsError {
    /// A variant's definition is not valid.
    #[error("variant {name}")]
    Spec {
        /// The variant.
        name: String,
        /// What is wrong.
        #[source]
        source: Invalid,
    },
    /// A variant changes nothing (every field at its default): it would be a copy of its
    /// scenes under another name.
    #[error("variant {name}: no change given")]
    NoChange {
        /// The variant.
        name: String,
    },
    /// The DATA folder has no readable manifest.
    #[error("nothing ingested")]
    NoManifest(#[source] StoreError),
    /// The DATA folder's lock could not be taken.
    #[error("the DATA folder's lock")]
    Lock(#[source] LockError),
    /// Temporary files a killed writer left could not be removed.
    #[error("{}: removing stale temporary files", path.display())]
    Sweep {
        /// The folder.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The material statistics, a variant's definition or the provenance record could not
    /// be read or written.
    #[error("writing the DATA folder")]
    Store(#[source] StoreError),
    /// The DATA folder's provenance record could not be written.
    #[error("the DATA folder's provenance record")]
    Provenance(#[source] crate::file_error::FileError),
}

/// Does not pass a stage's total on: the driver announces the whole work once.
struct Continued<'a>(&'a dyn Progress);

impl Progress for Continued<'_> {
    fn advance(&self, n: u64) {
        self.0.advance(n);
    }
}

/// Defines `job.variants` in the DATA folder under its writer lock (`mode` says whether to
/// wait for another writer): computes the material statistics first when a variant
/// retextures and none exist (or `refresh_stats`), dry-runs each variant over every ingested
/// scene to report what it does, writes each definition to `DATA/variants/<name>.toml`, and
/// rewrites the folder's provenance record. A scene a variant cannot be applied to is
/// reported, not fatal. Progress counts one unit per scene per stage.
pub fn define_variants(
    job: &VariantsJob,
    mode: LockMode,
    progress: &dyn Progress,
) -> Result<VariantsReport, VariantsError> {
    for (name, spec) in &job.variants {
        validate_name(name)
            .and_then(|()| spec.validate())
            .map_err(|source| VariantsError::Spec {
                name: name.clone(),
                source,
            })?;
        if *spec == VariantSpec::default() {
            return Err(VariantsError::NoChange { name: name.clone() });
        }
    }
    let data = &job.data;
    let ids = data.ingested_ids().map_err(VariantsError::NoManifest)?;
    // Taken once DATA is known to hold a manifest, so a wrong folder is left as it was.
    let _lock = data.lock("variants", mode).map_err(VariantsError::Lock)?;
    for dir in [data.variants_dir(), data.stats_dir()] {
        sweep_stale(&dir).map_err(|source| VariantsError::Sweep { path: dir, source })?;
    }
    let needs_stats = job.variants.iter().any(|(_, s)| s.retexture.is_some());
    let existing = if job.refresh_stats || !needs_stats {
        None
    } else {
        data.read_material_stats().ok()
    };
    let compute = job.refresh_stats || (needs_stats && existing.is_none());
    let stages = job.variants.len() + usize::from(compute);
    progress.set_total((ids.len() * stages) as u64);
    let progress = Continued(progress);
    let mut report = VariantsReport::default();
    let stats = if compute {
        let (stats, left_out) =
            collect_stats(data, &ids, job.partition_seed, DEFAULT_FRACTIONS, &progress);
        let path = data
            .write_material_stats(&stats)
            .map_err(VariantsError::Store)?;
        let per_set =
            TextureSet::ALL.map(|set| stats.materials.iter().filter(|m| m.set == set).count());
        report.stats = Some(StatsSummary {
            path,
            scenes: stats.scenes.len(),
            materials: stats.materials.len(),
            categories: stats.categories.len(),
            per_set,
            left_out,
        });
        Some(stats)
    } else {
        existing
    };
    for (name, spec) in &job.variants {
        let runs = dry_run(data, &ids, name, spec, stats.as_ref(), &progress);
        let mut v = VariantSummary {
            name: name.clone(),
            path: PathBuf::new(),
            scenes: runs.len(),
            removed: 0,
            swapped: 0,
            cleared: 0,
            redrawn: 0,
            kept: 0,
            changes_doors: spec.open_doors || !spec.doors.is_empty(),
            retextures: spec.retexture.is_some(),
            changes_geometry: spec.changes_geometry(),
            failures: Vec::new(),
            unmatched: Vec::new(),
        };
        for (id, run) in runs {
            match run {
                Ok(r) => {
                    v.removed += r.removed;
                    v.swapped += r.doors.swapped;
                    v.cleared += r.doors.cleared;
                    if let Some(t) = r.retexture {
                        v.redrawn += t.redrawn;
                        v.kept += t.kept;
                    }
                    v.unmatched
                        .extend(r.doors.unmatched.into_iter().map(|w| (id.clone(), w)));
                }
                Err(e) => v.failures.push((id, crate::escape::error_line(&e))),
            }
        }
        v.path = data
            .write_variant(name, spec)
            .map_err(VariantsError::Store)?;
        report.variants.push(v);
    }
    write_data_record(data).map_err(VariantsError::Provenance)?;
    Ok(report)
}
