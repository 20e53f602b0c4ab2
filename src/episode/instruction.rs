//! An episode's task in words, for policies that condition on language (LeRobot's `task`):
//! "find a chair", "go to the kitchen", "go 4.2 m ahead and 1.3 m left", and for a VLN
//! episode its first route instruction ("Walk out of the bedroom and turn left. …").
//!
//! PointGoal instructions are in the start pose's frame (forward = −Z turned by the start yaw,
//! right = +X turned likewise; see the coordinate conventions), rounded to 0.1 m; a height
//! difference of more than half a metre (another level) is said too ("and 2.8 m up"); a leg
//! that rounds to 0.0 m is left out.

use super::{Episode, Goal};

/// Height difference (m) from which a PointGoal instruction says "up" or "down".
const LEVEL_CHANGE: f32 = 0.5;

/// The episode's instruction in English (a VLN episode's first instruction).
pub fn instruction(episode: &Episode) -> String {
    if let Some(text) = episode.route.as_ref().and_then(|r| r.instructions.first()) {
        return text.clone();
    }
    match &episode.goal {
        Goal::Object { category, .. } => format!("find {}", with_article(&words(category))),
        Goal::Room { class, .. } => format!("go to the {}", words(class)),
        Goal::Point { position } => {
            point_instruction(episode.start_position, episode.start_yaw, *position)
        }
    }
}

/// "go A m ahead|back and B m left|right[ and C m up|down]" from a start pose to a point.
fn point_instruction(start: [f32; 3], yaw: f32, goal: [f32; 3]) -> String {
    let (dx, dy, dz) = (goal[0] - start[0], goal[1] - start[1], goal[2] - start[2]);
    let (s, c) = yaw.sin_cos();
    // Forward is (−sin yaw, −cos yaw) in (x, z); right is (cos yaw, −sin yaw).
    let ahead = -s * dx - c * dz;
    let right = c * dx - s * dz;
    let mut legs = Vec::new();
    // A leg that rounds to 0.0 m is not said.
    let mut leg = |v: f32, negative: &str, positive: &str| {
        let text = format!("{:.1}", v.abs());
        if text != "0.0" {
            legs.push(format!(
                "{text} m {}",
                if v < 0.0 { negative } else { positive }
            ));
        }
    };
    leg(ahead, "back", "ahead");
    leg(right, "left", "right");
    if dy.abs() > LEVEL_CHANGE {
        leg(dy, "down", "up");
    }
    if legs.is_empty() {
        "stay where you are".into()
    } else {
        format!("go {}", legs.join(" and "))
    }
}

/// A category or room-class name as words: `living_room` → `living room`.
fn words(name: &str) -> String {
    name.replace(['_', '-'], " ").trim().to_string()
}

/// `a chair`, `an armchair`.
fn with_article(noun: &str) -> String {
    let vowel = noun
        .chars()
        .next()
        .is_some_and(|c| "aeiouAEIOU".contains(c));
    format!("{} {noun}", if vowel { "an" } else { "a" })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode::{Difficulty, GoalTarget, Task};

    fn episode(goal: Goal, yaw: f32) -> Episode {
        Episode {
            episode_id: "s:pointgoal:00000".into(),
            scene_id: "s".into(),
            split: String::new(),
            task: Task::PointGoal,
            seed: 0,
            start_position: [1.0, 0.0, 2.0],
            start_yaw: yaw,
            goal,
            euclidean_distance: 0.0,
            geodesic_distance: 0.0,
            path_num_doors: 0,
            path_num_rooms: 1,
            difficulty: Difficulty::Easy,
            success_radius: 0.2,
            max_steps: 500,
            levels_crossed: 0,
            route: None,
        }
    }

    #[test]
    fn object_and_room_goals_read_as_english() {
        let target = GoalTarget {
            id: "0_1".into(),
            position: [0.0; 3],
            view_points: vec![],
            room: None,
        };
        let object = |c: &str| Goal::Object {
            category: c.into(),
            targets: vec![target.clone()],
        };
        assert_eq!(instruction(&episode(object("chair"), 0.0)), "find a chair");
        assert_eq!(
            instruction(&episode(object("arm_chair"), 0.0)),
            "find an arm chair"
        );
        let room = Goal::Room {
            class: "living_room".into(),
            targets: vec![target],
        };
        assert_eq!(instruction(&episode(room, 0.0)), "go to the living room");
    }

    #[test]
    fn a_vln_episode_is_said_by_its_first_route_instruction() {
        let mut e = episode(
            Goal::Point {
                position: [1.0, 0.0, -3.0],
            },
            0.0,
        );
        e.task = Task::Vln;
        e.route = Some(Box::new(crate::episode::vln::Route {
            path: vec![[1.0, 0.0, 2.0], [1.0, 0.0, -3.0]],
            rooms: vec![],
            doors: vec![],
            levels: vec![0],
            landmarks: vec![],
            goal_object: None,
            instructions: vec!["Walk ahead. Stop.".into(), "Stop ahead.".into()],
        }));
        // LeRobot's task and `minos serve` read this.
        assert_eq!(instruction(&e), "Walk ahead. Stop.");
        e.route = None;
        assert_eq!(instruction(&e), "go 5.0 m ahead");
    }

    #[test]
    fn point_goals_are_said_in_the_start_frame() {
        // Yaw 0 faces −Z: a goal 4.2 m along −Z and 1.3 m along −X is ahead and left.
        let goal = |dx: f32, dy: f32, dz: f32| Goal::Point {
            position: [1.0 + dx, dy, 2.0 + dz],
        };
        assert_eq!(
            instruction(&episode(goal(-1.3, 0.0, -4.2), 0.0)),
            "go 4.2 m ahead and 1.3 m left"
        );
        // Turned a quarter left (yaw π/2 faces −X): the same goal is 1.3 m ahead, 4.2 m right.
        assert_eq!(
            instruction(&episode(goal(-1.3, 0.0, -4.2), std::f32::consts::FRAC_PI_2)),
            "go 1.3 m ahead and 4.2 m right"
        );
        // Behind, and one level up.
        assert_eq!(
            instruction(&episode(goal(0.0, 2.8, 3.0), 0.0)),
            "go 3.0 m back and 2.8 m up"
        );
        // Checked against an independent rotation: the goal's offset turned by −yaw lands
        // on (right, −ahead) for any yaw (these yaws keep both legs above 0.05 m).
        for k in 0..16 {
            let yaw = k as f32 * 0.37 - 2.95;
            let (dx, dz) = (2.5f32, -1.5f32);
            let text = instruction(&episode(goal(dx, 0.0, dz), yaw));
            let (s, c) = (-yaw).sin_cos();
            let (x, z) = (c * dx + s * dz, -s * dx + c * dz);
            let expected = format!(
                "go {:.1} m {} and {:.1} m {}",
                z.abs(),
                if -z < 0.0 { "back" } else { "ahead" },
                x.abs(),
                if x < 0.0 { "left" } else { "right" }
            );
            assert_eq!(text, expected, "yaw {yaw}");
        }
    }
}
