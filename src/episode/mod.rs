//! Episodes: navigable PointGoal / ObjectGoal / RoomGoal start–goal pairs and VLN routes with
//! instructions in words, their Parquet file, and interchange with Habitat-Lab, VLN-CE, R2R and
//! MINOS formats.

pub mod format;
pub mod goal;
pub mod habitat;
pub mod import;
internal! {
    pub mod instruction;
}
pub mod interchange;
pub mod minos_csv;
pub mod sample;
pub mod vln;

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
    /// Follow a route described in words (vision-and-language navigation): the goal is the
    /// route's end point, the episode's [`vln::Route`] holds the reference path and the
    /// instructions.
    Vln,
}

impl crate::vocab::Vocabulary for Task {
    const WHAT: &'static str = "task";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: Task::PointGoal,
            name: "pointgoal",
            aliases: &[],
            help: "reach a point given as distance and direction",
        },
        crate::vocab::Term {
            value: Task::ObjectGoal,
            name: "objectgoal",
            aliases: &[],
            help: "reach an object of a category",
        },
        crate::vocab::Term {
            value: Task::RoomGoal,
            name: "roomgoal",
            aliases: &[],
            help: "reach a room of a class",
        },
        crate::vocab::Term {
            value: Task::Vln,
            name: "vln",
            aliases: &[],
            help: "vision-and-language navigation: routes with instructions in words",
        },
    ];
}

crate::vocab::name_traits!(Task);

impl Task {
    /// Name used on the command line and in files (`pointgoal`, `objectgoal`, `roomgoal`,
    /// `vln`).
    pub fn name(self) -> &'static str {
        crate::vocab::Vocabulary::term_name(self)
    }
}

/// One target of an object or room goal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GoalTarget {
    /// Object instance id or room id in the scene.
    pub id: String,
    /// A representative position: object box centre, or a walkable point of the room.
    pub position: [f32; 3],
    /// Walkable points from which the target counts as reached (Habitat's "view points":
    /// near an object, or inside a room), possibly subsampled; empty when not computed.
    pub view_points: Vec<[f32; 3]>,
    /// The room the target is in (for a room target, itself), when known.
    #[serde(default)]
    pub room: Option<TargetRoom>,
}

/// The room of a goal target.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct TargetRoom {
    /// Room id in the scene.
    pub id: String,
    /// MINOS room class name (`kitchen`, …).
    pub class: String,
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

impl crate::vocab::Vocabulary for Difficulty {
    const WHAT: &'static str = "difficulty";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: Difficulty::Easy,
            name: "easy",
            aliases: &[],
            help: "short geodesic distance",
        },
        crate::vocab::Term {
            value: Difficulty::Medium,
            name: "medium",
            aliases: &[],
            help: "medium geodesic distance",
        },
        crate::vocab::Term {
            value: Difficulty::Hard,
            name: "hard",
            aliases: &[],
            help: "long geodesic distance",
        },
    ];
}

crate::vocab::name_traits!(Difficulty);

impl Difficulty {
    /// `easy`, `medium` or `hard`.
    pub fn name(self) -> &'static str {
        crate::vocab::Vocabulary::term_name(self)
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
    /// Levels the shortest path climbs or descends: the sum of the level changes between
    /// its consecutive corners (0 on one floor; 0 for imported episodes that do not say).
    #[serde(default)]
    pub levels_crossed: u32,
    /// The route of a VLN episode (reference path, rooms, doors, instructions); `None` for
    /// the other tasks.
    #[serde(default)]
    pub route: Option<Box<vln::Route>>,
}

impl Episode {
    /// A PointGoal episode for a start pose and a goal given directly (a simulator reset
    /// to a pose rather than to a sampled episode), so the success test and the oracle work
    /// on it: no split, seed, route or door counts, and no geodesic distance (NaN).
    #[allow(clippy::too_many_arguments)]
    pub fn point(
        scene_id: &str,
        episode_id: &str,
        start: glam::Vec3,
        yaw: f32,
        goal: glam::Vec3,
        success_radius: f32,
        max_steps: u32,
    ) -> Episode {
        Episode {
            episode_id: episode_id.to_string(),
            scene_id: scene_id.to_string(),
            split: String::new(),
            task: Task::PointGoal,
            seed: 0,
            start_position: start.to_array(),
            start_yaw: yaw,
            goal: Goal::Point {
                position: goal.to_array(),
            },
            euclidean_distance: start.distance(goal),
            geodesic_distance: f32::NAN,
            path_num_doors: 0,
            path_num_rooms: 0,
            difficulty: Difficulty::Easy,
            success_radius,
            max_steps,
            levels_crossed: 0,
            route: None,
        }
    }

    /// Checks what later stages compute with: start, goal, target and view-point positions and
    /// the start yaw finite; the success radius finite and not negative; the distances not
    /// negative (NaN stands for "not known", as Habitat files without them give; a target whose
    /// three coordinates are all NaN is known by id only, as Habitat's `object_id`). Returns the
    /// first problem as (field, message), the field named as the Parquet column holding it.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        // The first coordinate that is not finite, named by its column.
        let point =
            |fields: [&'static str; 3], p: &[f32; 3]| match p.iter().position(|v| !v.is_finite()) {
                None => Ok(()),
                Some(k) => Err((fields[k], format!("{} is not finite", p[k]))),
            };
        point(["start_x", "start_y", "start_z"], &self.start_position)?;
        if !self.start_yaw.is_finite() {
            return Err(("start_yaw", format!("{} is not finite", self.start_yaw)));
        }
        match &self.goal {
            Goal::Point { position } => point(["goal_x", "goal_y", "goal_z"], position)?,
            Goal::Object { targets, .. } | Goal::Room { targets, .. } => {
                for (j, t) in targets.iter().enumerate() {
                    // All three NaN is a target known by id only (Habitat's `object_id`).
                    if !t.position.iter().all(|v| v.is_nan()) {
                        point(["goal_positions"; 3], &t.position)
                            .map_err(|(f, m)| (f, format!("target {j}: {m}")))?;
                    }
                    for (v, p) in t.view_points.iter().enumerate() {
                        point(["goal_view_points"; 3], p)
                            .map_err(|(f, m)| (f, format!("target {j}: view point {v}: {m}")))?;
                    }
                }
            }
        }
        if let Some(route) = &self.route {
            for (k, p) in route.path.iter().enumerate() {
                point(["route_path"; 3], p).map_err(|(f, m)| (f, format!("point {k}: {m}")))?;
            }
        }
        if !(self.success_radius.is_finite() && self.success_radius >= 0.0) {
            return Err((
                "success_radius",
                format!("{} is not a finite radius", self.success_radius),
            ));
        }
        for (field, d) in [
            ("euclidean_distance", self.euclidean_distance),
            ("geodesic_distance", self.geodesic_distance),
        ] {
            if d < 0.0 {
                return Err((field, format!("{d} is negative")));
            }
        }
        Ok(())
    }

    /// The same episode on variant `name` of its scene: the scene id becomes `<scene>@<name>`
    /// (replacing any variant it had) and the episode id follows it. Positions stay: variants
    /// that only remove clutter, open doors or retexture keep every start and goal walkable.
    pub fn on_variant(mut self, name: &str) -> Self {
        let scene = crate::scene::SceneRef::parse(&self.scene_id)
            .with_variant(Some(name))
            .to_string();
        if let Some(rest) = self.episode_id.strip_prefix(&format!("{}:", self.scene_id)) {
            self.episode_id = format!("{scene}:{rest}");
        } else {
            self.episode_id = format!("{scene}:{}", self.episode_id);
        }
        self.scene_id = scene;
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_episode_moves_to_a_variant_with_its_ids() {
        let e = Episode {
            episode_id: "h1@old:pointgoal:00003".into(),
            scene_id: "h1@old".into(),
            split: "val".into(),
            task: Task::PointGoal,
            seed: 1,
            start_position: [0.0; 3],
            start_yaw: 0.0,
            goal: Goal::Point {
                position: [1.0, 0.0, 1.0],
            },
            euclidean_distance: 1.0,
            geodesic_distance: 1.0,
            path_num_doors: 0,
            path_num_rooms: 1,
            difficulty: Difficulty::Easy,
            success_radius: 0.2,
            max_steps: 500,
            levels_crossed: 0,
            route: None,
        }
        .on_variant("empty");
        assert_eq!(e.scene_id, "h1@empty");
        assert_eq!(e.episode_id, "h1@empty:pointgoal:00003");
    }

    #[test]
    fn a_target_known_by_id_only_is_valid_but_a_partly_unknown_one_is_not() {
        let target = |position: [f32; 3]| GoalTarget {
            id: "4".into(),
            position,
            view_points: Vec::new(),
            room: None,
        };
        let mut e = Episode {
            episode_id: "h1:objectgoal:0".into(),
            scene_id: "h1".into(),
            split: "val".into(),
            task: Task::ObjectGoal,
            seed: 1,
            start_position: [0.0; 3],
            start_yaw: 0.0,
            goal: Goal::Object {
                category: "toilet".into(),
                targets: vec![target([f32::NAN; 3])],
            },
            euclidean_distance: f32::NAN,
            geodesic_distance: f32::NAN,
            path_num_doors: 0,
            path_num_rooms: 1,
            difficulty: Difficulty::Medium,
            success_radius: 1.0,
            max_steps: 500,
            levels_crossed: 0,
            route: None,
        };
        assert_eq!(e.validate(), Ok(()));
        for (bad, what) in [
            ([1.0, f32::NAN, 2.0], "target 0: NaN is not finite"),
            ([f32::INFINITY, 0.0, 0.0], "target 0: inf is not finite"),
        ] {
            e.goal = Goal::Object {
                category: "toilet".into(),
                targets: vec![target(bad)],
            };
            assert_eq!(e.validate(), Err(("goal_positions", what.to_string())));
        }
        e.goal = Goal::Object {
            category: "toilet".into(),
            targets: vec![target([1.0, 0.0, 2.0])],
        };
        e.geodesic_distance = -1.0;
        assert_eq!(
            e.validate(),
            Err(("geodesic_distance", "-1 is negative".to_string()))
        );
    }
}
