//! What an agent is given at each step beside its cameras, defined once: the goal
//! measurements every MINOS agent received (distance and direction to the goal, the goal
//! room's class, the target category), whether the success test holds, the contact sensors,
//! the last step's collision and action, and the steps left.
//!
//! The [`EpisodeStepper`](super::stepper::EpisodeStepper) computes a [`StepFeatures`] for
//! every observation ([`EpisodeStepper::features`](super::stepper::EpisodeStepper::features)),
//! and every consumer reads it from there: the run's `trajectories.parquet` (one row per
//! observation, before its action), the LeRobot export (`observation.goal`,
//! `observation.contact`, … — see `crate::io::lerobot::features`) and the Gym observations
//! of the Python bindings (`goal`, `contact`, …).
//!
//! Frames and units: distances in metres; directions are unit vectors in the agent frame,
//! `[right, forward]` (the agent faces −Z; right is +X: `docs/FORMATS.md`, conventions).

use crate::episode::{Episode, Goal};
use crate::scene::RoomClass;
use crate::sim::Measurements;

use super::agents::Decision;

/// Names of the contact bits for the usual four sensors, in sensor order (sensor k looks
/// `k × 90°` counter-clockwise from forward).
pub const CONTACT_NAMES: [&str; 4] = ["front", "left", "back", "right"];

/// Names of `goal`'s elements.
pub const GOAL_NAMES: [&str; 3] = ["distance", "right", "forward"];

/// The features of one observation.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StepFeatures {
    /// MINOS's goal measurement: the straight-line distance to the goal (m), then the unit
    /// direction to it in the agent frame `[right, forward]` (Habitat's GPS+compass in
    /// Cartesian form). Object and room goals measure to the target the shortest path ends
    /// at (the nearest by path). Zeros without a goal; the direction is zero at the goal.
    pub goal: [f32; 3],
    /// The straight-line distance alone (`None` without a goal).
    pub euclidean: Option<f32>,
    /// Shortest-path distance to the same target (`None` when unreachable or no goal; never
    /// below `euclidean`).
    pub geodesic: Option<f32>,
    /// A room goal's MINOS room class (`None` for other tasks and unknown classes).
    pub goal_room: Option<RoomClass>,
    /// An object goal's target category (`None` for other tasks).
    pub goal_object: Option<String>,
    /// The episode's success test holds at this observation (for room goals: the agent is in
    /// a goal room).
    pub at_goal: bool,
    /// Contact per contact sensor ([`CONTACT_NAMES`] for four sensors).
    pub contacts: Vec<bool>,
    /// The step that led to this observation collided (false at an episode's start).
    pub collision: bool,
    /// The decision that led to this observation (`None` at an episode's start).
    pub previous_action: Option<Decision>,
    /// Steps left before the episode's step limit.
    pub steps_left: u32,
}

impl StepFeatures {
    /// The features of an observation with `measurements`, in `episode`, given whether the
    /// success test holds, the decision that led there and the steps left.
    pub fn new(
        measurements: &Measurements,
        episode: &Episode,
        at_goal: bool,
        previous_action: Option<Decision>,
        steps_left: u32,
    ) -> StepFeatures {
        let m = measurements;
        let direction = m.goal_direction.unwrap_or([0.0, 0.0]);
        let (goal_room, goal_object) = match &episode.goal {
            Goal::Point { .. } => (None, None),
            Goal::Room { class, .. } => (RoomClass::from_label(class), None),
            Goal::Object { category, .. } => (None, Some(category.clone())),
        };
        StepFeatures {
            goal: [m.goal_euclidean.unwrap_or(0.0), direction[0], direction[1]],
            euclidean: m.goal_euclidean,
            geodesic: m.goal_geodesic,
            goal_room,
            goal_object,
            at_goal,
            contacts: m.contacts.clone(),
            collision: m.collision,
            previous_action,
            steps_left,
        }
    }

    /// The goal room class one-hot over [`RoomClass::ALL`] (as MINOS fed it; zeros without
    /// a room goal).
    pub fn goal_room_one_hot(&self) -> [f32; RoomClass::ALL.len()] {
        let mut v = [0.0; RoomClass::ALL.len()];
        if let Some(c) = self.goal_room {
            v[c.index() as usize] = 1.0;
        }
        v
    }

    /// The previous action as the LeRobot `action` vector: the eight strengths, then 1 for
    /// `stop` (zeros at an episode's start).
    pub fn previous_action_vector(&self) -> [f32; 9] {
        action_vector(self.previous_action.as_ref())
    }
}

/// A decision as the LeRobot `action` vector: the eight strengths, then 1 for `stop`; zeros
/// for none.
pub fn action_vector(decision: Option<&Decision>) -> [f32; 9] {
    let mut v = [0.0; 9];
    match decision {
        None => {}
        Some(Decision::Stop) => v[8] = 1.0,
        Some(d) => v[..8].copy_from_slice(&d.strengths()),
    }
    v
}

/// Names of `count` contact bits: [`CONTACT_NAMES`] for four, else `contact_<k>`.
pub fn contact_names(count: usize) -> Vec<String> {
    if count == CONTACT_NAMES.len() {
        CONTACT_NAMES.iter().map(|s| s.to_string()).collect()
    } else {
        (0..count).map(|k| format!("contact_{k}")).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::Actions;

    #[test]
    fn action_vectors_put_stop_last() {
        assert_eq!(action_vector(None), [0.0; 9]);
        let stop = action_vector(Some(&Decision::Stop));
        assert_eq!(stop[8], 1.0);
        assert_eq!(stop[..8].iter().sum::<f32>(), 0.0);
        let fwd = Actions::single("forward").map(Decision::Act);
        let v = action_vector(fwd.as_ref());
        assert_eq!(v[0], 1.0, "forward is the first strength: {v:?}");
        assert_eq!(v[8], 0.0);
    }

    #[test]
    fn room_one_hot_marks_the_class_index() {
        let f = StepFeatures {
            goal_room: Some(RoomClass::Kitchen),
            ..Default::default()
        };
        let v = f.goal_room_one_hot();
        assert_eq!(v.iter().sum::<f32>(), 1.0);
        assert_eq!(v[4], 1.0, "kitchen is MINOS class 4");
        assert_eq!(StepFeatures::default().goal_room_one_hot(), [0.0; 9]);
    }
}
