//! An episode file: its provenance sidecar's checksums, the file decoding, and — given the
//! DATA folder its scenes were baked in — every start and goal on the baked grid with its
//! stored geodesic distance re-computed.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::Vec3;

use super::{checksums, read_json, Found, VerifyOptions};
use crate::episode::format::read_episodes;
use crate::episode::goal::shortest_path;
use crate::episode::{Episode, Goal};
use crate::navmesh::route::route_in;
use crate::navmesh::{geodesic::Geodesic, NavGrid};
use crate::progress::Progress;
use crate::scene::SceneRef;
use crate::store::DataDir;

/// How far (m) a re-computed geodesic distance may lie from the stored one: the goal
/// field's path (object and room goals) and the point-to-point route that measured the
/// episode refine their corners separately, within a fraction of a 5 cm cell.
pub const GEODESIC_TOLERANCE: f32 = 0.05;

/// Checks the episode file `path`.
pub(super) fn check(
    path: &Path,
    options: &VerifyOptions,
    found: &mut Found,
    progress: &dyn Progress,
) {
    let sidecar = PathBuf::from(format!("{}.provenance.json", path.display()));
    let folder = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if sidecar.is_file() {
        if let Some(record) = read_json(&sidecar, found) {
            checksums::check(folder, &sidecar, record.get("files"), None, found, progress);
        }
    } else {
        found.problem(&sidecar, "file", "missing: no checksums to compare");
    }
    let episodes = match read_episodes(path) {
        Ok(e) => e,
        Err(e) => {
            let message = super::tables::strip_path(&crate::escape::error_line(&e), path);
            found.problem(path, "file", message);
            return;
        }
    };
    let mut ids = std::collections::HashSet::new();
    for (i, e) in episodes.iter().enumerate() {
        if !ids.insert(e.episode_id.as_str()) {
            found.problem(
                path,
                format!("row {i} (episode `{}`)", e.episode_id),
                "repeats an earlier episode id",
            );
        }
    }
    match &options.data {
        Some(data) => {
            navigable(path, &episodes, &DataDir::new(data), found);
            found.checked.push(format!(
                "{} episodes: starts, goals and geodesic distances re-computed on {}'s grids",
                episodes.len(),
                data.display()
            ));
        }
        None => found.checked.push(format!(
            "{} episodes read (give their DATA folder to check them on the baked grids)",
            episodes.len()
        )),
    }
}

/// Every episode's start and goal on its scene's grid, and its geodesic distance.
fn navigable(path: &Path, episodes: &[Episode], data: &DataDir, found: &mut Found) {
    let mut grids: HashMap<String, Option<NavGrid>> = HashMap::new();
    for (i, e) in episodes.iter().enumerate() {
        let record = format!("row {i} (episode `{}`)", e.episode_id);
        let scene = SceneRef::parse(&e.scene_id);
        let grid =
            grids
                .entry(e.scene_id.clone())
                .or_insert_with(|| match data.read_grid(&scene) {
                    Ok(g) => Some(g),
                    Err(err) => {
                        found.problem(
                            &data.grid_path(&scene),
                            "file",
                            format!(
                                "no grid for scene `{}`: {}",
                                e.scene_id,
                                crate::escape::error_line(&err)
                            ),
                        );
                        None
                    }
                });
        let Some(grid) = grid else { continue };
        let start = Vec3::from_array(e.start_position);
        if !grid.is_walkable(start) {
            found.problem(
                path,
                record,
                format!(
                    "start ({:.3}, {:.3}, {:.3}) is not on the navigable grid of scene `{}`",
                    start.x, start.y, start.z, e.scene_id
                ),
            );
            continue;
        }
        let length = match &e.goal {
            Goal::Point { position } => {
                let goal = Vec3::from_array(*position);
                if !grid.is_walkable(goal) {
                    found.problem(
                        path,
                        record,
                        format!(
                            "goal ({:.3}, {:.3}, {:.3}) is not on the navigable grid of scene `{}`",
                            goal.x, goal.y, goal.z, e.scene_id
                        ),
                    );
                    continue;
                }
                route_in(&Geodesic::new(grid), start, goal)
                    .ok()
                    .and_then(|r| r.geodesic)
            }
            _ => shortest_path(grid, e)
                .map(|p| p.windows(2).map(|w| w[0].distance(w[1])).sum::<f32>()),
        };
        match length {
            None => found.problem(
                path,
                record,
                format!(
                    "no path from the start to the goal on scene `{}`'s grid",
                    e.scene_id
                ),
            ),
            Some(d) if (d - e.geodesic_distance).abs() > GEODESIC_TOLERANCE => found.problem(
                path,
                record,
                format!(
                    "geodesic_distance {} m where the grid gives {d:.3} m",
                    e.geodesic_distance
                ),
            ),
            Some(_) => {}
        }
    }
}
