//! `minos view`: one scene's recording — its meshes, its navigation grid and, for each given
//! episode of the scene, the start, goal and shortest path under `world/episodes/<id>`.

use std::path::PathBuf;

use super::scene::{episode_entity, log_coordinates, log_episode_plan, log_nav, log_scene_mesh};
use super::{RecordingError, RrdFile};
use crate::episode::Episode;
use crate::io::variant_store::{grid_ref, load_scene};
use crate::navmesh::file::{nav_path, read_nav};
use crate::render::RenderScene;

/// What `minos view` records.
#[derive(Debug, Clone)]
pub struct ViewConfig {
    /// DATA folder (ingested and baked).
    pub data: PathBuf,
    /// Scene id, or `<scene>@<variant>`.
    pub scene: String,
    /// The `.rrd` file to write.
    pub out: PathBuf,
}

/// What a view recording holds.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ViewReport {
    /// Triangles of the scene mesh (ceilings left out).
    pub triangles: usize,
    /// Walkable spans drawn.
    pub walkable: usize,
    /// Episodes drawn.
    pub episodes: usize,
    /// Of those, episodes whose goal is unreachable on the grid (start and goal only).
    pub unreachable: usize,
}

/// Why a view could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// The scene or its grid could not be read.
    #[error("{0}")]
    Input(String),
    /// The recording failed.
    #[error(transparent)]
    Recording(#[from] RecordingError),
}

/// Writes the recording of `cfg.scene` with those of `episodes` that belong to it.
pub fn write_view(cfg: &ViewConfig, episodes: &[Episode]) -> Result<ViewReport, ViewError> {
    let (scene, _) = load_scene(&cfg.data, &cfg.scene)
        .map_err(|e| ViewError::Input(format!("{e} (run `minos ingest`)")))?;
    let grid = read_nav(&nav_path(&cfg.data, &grid_ref(&cfg.data, &cfg.scene)))
        .map_err(|e| ViewError::Input(format!("{e} (run `minos bake`)")))?;
    let render = RenderScene::new(&scene);
    let file = RrdFile::create(&cfg.out, &cfg.scene, &cfg.scene)?;
    let mut report = ViewReport {
        triangles: log_scene_mesh(&file, &render)?,
        walkable: log_nav(&file, &grid)?,
        ..ViewReport::default()
    };
    log_coordinates(&file)?;
    for ep in episodes.iter().filter(|e| e.scene_id == cfg.scene) {
        let path = log_episode_plan(&file, &grid, ep, &episode_entity(&ep.episode_id))?;
        report.episodes += 1;
        report.unreachable += usize::from(path.is_empty());
    }
    file.finish()?;
    Ok(report)
}
