//! Vision-and-language navigation (VLN) episodes: a route over the navigation grid — start,
//! goal, the geodesic reference path, the rooms, doors and levels it passes — and several
//! instructions in English generated from the route itself by a seeded grammar.
//!
//! One file per concept: [`landmarks`] indexes a scene's objects by room (which categories are
//! distinctive, which objects a route may stop next to), [`walk`] walks a reference path span
//! by span into what an instruction can say (room changes, doors, turns, stairs, landmarks),
//! [`grammar`] turns that into sentences, `tokens` is the tokeniser and vocabulary of the
//! VLN-CE export, and [`export`] writes VLN-CE and R2R files. Sampling lives with the other
//! tasks in [`super::sample`].
//!
//! The grammar is documented in `docs/FORMATS.md` ("VLN instructions"); everything an
//! instruction names is grounded by construction, and [`grammar::Rendered::mentions`] says what
//! each instruction named and where, so tests (and users) can check it.

pub mod export;
pub mod grammar;
pub mod landmarks;
internal! {
    pub mod tokens;
}
pub mod walk;

use serde::{Deserialize, Serialize};

use super::TargetRoom;

/// Instructions generated per route unless asked otherwise (R2R has three per path).
pub const DEFAULT_INSTRUCTIONS: usize = 3;

/// Success radius (m) of VLN episodes unless asked otherwise: R2R's and VLN-CE's 3 m.
pub const DEFAULT_SUCCESS_RADIUS: f32 = 3.0;

/// The route of a VLN episode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Route {
    /// The reference path: the start, the corners of the geodesic path, the goal (x, y = floor
    /// height, z).
    pub path: Vec<[f32; 3]>,
    /// The rooms the path passes, in order, the start's first (a room counts once the path
    /// has stayed in it for half a metre; consecutive repeats removed).
    pub rooms: Vec<TargetRoom>,
    /// The doorways (door and arch object ids) the path passes through, in order.
    pub doors: Vec<String>,
    /// The levels the path is on, in order (consecutive repeats removed; one entry on one
    /// floor).
    pub levels: Vec<u32>,
    /// The object ids the instructions name as landmarks, in order of first mention.
    pub landmarks: Vec<String>,
    /// The object the stop description names ("stop next to the fridge"), if any.
    pub goal_object: Option<String>,
    /// The instructions, in English.
    pub instructions: Vec<String>,
}

/// The ends of a route and what the stop description names.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RouteEnds {
    /// The start position.
    pub start: glam::Vec3,
    /// The goal position.
    pub goal: glam::Vec3,
    /// The start yaw (radians).
    pub yaw: f32,
    /// The object the route ends next to (index into the grid's objects), if any.
    pub goal_object: Option<u32>,
}

/// A route with everything it was made from: the walk and each instruction's mentions.
#[derive(Debug, Clone, PartialEq)]
pub struct Described {
    /// The route as stored in the episode.
    pub route: Route,
    /// The walk along the reference path the instructions were made from.
    pub walk: walk::RouteWalk,
    /// Each instruction with what it names.
    pub rendered: Vec<grammar::Rendered>,
}

/// The seed of the instructions of episode `index` of a scene whose episodes were drawn with
/// `scene_seed`: a stream of its own, so changing the grammar never changes which routes are
/// drawn.
pub fn instruction_seed(scene_seed: u64, index: usize) -> u64 {
    crate::seed::splitmix64(scene_seed ^ crate::seed::splitmix64(0x766c_6e00 + index as u64))
}

/// Describes the geodesic `path` (from [`crate::navmesh::path`], rooms and doors filled in)
/// between `ends`: walks it and renders `instructions` instructions, the `k`-th at
/// [`grammar::Detail::of_instruction`]`(k)`, all drawn from one generator seeded with `seed`.
pub fn describe_route(
    grid: &crate::navmesh::NavGrid,
    index: &landmarks::SceneIndex,
    path: &crate::navmesh::path::Path,
    ends: RouteEnds,
    seed: u64,
    instructions: usize,
) -> Described {
    let mut points = path.points.clone();
    if let Some(first) = points.first_mut() {
        *first = ends.start;
    }
    if points.len() >= 2 {
        if let Some(last) = points.last_mut() {
            *last = ends.goal;
        }
    } else {
        points.push(ends.goal);
    }
    let mut spans = path.spans.clone();
    if spans.len() < points.len() {
        if let Some(&last) = spans.last() {
            spans.push(last);
        }
    }
    let walk = walk::walk_route(grid, index, &points, &spans, ends.yaw, ends.goal_object);
    let mut rng = crate::seed::Rng::new(seed);
    let rendered: Vec<grammar::Rendered> = (0..instructions)
        .map(|k| {
            grammar::render(
                grid,
                &walk,
                ends.goal_object,
                grammar::Detail::of_instruction(k),
                &mut rng,
            )
        })
        .collect();
    let object_id = |o: u32| grid.objects[o as usize].id.clone();
    let mut landmarks: Vec<String> = Vec::new();
    for r in &rendered {
        for m in &r.mentions {
            if let grammar::Mention::Landmark { object, .. } = m {
                let id = object_id(*object);
                if !landmarks.contains(&id) {
                    landmarks.push(id);
                }
            }
        }
    }
    let route = Route {
        path: walk.points.iter().map(|p| p.to_array()).collect(),
        rooms: walk
            .rooms
            .iter()
            .map(|&r| {
                let room = &grid.rooms[r as usize];
                TargetRoom {
                    id: room.id.clone(),
                    class: crate::scene::RoomClass::ALL
                        .get(room.class as usize)
                        .copied()
                        .unwrap_or(crate::scene::RoomClass::Other)
                        .name()
                        .to_string(),
                }
            })
            .collect(),
        doors: walk.doors.iter().map(|&o| object_id(o)).collect(),
        levels: walk.levels.clone(),
        landmarks,
        goal_object: ends.goal_object.map(object_id),
        instructions: rendered.iter().map(|r| r.text.clone()).collect(),
    };
    Described {
        route,
        walk,
        rendered,
    }
}
