//! A scene's objects as a route describer sees them, built once per scene from its grid: the
//! room each object stands in, the objects that are *distinctive* in their room (the only one
//! of their category there, so "the sofa" names one thing), the doorways, and the objects a
//! route may end next to.
//!
//! An object's room is the room most of the walkable spans within [`ROOM_PROBE`] of its box lie
//! in. Landmarks are objects of at least [`MIN_LANDMARK_SIZE`] in some extent whose category is
//! not structural or moving ([`NOT_LANDMARKS`]: doors, walls, windows, stairs, people, …). Goal objects are
//! landmarks with walkable floor of their own room within [`GOAL_RADIUS`] of their box.

use std::collections::BTreeMap;

use crate::navmesh::{NavGrid, NONE};

/// Distance (m, in XZ) around an object's box searched for the floor that says its room.
pub const ROOM_PROBE: f32 = 0.6;

/// Distance (m, in XZ) from a goal object's box within which a route may end ("next to").
pub const GOAL_RADIUS: f32 = 1.0;

/// Smallest largest extent (m) of an object named as a landmark.
pub const MIN_LANDMARK_SIZE: f32 = 0.3;

/// Categories never named as landmarks or goals (structure, not furniture), compared in
/// lower case.
pub const NOT_LANDMARKS: [&str; 24] = [
    "arch",
    "beam",
    "ceiling",
    "column",
    "door",
    "door_frame",
    "doorframe",
    "floor",
    "garage_door",
    "misc",
    "object",
    "objects",
    "other",
    "people",
    "person",
    "railing",
    "stair",
    "stairs",
    "unknown",
    "void",
    "wall",
    "window",
    "window_frame",
    "",
];

/// An object a route may end next to.
#[derive(Debug, Clone, PartialEq)]
pub struct GoalObject {
    /// Object index (into [`NavGrid::objects`]).
    pub object: u32,
    /// Its room (into [`NavGrid::rooms`]).
    pub room: u32,
    /// Walkable spans of that room within [`GOAL_RADIUS`] of the object's box.
    pub spans: Vec<u32>,
}

/// A scene's objects by room.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SceneIndex {
    /// Per object, its room index (`NONE` when none is known).
    pub object_room: Vec<u32>,
    /// Per room, the landmark objects whose category occurs once in the room, by index.
    pub distinctive: Vec<Vec<u32>>,
    /// Per object, whether it is distinctive in its room.
    pub is_distinctive: Vec<bool>,
    /// Doorway objects (doors and arches), by index.
    pub doors: Vec<u32>,
    /// Distinctive objects with floor of their room next to them.
    pub goals: Vec<GoalObject>,
}

/// Can an object of this category and size be named as a landmark?
pub fn landmark_category(category: &str) -> bool {
    let c = category.trim().to_ascii_lowercase();
    !NOT_LANDMARKS.contains(&c.as_str())
}

impl SceneIndex {
    /// Indexes the objects of `grid`.
    pub fn new(grid: &NavGrid) -> Self {
        let n = grid.objects.len();
        let mut object_room = vec![NONE; n];
        for (i, room) in object_room.iter_mut().enumerate() {
            let mut counts: BTreeMap<u32, usize> = BTreeMap::new();
            for s in grid.object_spans(i as u32, ROOM_PROBE) {
                let r = grid.spans[s as usize].room;
                if (r as usize) < grid.rooms.len() {
                    *counts.entry(r).or_default() += 1;
                }
            }
            // The most frequent room; ties go to the lowest index.
            if let Some((&r, _)) = counts.iter().max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0))) {
                *room = r;
            }
        }
        // Category counts per room, over every object (small ones too: "the only chair"
        // must be the only one).
        let mut per_room: BTreeMap<(u32, String), u32> = BTreeMap::new();
        for (i, o) in grid.objects.iter().enumerate() {
            if object_room[i] != NONE {
                *per_room
                    .entry((object_room[i], o.category.to_ascii_lowercase()))
                    .or_default() += 1;
            }
        }
        let mut distinctive = vec![Vec::new(); grid.rooms.len()];
        let mut is_distinctive = vec![false; n];
        let mut doors = Vec::new();
        for (i, o) in grid.objects.iter().enumerate() {
            if o.door || o.arch {
                doors.push(i as u32);
                continue;
            }
            let r = object_room[i];
            if r == NONE || !landmark_category(&o.category) {
                continue;
            }
            let size = (0..3).map(|a| o.max[a] - o.min[a]).fold(0.0f32, f32::max);
            if size < MIN_LANDMARK_SIZE
                || per_room.get(&(r, o.category.to_ascii_lowercase())) != Some(&1)
            {
                continue;
            }
            distinctive[r as usize].push(i as u32);
            is_distinctive[i] = true;
        }
        let mut goals = Vec::new();
        for (r, objects) in distinctive.iter().enumerate() {
            for &o in objects {
                let spans: Vec<u32> = grid
                    .object_spans(o, GOAL_RADIUS)
                    .into_iter()
                    .filter(|&s| grid.spans[s as usize].room == r as u32)
                    .collect();
                if !spans.is_empty() {
                    goals.push(GoalObject {
                        object: o,
                        room: r as u32,
                        spans,
                    });
                }
            }
        }
        goals.sort_by_key(|g| g.object);
        SceneIndex {
            object_room,
            distinctive,
            is_distinctive,
            doors,
            goals,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn structure_is_never_a_landmark() {
        for c in ["door", "Wall", "stairs", "unknown", " window "] {
            assert!(!landmark_category(c), "{c}");
        }
        for c in ["sofa", "refrigerator", "bed"] {
            assert!(landmark_category(c), "{c}");
        }
    }
}
