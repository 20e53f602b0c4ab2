//! Episodes: navigable PointGoal / ObjectGoal / RoomGoal start–goal pairs, their Parquet
//! file, and interchange with Habitat-Lab and MINOS formats.

pub mod batch;
pub mod format;
pub mod goal;
pub mod habitat;
pub mod interchange;
pub mod minos_csv;
pub mod sample;

use serde::{Deserialize, Serialize};

/// The navigation task of an episode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Task {
    /// Reach a point.
    PointGoal,
    /// Reach an instance of an object category.
    ObjectGoal,
    /// Reach a room of a class.
    RoomGoal,
}

impl Task {
    /// Name used on the command line and in files (`pointgoal`, `objectgoal`, `roomgoal`).
    pub fn name(self) -> &'static str {
        match self {
            Task::PointGoal => "pointgoal",
            Task::ObjectGoal => "objectgoal",
            Task::RoomGoal => "roomgoal",
        }
    }

    /// Parses a task name.
    pub fn from_name(s: &str) -> Option<Task> {
        match s {
            "pointgoal" => Some(Task::PointGoal),
            "objectgoal" => Some(Task::ObjectGoal),
            "roomgoal" => Some(Task::RoomGoal),
            _ => None,
        }
    }
}

/// One target of an object or room goal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GoalTarget {
    /// Object instance id or room id in the scene.
    pub id: String,
    /// A representative position: object box centre, or a walkable point of the room.
    pub position: [f32; 3],
    /// Walkable points from which the target counts as reached (object "view points"),
    /// possibly subsampled; empty when not computed.
    pub view_points: Vec<[f32; 3]>,
}

/// What the agent must reach.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Goal {
    /// A point.
    Point {
        /// Goal position (x, y = floor height, z).
        position: [f32; 3],
    },
    /// Any of the listed instances of an object category.
    Object {
        /// Category name (e.g. `door`).
        category: String,
        /// The instances that count.
        targets: Vec<GoalTarget>,
    },
    /// Any of the listed rooms of a MINOS room class.
    Room {
        /// MINOS room class name (e.g. `kitchen`).
        class: String,
        /// The rooms that count.
        targets: Vec<GoalTarget>,
    },
}

/// Distance bin of an episode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Difficulty {
    /// Short geodesic distance.
    Easy,
    /// Medium.
    Medium,
    /// Long.
    Hard,
}

impl Difficulty {
    /// `easy`, `medium` or `hard`.
    pub fn name(self) -> &'static str {
        match self {
            Difficulty::Easy => "easy",
            Difficulty::Medium => "medium",
            Difficulty::Hard => "hard",
        }
    }

    /// Parses a name.
    pub fn from_name(s: &str) -> Option<Difficulty> {
        match s {
            "easy" => Some(Difficulty::Easy),
            "medium" => Some(Difficulty::Medium),
            "hard" => Some(Difficulty::Hard),
            _ => None,
        }
    }
}

/// One episode: a start, a goal, and what the shortest path between them looks like.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Episode {
    /// Stable id: `<scene>:<task>:<index>` (index zero-padded to 5 digits).
    pub episode_id: String,
    /// Scene id (`<scene>@<variant>` for variants).
    pub scene_id: String,
    /// Split subset (`train`, `val`, `test`), or empty.
    pub split: String,
    /// The task.
    pub task: Task,
    /// The per-scene seed the episode was drawn with.
    pub seed: u64,
    /// Start position (x, y = floor height, z).
    pub start_position: [f32; 3],
    /// Start yaw (radians, counter-clockwise about +Y, 0 faces −Z).
    pub start_yaw: f32,
    /// The goal.
    pub goal: Goal,
    /// Straight-line distance from the start to the goal (the closest target).
    pub euclidean_distance: f32,
    /// Shortest-path distance from the start to the goal (the closest target).
    pub geodesic_distance: f32,
    /// Doors on that shortest path.
    pub path_num_doors: u32,
    /// Rooms on that shortest path (counting the start's).
    pub path_num_rooms: u32,
    /// Distance bin.
    pub difficulty: Difficulty,
    /// Success radius (m).
    pub success_radius: f32,
    /// Step limit.
    pub max_steps: u32,
}
