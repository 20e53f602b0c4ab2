//! `minos view`: one scene's recording — its meshes, its navigation grid and, for each given
//! episode of the scene, the start, goal and shortest path under `world/episodes/<id>`.

use std::path::Path;

use super::scene::{episode_entity, log_coordinates, log_episode_plan, log_nav, log_scene_mesh};
use super::{RecordingError, RrdFile};
use crate::episode::Episode;
use crate::navmesh::NavGrid;
use crate::render::RenderScene;
use crate::scene::Scene;

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

/// Writes the recording of scene `scene_ref` (loaded as `scene`, its grid `grid`) to `out`,
/// with those of `episodes` that belong to it.
pub fn write_view(
    out: &Path,
    scene_ref: &str,
    scene: &Scene,
    grid: &NavGrid,
    episodes: &[Episode],
) -> Result<ViewReport, RecordingError> {
    let render = RenderScene::new(scene);
    let file = RrdFile::create(out, scene_ref, scene_ref)?;
    let mut report = ViewReport {
        triangles: log_scene_mesh(&file, &render)?,
        walkable: log_nav(&file, grid)?,
        ..ViewReport::default()
    };
    log_coordinates(&file)?;
    for ep in episodes.iter().filter(|e| e.scene_id == scene_ref) {
        let path = log_episode_plan(&file, grid, ep, &episode_entity(&ep.episode_id))?;
        report.episodes += 1;
        report.unreachable += usize::from(path.is_empty());
    }
    file.finish()?;
    Ok(report)
}
