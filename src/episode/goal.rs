//! Where an episode's goal lies on a navigation grid, and the shortest path to it: the
//! walkable spans that count as reached (a point goal's span; an object goal's spans within
//! the success radius of each target; a room goal's floor) and the path from the start to
//! the nearest of them. The simulator builds its goal field from these spans; `minos view`
//! and run recordings draw the path.

use glam::Vec3;

use super::{Episode, Goal};
use crate::navmesh::geodesic::Geodesic;
use crate::navmesh::path::{path_from_field, PathResult};
use crate::navmesh::NavGrid;

/// The walkable spans that count as the episode's goal (empty when none lies on the grid).
pub fn goal_spans(grid: &NavGrid, episode: &Episode) -> Vec<u32> {
    match &episode.goal {
        Goal::Point { position } => grid.snap(Vec3::from_array(*position)).into_iter().collect(),
        Goal::Object { targets, .. } => targets
            .iter()
            .filter_map(|t| grid.objects.iter().position(|o| o.id == t.id))
            .flat_map(|o| grid.object_spans(o as u32, episode.success_radius))
            .collect(),
        Goal::Room { targets, .. } => targets
            .iter()
            .filter_map(|t| grid.rooms.iter().position(|r| r.id == t.id))
            .flat_map(|r| grid.room_spans(r as u32))
            .collect(),
    }
}

/// The shortest path from the episode's start to its nearest goal span, as a polyline that
/// begins at the start position itself (and ends at a point goal itself); `None` when the
/// start is off the grid or no goal is reachable.
pub fn shortest_path(grid: &NavGrid, episode: &Episode) -> Option<Vec<Vec3>> {
    let start = Vec3::from_array(episode.start_position);
    let from = grid.snap(start)?;
    let goals = goal_spans(grid, episode);
    if goals.is_empty() {
        return None;
    }
    let field = Geodesic::new(grid).field(&goals);
    match path_from_field(grid, &field, from) {
        PathResult::Unreachable => None,
        PathResult::Found(p) => {
            // Start (and, for a point goal, end) at the points themselves, not the span
            // centres, as the episode's geodesic distance does.
            let mut points = p.points;
            if let Some(first) = points.first_mut() {
                *first = Vec3::new(start.x, first.y, start.z);
            }
            if let (Goal::Point { position }, Some(last)) = (&episode.goal, points.last_mut()) {
                *last = Vec3::new(position[0], last.y, position[2]);
            }
            Some(points)
        }
    }
}

/// Representative goal positions: the point, or each target's position.
pub fn goal_positions(episode: &Episode) -> Vec<[f32; 3]> {
    match &episode.goal {
        Goal::Point { position } => vec![*position],
        Goal::Object { targets, .. } | Goal::Room { targets, .. } => {
            targets.iter().map(|t| t.position).collect()
        }
    }
}
