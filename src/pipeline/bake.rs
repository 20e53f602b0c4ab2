//! Baking many scenes: load each compiled scene (applying its variant, if the id names one),
//! build its grid, write `DATA/nav/<id>.nav`
//! and its previews, in parallel. A scene that fails is reported and the others finish;
//! grids newer than their scene and baked with the same parameters are kept (and given the
//! previews a killed bake did not write). A grid or preview that cannot be written (a full
//! disk, a read-only folder) stops the batch: it is the folder's problem, not the scene's.
//! Temporary files a killed bake left in `DATA/nav/` are removed first.

use crate::file_error::FileError;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use rayon::prelude::*;

use crate::atomic::{sweep_stale, sweep_stale_where};
use crate::body::{AgentBody, AgentPreset};
use crate::invalid::{read_settings, Invalid, SettingsFileError};
use crate::lock::{LockError, LockMode};
use crate::navmesh::build::build;
use crate::navmesh::file::NavFileError;
use crate::navmesh::file::{read_nav, read_nav_params, write_nav};
use crate::navmesh::params_from_toml;
use crate::navmesh::preview::{previews_present, write_previews};
use crate::navmesh::NavParams;
use crate::progress::Progress;
use crate::scene::SceneRef;
use crate::shard::Shard;
use crate::store::DataDir;

/// How one scene's bake went.
#[derive(Debug, Clone)]
pub enum BakeOutcome {
    /// Baked now: spans, walkable spans, islands.
    Baked {
        /// Walkable spans.
        walkable: usize,
        /// Islands.
        islands: usize,
        /// The body of the grid this bake replaced, when it was baked for another body
        /// (episodes and runs made on the old grid were for that body).
        replaced_body: Option<AgentBody>,
    },
    /// Its grid was up to date.
    UpToDate,
    /// It failed: why.
    Failed(BakeFailure),
    /// Its grid or a preview could not be written (the error names the file); the batch
    /// stops baking further scenes.
    WriteFailed(BakeFailure),
    /// Not baked because a write failed for another scene first.
    Stopped,
}

/// Why a scene was not baked. Cheap to clone: the causes are shared.
#[derive(Debug, Clone, thiserror::Error)]
pub enum BakeFailure {
    /// The compiled scene (or its variant) could not be loaded.
    #[error(transparent)]
    Scene(Arc<crate::store::StoreError>),
    /// The grid could not be built.
    #[error(transparent)]
    Build(Arc<crate::navmesh::build::BuildError>),
    /// The grid file could not be written.
    #[error(transparent)]
    Grid(Arc<NavFileError>),
    /// A preview image could not be written (the error names it).
    #[error(transparent)]
    Preview(Arc<crate::file_error::FileError>),
}

/// Result of a batch bake: one outcome per scene id, in input order.
#[derive(Debug, Default)]
pub struct BakeReport {
    /// `(scene id, outcome)`.
    pub scenes: Vec<(String, BakeOutcome)>,
}

impl BakeReport {
    /// The failures: each scene's id and why, on one line ([`crate::escape::error_line`]).
    pub fn failures(&self) -> impl Iterator<Item = (&str, String)> {
        self.scenes.iter().filter_map(|(id, o)| match o {
            BakeOutcome::Failed(e) | BakeOutcome::WriteFailed(e) => {
                Some((id.as_str(), crate::escape::error_line(e)))
            }
            BakeOutcome::Stopped => Some((id.as_str(), "not baked: a write failed".to_string())),
            _ => None,
        })
    }

    /// Scenes whose grid for another body this bake replaced, with that body.
    pub fn replaced_bodies(&self) -> impl Iterator<Item = (&str, AgentBody)> {
        self.scenes.iter().filter_map(|(id, o)| match o {
            BakeOutcome::Baked {
                replaced_body: Some(b),
                ..
            } => Some((id.as_str(), *b)),
            _ => None,
        })
    }

    /// The first write failure in input order, naming the file: a problem of the whole batch
    /// (a full disk, a read-only folder), reported as the one error of the command.
    pub fn write_failure(&self) -> Option<&BakeFailure> {
        self.scenes.iter().find_map(|(_, o)| match o {
            BakeOutcome::WriteFailed(e) => Some(e),
            _ => None,
        })
    }
}

/// Options of a batch bake.
#[derive(Debug, Clone)]
pub struct BakeConfig {
    /// DATA folder.
    pub data: DataDir,
    /// Scenes (or variants) to bake.
    pub scenes: Vec<SceneRef>,
    /// Agent and grid parameters.
    pub params: NavParams,
    /// Rebake even when up to date.
    pub force: bool,
    /// Write PNG previews.
    pub previews: bool,
}

/// Why grid parameters could not be resolved.
#[derive(Debug, thiserror::Error)]
pub enum GridParamsError {
    /// The parameter file could not be read or is not valid.
    #[error(transparent)]
    File(#[from] SettingsFileError),
    /// The cell size given is not usable.
    #[error("cell size")]
    CellSize(#[source] Invalid),
}

/// The grid parameters a bake is asked for: those of agent preset `preset`, with
/// `cell_size` when given, then the keys of the TOML file `config` over them (see
/// [`params_from_toml`]), checked.
pub fn grid_params(
    preset: AgentPreset,
    cell_size: Option<f32>,
    config: Option<&Path>,
) -> Result<NavParams, GridParamsError> {
    let mut params = NavParams::preset(preset);
    if let Some(cell) = cell_size {
        params.cell_size = cell;
    }
    if let Some(path) = config {
        params = read_settings(path, |text| params_from_toml(text, params))?;
    }
    params.validate().map_err(GridParamsError::CellSize)?;
    Ok(params)
}

/// True when `out` exists and is at least as new as every input of `scene_ref`.
fn up_to_date(data: &DataDir, out: &Path, scene_ref: &SceneRef) -> bool {
    let built = std::fs::metadata(out).and_then(|m| m.modified()).ok();
    matches!((built, data.newest_input(scene_ref)), (Some(x), Some(y)) if x >= y)
}

fn bake_one(cfg: &BakeConfig, id: &SceneRef) -> BakeOutcome {
    let out = cfg.data.nav_path(id);
    if !cfg.force && up_to_date(&cfg.data, &out, id) {
        if let Ok(g) = read_nav(&out) {
            if g.params == cfg.params {
                // A bake killed between the grid and its previews left them missing.
                if cfg.previews && !previews_present(&g, &out) {
                    if let Err(e) = write_previews(&g, &out) {
                        return BakeOutcome::WriteFailed(BakeFailure::Preview(Arc::new(e)));
                    }
                }
                return BakeOutcome::UpToDate;
            }
        }
    }
    let replaced_body = read_nav_params(&out)
        .ok()
        .map(|p| p.body)
        .filter(|b| *b != cfg.params.body);
    let (scene, _) = match cfg.data.load_scene(id) {
        Ok(s) => s,
        Err(e) => return BakeOutcome::Failed(BakeFailure::Scene(Arc::new(e))),
    };
    let grid = match build(&scene, &cfg.params) {
        Ok(g) => g,
        Err(e) => return BakeOutcome::Failed(BakeFailure::Build(Arc::new(e))),
    };
    match write_nav(&out, &grid) {
        Ok(()) => {}
        Err(e @ NavFileError::Io(FileError { .. })) => {
            return BakeOutcome::WriteFailed(BakeFailure::Grid(Arc::new(e)))
        }
        Err(e) => return BakeOutcome::Failed(BakeFailure::Grid(Arc::new(e))),
    }
    if cfg.previews {
        if let Err(e) = write_previews(&grid, &out) {
            return BakeOutcome::WriteFailed(BakeFailure::Preview(Arc::new(e)));
        }
    }
    BakeOutcome::Baked {
        walkable: grid.walkable_count(),
        islands: grid.islands.len(),
        replaced_body,
    }
}

/// Bakes every scene of `cfg.scenes` in parallel, after removing what a killed bake left in
/// `DATA/nav/`. Once a write fails, the scenes not yet started are [`BakeOutcome::Stopped`].
pub fn bake_scenes(cfg: &BakeConfig, progress: &dyn Progress) -> BakeReport {
    let nav = cfg.data.nav_dir();
    if let Err(e) = sweep_stale(&nav) {
        tracing::warn!(
            "{}: cannot remove stale temporary files: {}",
            nav.display(),
            crate::escape::error_line(&e)
        );
    }
    bake_list(cfg, &cfg.scenes, progress)
}

/// Why [`bake`] could not run, or could not finish the DATA folder's record.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    /// The DATA folder's lock could not be taken.
    #[error("the DATA folder's lock")]
    Lock(#[source] LockError),
    /// The grids are written, but the DATA folder's provenance record could not be.
    #[error("the DATA folder's provenance record")]
    Provenance(#[source] crate::file_error::FileError),
}

/// Bakes `shard` of `cfg.scenes` holding the DATA folder's lock as the bake needs it: the
/// writer lock for the whole list ([`bake_scenes`]); for one shard of several, the shared lock
/// the shards hold side by side ([`bake_shard`]), so a split or an ingest cannot write the
/// folder meanwhile. `mode` says whether to wait for another writer. The whole list's bake
/// rewrites the DATA folder's provenance record (`DATA/provenance.json`) when no write
/// failed.
pub fn bake(
    cfg: &BakeConfig,
    shard: Shard,
    mode: LockMode,
    progress: &dyn Progress,
) -> Result<BakeReport, BakeError> {
    if shard == Shard::ALL {
        let _lock = cfg.data.lock("bake", mode).map_err(BakeError::Lock)?;
        let report = bake_scenes(cfg, progress);
        // (Shards bake side by side: the unsharded bake or a later command writes the record.)
        if report.write_failure().is_none() {
            crate::store::provenance::write_data_record(&cfg.data)
                .map_err(BakeError::Provenance)?;
        }
        Ok(report)
    } else {
        let _lock = cfg.data.lock_shared(mode).map_err(BakeError::Lock)?;
        Ok(bake_shard(cfg, shard, progress))
    }
}

/// Bakes shard `shard` of `cfg.scenes` (every n-th scene of the list sorted by name), for
/// several shards baking one DATA folder at once, on one machine or many sharing it. Only the
/// temporaries of this shard's own scenes' files are swept: another shard's files in the
/// making, on another machine whose processes this one cannot see, are never touched.
pub fn bake_shard(cfg: &BakeConfig, shard: Shard, progress: &dyn Progress) -> BakeReport {
    let mut sorted: Vec<&SceneRef> = cfg.scenes.iter().collect();
    sorted.sort_by_key(|s| s.to_string());
    sorted.dedup_by_key(|s| s.to_string());
    let mine: Vec<SceneRef> = sorted
        .into_iter()
        .enumerate()
        .filter(|(i, _)| shard.keeps(*i))
        .map(|(_, s)| s.clone())
        .collect();
    let nav = cfg.data.nav_dir();
    for scene in &mine {
        let path = cfg.data.nav_path(scene);
        let Some(stem) = path
            .file_stem()
            .map(|s| format!("{}.", s.to_string_lossy()))
        else {
            continue;
        };
        if let Err(e) = sweep_stale_where(&nav, |of| of.starts_with(&stem)) {
            tracing::warn!(
                "{}: cannot remove stale temporary files: {}",
                nav.display(),
                crate::escape::error_line(&e)
            );
        }
    }
    bake_list(cfg, &mine, progress)
}

fn bake_list(cfg: &BakeConfig, list: &[SceneRef], progress: &dyn Progress) -> BakeReport {
    progress.set_total(list.len() as u64);
    let stop = AtomicBool::new(false);
    let scenes = list
        .par_iter()
        .map(|id| {
            let outcome = if stop.load(Ordering::Relaxed) {
                BakeOutcome::Stopped
            } else {
                bake_one(cfg, id)
            };
            if matches!(outcome, BakeOutcome::WriteFailed(_)) {
                stop.store(true, Ordering::Relaxed);
            }
            progress.advance(1);
            (id.to_string(), outcome)
        })
        .collect();
    BakeReport { scenes }
}
