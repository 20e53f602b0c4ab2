//! Baking many scenes: load each compiled scene (applying its variant, if the id names one),
//! build its grid, write `DATA/nav/<id>.nav`
//! and its previews, in parallel. A scene that fails is reported and the others finish;
//! grids newer than their scene and baked with the same parameters are kept.

use std::path::Path;

use rayon::prelude::*;

use crate::navmesh::build::build;
use crate::navmesh::file::{read_nav, write_nav};
use crate::navmesh::preview::write_previews;
use crate::navmesh::NavParams;
use crate::progress::Progress;
use crate::scene::SceneRef;
use crate::store::DataDir;

/// How one scene's bake went.
#[derive(Debug, Clone, PartialEq)]
pub enum BakeOutcome {
    /// Baked now: spans, walkable spans, islands.
    Baked {
        /// Walkable spans.
        walkable: usize,
        /// Islands.
        islands: usize,
    },
    /// Its grid was up to date.
    UpToDate,
    /// It failed, with a one-line reason.
    Failed(String),
}

/// Result of a batch bake: one outcome per scene id, in input order.
#[derive(Debug, Default)]
pub struct BakeReport {
    /// `(scene id, outcome)`.
    pub scenes: Vec<(String, BakeOutcome)>,
}

impl BakeReport {
    /// The failures.
    pub fn failures(&self) -> impl Iterator<Item = (&str, &str)> {
        self.scenes.iter().filter_map(|(id, o)| match o {
            BakeOutcome::Failed(e) => Some((id.as_str(), e.as_str())),
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
                return BakeOutcome::UpToDate;
            }
        }
    }
    let result = (|| -> Result<BakeOutcome, String> {
        let (scene, _) = cfg.data.load_scene(id).map_err(|e| e.to_string())?;
        let grid = build(&scene, &cfg.params).map_err(|e| e.to_string())?;
        write_nav(&out, &grid).map_err(|e| e.to_string())?;
        if cfg.previews {
            write_previews(&grid, &out).map_err(|e| format!("{}: preview: {e}", out.display()))?;
        }
        Ok(BakeOutcome::Baked {
            walkable: grid.walkable_count(),
            islands: grid.islands.len(),
        })
    })();
    result.unwrap_or_else(BakeOutcome::Failed)
}

/// Bakes every scene of `cfg.scenes` in parallel.
pub fn bake_scenes(cfg: &BakeConfig, progress: &dyn Progress) -> BakeReport {
    progress.set_total(cfg.scenes.len() as u64);
    let scenes = cfg
        .scenes
        .par_iter()
        .map(|id| {
            let outcome = bake_one(cfg, id);
            progress.advance(1);
            (id.to_string(), outcome)
        })
        .collect();
    BakeReport { scenes }
}
