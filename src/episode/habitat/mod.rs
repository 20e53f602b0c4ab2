//! Interchange with Habitat-Lab's episode datasets (`PointNav-v1` / `ObjectNav-v1` layout):
//! [`export_habitat`] writes a split as Habitat lays it out, [`import_habitat`] reads one
//! Habitat episode file (ours, or real Habitat / SemExp files) back into [`Episode`](super::Episode)s.
//!
//! This module only translates files; it does not check that episodes are navigable in the
//! scene, and it never loads scenes.
//!
//! # Export layout
//!
//! ```text
//! DIR/<split>/<split>.json.gz            {"episodes": []} (+ category maps for ObjectNav)
//! DIR/<split>/content/<scene>.json.gz    {"episodes": [...]} (+ category maps, "goals_by_category")
//! ```
//!
//! Every episode given goes into the split named by the `split` argument (callers filter by
//! [`Episode::split`](super::Episode::split) first). Each episode becomes:
//!
//! - `episode_id` (string), `scene_id` = prefix + the scene id + suffix ([`SceneIdStyle`]).
//!   Habitat resolves `scene_id` against its `scenes_dir`, so users typically pass a prefix
//!   such as `data/scene_datasets/minos/` and the scene files' extension as suffix (`.glb`).
//! - `start_position` [x, y, z]; `start_rotation` [x, y, z, w] = [0, sin(yaw/2), 0, cos(yaw/2)].
//! - `info`: `geodesic_distance`, `euclidean_distance` (null when NaN), `difficulty`, and, as a
//!   minos extension that Habitat ignores (it keeps `info` as a free dictionary),
//!   `minos_episode_id` (the episode id again: Habitat's ObjectNav loader replaces
//!   `episode_id` by the episode's index in its file), `task`, `split`, `seed`,
//!   `path_num_doors`, `path_num_rooms`, `success_radius`, `max_steps`, `levels_crossed`
//!   (levels the shortest path climbs or descends; read back on import, 0 when absent).
//! - PointGoal: `goals` = `[{"position", "radius"}]` with the success radius.
//! - ObjectGoal: `object_category` and an empty `goals` list; the targets go to the content
//!   file's top-level `goals_by_category[key]` as `{"object_id", "object_name",
//!   "object_name_id", "object_category", "room_id", "room_name", "position", "view_points":
//!   [{"agent_state": {"position", "rotation"}, "iou": 1.0}]}`, as Habitat's ObjectNav loader
//!   expects. The key is Habitat's ([`goals_key`]): the last path component of `scene_id`,
//!   extension included, `_`, the category. `object_name` is the id again; `object_name_id`
//!   numbers the file's distinct `object_id`s in sorted order from 0; `room_id` and
//!   `room_name` are the id and MINOS class of the room the object stands in (the room most of
//!   the spans it counts as reached from lie in; null when none is known, e.g. for imported
//!   episodes). A view point's
//!   rotation faces the target's position.
//! - RoomGoal (minos extension): exported like ObjectGoal with `object_category` = the room
//!   class and the rooms as goals (`object_id`, `object_name` and `room_id` = the room id,
//!   `room_name` = the class), marked by `info.task = "roomgoal"`. The view points are
//!   walkable points inside the room, facing its position (the walkable point nearest its
//!   centre). Habitat's ObjectNav loader reads it as an object-goal episode, and its
//!   `DistanceToGoal` measures to those view points.
//!
//! Habitat stores one goal list per scene and category, so when several episodes of the same
//! scene and category list different targets, the exported list is their union (first
//! occurrence of each id wins) and every episode reads the union back.
//!
//! When any episode has an object or room goal, the split file and every content file carry
//! `category_to_task_category_id` and `category_to_scene_annotation_category_id`: the sorted
//! category (and room class) names of the whole split numbered from 0, the same numbers in
//! both maps (minos has no scene annotation ids). Habitat's ObjectNav loader needs them in any
//! file it loads on its own.
//!
//! Habitat's two loaders read one task each: a content file mixing PointGoal with object or
//! room episodes loads in neither (the command line exports one task at a time).
//!
//! Output is deterministic: fixed key order, episodes in the order given (grouped by scene,
//! scenes sorted), f32 values written as their exact f64 value, gzip header mtime 0. Files are
//! written atomically. Non-finite positions are refused.
//!
//! # Import
//!
//! [`import_habitat`] reads one `.json.gz` or plain `.json` file (told apart by content) with a
//! top-level `episodes` list, in any of these shapes: the content files written here, Habitat
//! PointNav episodes (`goals: [{position, radius}]`), Habitat ObjectNav content files
//! (`object_category` + `goals_by_category`), and SemExp ObjectNav episodes (`object_category`,
//! integer `object_id`, `floor_id`, no goal positions). `start_rotation` may be [x, y, z, w]
//! (Habitat) or [w, x, y, z] (SemExp, numpy-quaternion order): see [`yaw_from_quaternion`].
//!
//! Fields a source lacks get these defaults:
//!
//! | field | default |
//! |---|---|
//! | `episode_id` | `info.minos_episode_id`, else `episode_id` when it contains `:` (a minos id), else `<scene>:habitat:<id>` |
//! | `scene_id` | last component of the file's `scene_id`, without a `.glb`/`.gltf`/`.ply`/`.obj`/`.json`/`.house`/`.navmesh` extension |
//! | `task` | `info.task`, else `objectgoal` when `object_category` is present, else `pointgoal` |
//! | targets | `goals_by_category["<basename(scene_id)>_<category>"]` (Habitat's key, extension kept), else `goals_by_category["<scene>_<category>"]` (the key without it), else the episode's `goals`, else one target with the episode's `object_id` and an unknown (NaN) position |
//! | `euclidean_distance` | `info.euclidean_distance`, else computed from the start to the goal (the nearest target with a known position), else NaN |
//! | `geodesic_distance` | `info.geodesic_distance`, else NaN |
//! | `difficulty` | `info.difficulty`, else from the geodesic distance (below 3 m easy, below 6 m medium, else hard; medium when unknown) |
//! | `success_radius` | `info.success_radius`, else the first goal's `radius` (PointGoal), else 0.2 m (PointGoal) / 0.1 m (object and room goals) |
//! | `max_steps` | `info.max_steps`, else 500 |
//! | `split`, `seed`, `path_num_doors`, `path_num_rooms` | `info.*`, else empty / 0 |
//!
//! PointNav episodes with several goals keep the first. Bad entries are errors naming the
//! file, the episode index and the field (`val.json.gz: episodes[12].start_position: expected
//! 3 numbers`).

use super::interchange::yaw_from_y_w;
use crate::escape::escape_controls;
use crate::file_error::FileError;

/// Success radius (m) of imported PointNav episodes without one (Habitat's PointNav default).
pub const DEFAULT_POINT_SUCCESS_RADIUS: f32 = 0.2;

/// Success radius (m) of imported object/room episodes without one (Habitat's ObjectNav
/// default success distance).
pub const DEFAULT_OBJECT_SUCCESS_RADIUS: f32 = 0.1;

/// Largest non-Y axis component (of the normalised quaternion) still read as a pure yaw.
const YAW_AXIS_TOLERANCE: f64 = 1e-3;

/// Scene file extensions stripped from a Habitat `scene_id` to get the minos scene id.
const SCENE_EXTENSIONS: [&str; 7] = ["glb", "gltf", "ply", "obj", "json", "house", "navmesh"];

/// Errors exporting or importing Habitat episode files.
#[derive(Debug, thiserror::Error)]
pub enum HabitatError {
    /// File system error.
    #[error(transparent)]
    Io(#[from] FileError),
    /// The file is not JSON, or not an object with an `episodes` list.
    #[error("{path}: {}", escape_controls(.message))]
    Shape {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// A bad value in one record of the file.
    #[error(
        "{path}: {}: {}",
        escape_controls(&join(.record, .field)),
        escape_controls(.message)
    )]
    Entry {
        /// The file.
        path: String,
        /// The record (`episodes[12]`, `goals_by_category["x_chair"][0]`).
        record: String,
        /// The field in the record.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// An episode that cannot be exported.
    #[error(
        "{path}: episode `{}`: {}",
        escape_controls(.episode_id),
        escape_controls(.message)
    )]
    Export {
        /// The file it was bound for.
        path: String,
        /// The episode.
        episode_id: String,
        /// What is wrong.
        message: String,
    },
    /// The scene ids an export was asked to write are unusable (a scene suffix holding a
    /// path separator, say): the file they were bound for, and the rule they break.
    #[error("{path}")]
    SceneIds {
        /// The file.
        path: String,
        /// What is wrong.
        #[source]
        source: crate::invalid::Invalid,
    },
}

/// `record.field`, or `record[i]` for an element.
fn join(record: &str, field: &str) -> String {
    if field.starts_with('[') {
        format!("{record}{field}")
    } else {
        format!("{record}.{field}")
    }
}

/// The component order of a `start_rotation` quaternion.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QuaternionConvention {
    /// `[x, y, z, w]` (Habitat, Magnum).
    Xyzw,
    /// `[w, x, y, z]` (numpy-quaternion, SemExp).
    Wxyz,
}

/// The yaw of a quaternion known to be a rotation about +Y, whatever its component order: a
/// yaw quaternion has its x and z components ≈ 0 (within 1e-3 after normalisation), so if
/// `q` read as [x, y, z, w] has x ≈ z ≈ 0 it is that, else if read as [w, x, y, z] it has
/// x ≈ z ≈ 0 it is that; otherwise (or for a zero quaternion) `None`. The yaw is in
/// `(−π, π]`.
pub fn yaw_from_quaternion(q: [f64; 4]) -> Option<(f32, QuaternionConvention)> {
    let norm = q.iter().map(|c| c * c).sum::<f64>().sqrt();
    if !norm.is_finite() || norm < 1e-6 {
        return None;
    }
    let n = q.map(|c| c / norm);
    let small = |c: f64| c.abs() <= YAW_AXIS_TOLERANCE;
    if small(n[0]) && small(n[2]) {
        Some((yaw_from_y_w(n[1], n[3]), QuaternionConvention::Xyzw))
    } else if small(n[1]) && small(n[3]) {
        Some((yaw_from_y_w(n[2], n[0]), QuaternionConvention::Wxyz))
    } else {
        None
    }
}

mod export;
mod import;

pub use export::{export_habitat, goals_key, SceneIdStyle};
pub use import::import_habitat;
#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;
    use std::path::{Path, PathBuf};

    use serde_json::Value;

    use super::import::scene_name;
    use crate::episode::format::tests::sample_episodes;
    use crate::episode::interchange::{
        distance, read_text_bytes, yaw_to_quaternion, DEFAULT_MAX_STEPS,
    };
    use crate::episode::{Difficulty, Episode, Goal, GoalTarget, Task};
    use std::f32::consts::{PI, TAU};

    fn gz(bytes: &[u8]) -> Vec<u8> {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        e.write_all(bytes).unwrap();
        e.finish().unwrap()
    }

    fn read_json(path: &Path) -> Value {
        serde_json::from_slice(&read_text_bytes(path).unwrap()).unwrap()
    }

    fn yaw_diff(a: f32, b: f32) -> f32 {
        let d = (a - b).rem_euclid(TAU);
        d.min(TAU - d)
    }

    fn assert_close3(a: [f32; 3], b: [f32; 3], tol: f32) {
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() <= tol, "{a:?} vs {b:?}");
        }
    }

    fn prefixed(prefix: &str) -> SceneIdStyle {
        SceneIdStyle {
            prefix: prefix.into(),
            suffix: String::new(),
        }
    }

    /// Point and object episodes whose yaws span the whole circle, incl. values ≥ π.
    fn episodes_for_export() -> Vec<Episode> {
        let s = sample_episodes();
        let mut out = Vec::new();
        for (k, yaw) in [0.0f32, 1.0, 3.5, 6.0, -2.0, PI].into_iter().enumerate() {
            let mut e = s[k % 3].clone();
            e.episode_id = format!("{}:{}:{k:05}", e.scene_id, e.task.name());
            e.start_yaw = yaw;
            out.push(e);
        }
        out
    }

    #[test]
    fn export_then_import_gives_the_same_episodes() {
        let dir = tempfile::tempdir().unwrap();
        let eps = episodes_for_export();
        let files = export_habitat(
            dir.path(),
            "val",
            &prefixed("data/scene_datasets/minos/"),
            &eps,
        )
        .unwrap();
        let names: Vec<String> = files
            .iter()
            .map(|f| f.strip_prefix(dir.path()).unwrap().display().to_string())
            .collect();
        assert_eq!(
            names,
            [
                "val/val.json.gz",
                "val/content/house_a.json.gz",
                "val/content/house_b@dark.json.gz"
            ]
        );
        let mut back = import_habitat(&files[1]).unwrap();
        back.extend(import_habitat(&files[2]).unwrap());
        // Export groups by scene; compare in that order.
        let mut expected = eps.clone();
        expected.sort_by(|a, b| a.scene_id.cmp(&b.scene_id));
        assert_eq!(back.len(), expected.len());
        for (b, e) in back.iter().zip(&expected) {
            assert_eq!(b.episode_id, e.episode_id);
            assert_eq!(b.scene_id, e.scene_id);
            assert_eq!(b.task, e.task);
            assert_close3(b.start_position, e.start_position, 1e-5);
            assert!(
                yaw_diff(b.start_yaw, e.start_yaw) < 1e-4,
                "{} vs {}",
                b.start_yaw,
                e.start_yaw
            );
            assert!(b.start_yaw > -PI && b.start_yaw <= PI);
            assert_eq!(b.goal, e.goal);
            assert_eq!(b.euclidean_distance, e.euclidean_distance);
            assert_eq!(b.geodesic_distance, e.geodesic_distance);
            assert_eq!(
                (
                    b.split.as_str(),
                    b.seed,
                    b.difficulty,
                    b.success_radius,
                    b.max_steps
                ),
                (
                    e.split.as_str(),
                    e.seed,
                    e.difficulty,
                    e.success_radius,
                    e.max_steps
                )
            );
            assert_eq!(
                (b.path_num_doors, b.path_num_rooms),
                (e.path_num_doors, e.path_num_rooms)
            );
        }
    }

    #[test]
    fn export_layout_matches_habitat() {
        let dir = tempfile::tempdir().unwrap();
        let eps = episodes_for_export();
        let files = export_habitat(dir.path(), "train", &SceneIdStyle::default(), &eps).unwrap();
        let split = read_json(&files[0]);
        assert_eq!(split["episodes"], serde_json::json!([]));
        assert_eq!(
            split["category_to_task_category_id"],
            serde_json::json!({"chair": 0, "kitchen": 1})
        );
        assert_eq!(
            split["category_to_scene_annotation_category_id"],
            split["category_to_task_category_id"]
        );

        let content = read_json(&files[1]);
        let episodes = content["episodes"].as_array().unwrap();
        // Episode 0 (PointGoal, yaw 0) and 1 (ObjectGoal, yaw 1) are in house_a.
        let p = &episodes[0];
        assert_eq!(p["scene_id"], "house_a");
        assert_eq!(p["start_rotation"], serde_json::json!([0.0, 0.0, 0.0, 1.0]));
        assert_eq!(p["goals"][0]["radius"], f64::from(0.2f32));
        assert!(p.get("object_category").is_none());
        let o = &episodes[1];
        assert_eq!(o["object_category"], "chair");
        assert_eq!(o["goals"], serde_json::json!([]));
        let q = o["start_rotation"].as_array().unwrap();
        assert!((q[1].as_f64().unwrap() - 0.5f64.sin()).abs() < 1e-9);
        assert!((q[3].as_f64().unwrap() - 0.5f64.cos()).abs() < 1e-9);
        let goals = content["goals_by_category"]["house_a_chair"]
            .as_array()
            .unwrap();
        assert_eq!(goals.len(), 3);
        assert_eq!(goals[0]["object_id"], "0_12");
        assert_eq!(goals[0]["object_category"], "chair");
        let vp = &goals[0]["view_points"][0];
        assert_eq!(vp["iou"], 1.0);
        assert_eq!(
            vp["agent_state"]["position"],
            serde_json::json!([0.0, 0.05f32 as f64, 1.0])
        );
        // The view point at (0, _, 1) faces the target at (0.5, _, 1): +X, i.e. yaw −π/2.
        let rot = vp["agent_state"]["rotation"].as_array().unwrap();
        let rot: Vec<f64> = rot.iter().map(|v| v.as_f64().unwrap()).collect();
        let (yaw, conv) = yaw_from_quaternion([rot[0], rot[1], rot[2], rot[3]]).unwrap();
        assert_eq!(conv, QuaternionConvention::Xyzw);
        assert!((yaw + std::f32::consts::FRAC_PI_2).abs() < 1e-6);

        let room = read_json(&files[2]);
        assert_eq!(room["episodes"][0]["info"]["task"], "roomgoal");
        assert_eq!(room["episodes"][0]["object_category"], "kitchen");
        assert!(room["goals_by_category"]["house_b@dark_kitchen"].is_array());

        // Deterministic: a second export gives identical bytes; gzip mtime is 0.
        let dir2 = tempfile::tempdir().unwrap();
        let files2 = export_habitat(dir2.path(), "train", &SceneIdStyle::default(), &eps).unwrap();
        for (a, b) in files.iter().zip(&files2) {
            let (a, b) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
            assert_eq!(a, b);
            assert_eq!(&a[..2], &[0x1f, 0x8b]);
            assert_eq!(&a[4..8], &[0, 0, 0, 0]);
        }
    }

    #[test]
    fn union_of_targets_per_scene_and_category() {
        let dir = tempfile::tempdir().unwrap();
        let mut eps = sample_episodes();
        eps.truncate(2);
        let mut other = eps[1].clone();
        other.episode_id = "house_a:objectgoal:00009".into();
        if let Goal::Object { targets, .. } = &mut other.goal {
            targets.truncate(1);
            targets.push(GoalTarget {
                id: "0_99".into(),
                position: [9.0, 0.5, 9.0],
                view_points: vec![],
                room: None,
            });
        }
        eps.push(other);
        let files = export_habitat(dir.path(), "val", &SceneIdStyle::default(), &eps).unwrap();
        let back = import_habitat(&files[1]).unwrap();
        let ids = |e: &Episode| match &e.goal {
            Goal::Object { targets, .. } => targets.iter().map(|t| t.id.clone()).collect(),
            _ => Vec::new(),
        };
        let union = vec!["0_12", "0_13", "0_14", "0_99"];
        assert_eq!(ids(&back[1]), union);
        assert_eq!(ids(&back[2]), union);
    }

    #[test]
    fn a_scene_suffix_extends_scene_ids_and_goal_keys_alike() {
        let dir = tempfile::tempdir().unwrap();
        let eps = episodes_for_export();
        let style = SceneIdStyle {
            prefix: "data/scene_datasets/minos/".into(),
            suffix: ".glb".into(),
        };
        let files = export_habitat(dir.path(), "val", &style, &eps).unwrap();
        let content = read_json(&files[1]);
        let ep = &content["episodes"][1];
        assert_eq!(ep["scene_id"], "data/scene_datasets/minos/house_a.glb");
        assert_eq!(ep["info"]["minos_episode_id"], ep["episode_id"]);
        let keys: Vec<&String> = content["goals_by_category"]
            .as_object()
            .unwrap()
            .keys()
            .collect();
        assert_eq!(keys, ["house_a.glb_chair"]);
        // The category maps are in every content file, equal to the split file's.
        let split = read_json(&files[0]);
        for f in &files[1..] {
            let c = read_json(f);
            for map in [
                "category_to_task_category_id",
                "category_to_scene_annotation_category_id",
            ] {
                assert_eq!(c[map], split[map], "{map}");
            }
        }
        // Goals: name, number, room fields.
        let goals = content["goals_by_category"]["house_a.glb_chair"]
            .as_array()
            .unwrap();
        let numbers: Vec<u64> = goals
            .iter()
            .map(|g| g["object_name_id"].as_u64().unwrap())
            .collect();
        assert_eq!(numbers, [0, 1, 2]);
        assert_eq!(goals[1]["object_name"], "0_13");
        assert!(goals[1]["room_id"].is_null() && goals[1]["room_name"].is_null());
        let room = read_json(&files[2]);
        let g = &room["goals_by_category"]["house_b@dark.glb_kitchen"][0];
        assert_eq!(
            (&g["room_id"], &g["room_name"]),
            (&g["object_id"], &g["object_category"])
        );
        assert_eq!(g["room_name"], "kitchen");
        assert_eq!(g["view_points"].as_array().map(Vec::len), Some(3));
        // Everything reads back under the scene's own id.
        let mut back = import_habitat(&files[1]).unwrap();
        back.extend(import_habitat(&files[2]).unwrap());
        let mut expected = eps.clone();
        expected.sort_by(|a, b| a.scene_id.cmp(&b.scene_id));
        for (b, e) in back.iter().zip(&expected) {
            assert_eq!((&b.episode_id, &b.scene_id), (&e.episode_id, &e.scene_id));
            assert_eq!(b.goal, e.goal);
        }
        // A suffix with a path separator would change the key's basename: refused.
        let bad = SceneIdStyle {
            prefix: String::new(),
            suffix: "/x.glb".into(),
        };
        let err = export_habitat(dir.path(), "val", &bad, &eps).unwrap_err();
        // The file it was bound for, the rule as the source.
        assert!(
            matches!(&err, HabitatError::SceneIds { path, .. } if path.ends_with("val.json.gz"))
        );
        let line = crate::escape::error_line(&err);
        assert!(
            line.contains("val.json.gz: ") && line.contains("path separator"),
            "{line}"
        );
    }

    #[test]
    fn habitat_numbered_ids_and_extensionless_keys_still_import() {
        let dir = tempfile::tempdir().unwrap();
        // As habitat-lab re-saves a file (`episode_id` = index), and an older minos file whose
        // scene_id was given an extension by hand (its key lacks it).
        let path = dir.path().join("old.json");
        let text = r#"{"episodes": [
            {"episode_id": "0", "scene_id": "minos/h1.glb", "start_position": [0, 0, 0],
             "start_rotation": [0, 0, 0, 1], "object_category": "bed", "goals": [],
             "info": {"minos_episode_id": "h1:objectgoal:00007"}},
            {"episode_id": "1", "scene_id": "minos/h1.glb", "start_position": [0, 0, 0],
             "start_rotation": [0, 0, 0, 1], "object_category": "bed", "goals": []}],
          "goals_by_category": {"h1_bed": [{"object_id": "0_3", "position": [1, 0, 1]}]}}"#;
        std::fs::write(&path, text).unwrap();
        let back = import_habitat(&path).unwrap();
        assert_eq!(back[0].episode_id, "h1:objectgoal:00007");
        assert_eq!(back[1].episode_id, "h1:habitat:1");
        assert_eq!(back[0].scene_id, "h1");
        match &back[1].goal {
            Goal::Object { targets, .. } => assert_eq!(targets[0].id, "0_3"),
            other => panic!("{other:?}"),
        }
        // Habitat's key (with the extension) wins over the key without it.
        let both = text.replace(
            r#""goals_by_category": {"#,
            r#""goals_by_category": {"h1.glb_bed": [{"object_id": "0_5", "position": [2, 0, 2]}], "#,
        );
        std::fs::write(&path, both).unwrap();
        match &import_habitat(&path).unwrap()[0].goal {
            Goal::Object { targets, .. } => assert_eq!(targets[0].id, "0_5"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn quaternion_conventions_are_detected() {
        let yaw = 2.2f32;
        let (s, c) = ((f64::from(yaw) / 2.0).sin(), (f64::from(yaw) / 2.0).cos());
        let (y1, c1) = yaw_from_quaternion([0.0, s, 0.0, c]).unwrap();
        assert_eq!(c1, QuaternionConvention::Xyzw);
        assert!((y1 - yaw).abs() < 1e-6);
        let (y2, c2) = yaw_from_quaternion([c, 0.0, s, 0.0]).unwrap();
        assert_eq!(c2, QuaternionConvention::Wxyz);
        assert!((y2 - yaw).abs() < 1e-6);
        // SemExp's first Collierville rotation, [w, x, y, z].
        let (y3, c3) =
            yaw_from_quaternion([-0.22018953669540486, 0.0, 0.9754571071707168, 0.0]).unwrap();
        assert_eq!(c3, QuaternionConvention::Wxyz);
        let q = yaw_to_quaternion(y3);
        // q equals ±(0, 0.975, 0, −0.220): the same rotation.
        assert!((q[1] * -0.22018953669540486 - q[3] * 0.9754571071707168).abs() < 1e-6);
        // Identity and half turn in [x, y, z, w].
        assert_eq!(yaw_from_quaternion([0.0, 0.0, 0.0, 1.0]).unwrap().0, 0.0);
        assert!((yaw_from_quaternion([0.0, 1.0, 0.0, 0.0]).unwrap().0 - PI).abs() < 1e-6);
        // Not a yaw in either order, and degenerate input.
        assert!(yaw_from_quaternion([0.5, 0.5, 0.5, 0.5]).is_none());
        assert!(yaw_from_quaternion([0.3, 0.0, 0.0, 0.954]).is_none());
        assert!(yaw_from_quaternion([0.0; 4]).is_none());
        assert!(yaw_from_quaternion([f64::NAN, 0.0, 0.0, 1.0]).is_none());
    }

    #[test]
    fn non_yaw_rotation_is_an_error_naming_the_episode() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tilted.json");
        let good = r#"{"episode_id": "a", "scene_id": "s.glb", "start_position": [0, 0, 0],
            "start_rotation": [0, 0, 0, 1], "goals": [{"position": [1, 0, 1]}]}"#;
        let bad = good.replace("[0, 0, 0, 1]", "[0.5, 0.5, 0.5, 0.5]");
        std::fs::write(&path, format!(r#"{{"episodes": [{good}, {bad}]}}"#)).unwrap();
        let err = import_habitat(&path).unwrap_err().to_string();
        assert!(
            err.contains("tilted.json: episodes[1].start_rotation: "),
            "{err}"
        );
        assert!(err.contains("not a rotation about +Y"), "{err}");
    }

    #[test]
    fn bad_entries_name_file_episode_and_field() {
        let dir = tempfile::tempdir().unwrap();
        let ok = r#"{"episode_id": 3, "scene_id": "x/s.glb", "start_position": [0, 0, 0],
            "start_rotation": [0, 0, 0, 1], "goals": [{"position": [3, 0, 4], "radius": 0.36}]}"#;
        let cases: Vec<(&str, String, &str)> = vec![
            (
                "start_position",
                ok.replace(
                    "\"start_position\": [0, 0, 0]",
                    "\"start_position\": [0, 0]",
                ),
                "episodes[12].start_position: expected 3 numbers",
            ),
            (
                "position",
                ok.replace("[3, 0, 4]", "[3, \"a\", 4]"),
                "episodes[12].goals[0].position: expected 3 numbers",
            ),
            (
                "goals",
                ok.replace("[{\"position\": [3, 0, 4], \"radius\": 0.36}]", "[]"),
                "episodes[12].goals: expected at least one goal",
            ),
            (
                "scene",
                ok.replace("\"x/s.glb\"", "7"),
                "episodes[12].scene_id: expected a string, found a number",
            ),
            (
                "difficulty",
                ok.replace(
                    "\"goals\"",
                    "\"info\": {\"difficulty\": \"extreme\"}, \"goals\"",
                ),
                "episodes[12].info.difficulty: unknown difficulty `extreme`",
            ),
            (
                // Text quoted from the file stays on one line.
                "newline",
                ok.replace(
                    "\"goals\"",
                    "\"info\": {\"difficulty\": \"ex\\ntreme\"}, \"goals\"",
                ),
                "episodes[12].info.difficulty: unknown difficulty `ex\\ntreme`",
            ),
            (
                "huge",
                ok.replace("[3, 0, 4]", "[3, 1e39, 4]"),
                "episodes[12].goals[0].position: [3.0, inf, 4.0] is out of range for 32-bit floats",
            ),
            (
                "radius",
                ok.replace("0.36", "-1"),
                "episodes[12].success_radius: -1 is not a finite radius",
            ),
            (
                "notobject",
                "[1, 2]".to_string(),
                "episodes[12]: expected an object, found a list",
            ),
            (
                "object",
                ok.replace("\"goals\"", "\"object_category\": \"bed\", \"goals_x\""),
                "episodes[12].object_category: no goals",
            ),
        ];
        for (name, bad, expected) in cases {
            let path = dir.path().join(format!("{name}.json.gz"));
            let mut list = vec![ok.to_string(); 12];
            list.push(bad);
            let text = format!("{{\"episodes\": [{}]}}", list.join(","));
            std::fs::write(&path, gz(text.as_bytes())).unwrap();
            let err = import_habitat(&path).unwrap_err().to_string();
            let want = format!("{}: {expected}", path.display());
            assert!(err.starts_with(&want), "{err}\n  wanted {want}");
        }
        // The good episode alone imports, with the documented defaults.
        let path = dir.path().join("ok.json");
        std::fs::write(&path, format!("{{\"episodes\": [{ok}]}}")).unwrap();
        let e = &import_habitat(&path).unwrap()[0];
        assert_eq!(e.episode_id, "s:habitat:3");
        assert_eq!(e.scene_id, "s");
        assert_eq!(e.euclidean_distance, 5.0);
        assert!(e.geodesic_distance.is_nan());
        assert_eq!(e.difficulty, Difficulty::Medium);
        assert_eq!(e.success_radius, 0.36);
        assert_eq!(e.max_steps, DEFAULT_MAX_STEPS);
        // Not an episodes file at all.
        std::fs::write(&path, "[1, 2]").unwrap();
        let err = import_habitat(&path).unwrap_err().to_string();
        assert!(err.contains("`episodes` list"), "{err}");
    }

    #[test]
    fn scene_names_drop_only_scene_extensions() {
        assert_eq!(
            scene_name("gibson_semantic//Collierville.glb"),
            "Collierville"
        );
        assert_eq!(
            scene_name("mp3d/17DRP5sb8fy/17DRP5sb8fy.glb"),
            "17DRP5sb8fy"
        );
        assert_eq!(scene_name("data/minos/house_b@dark"), "house_b@dark");
        assert_eq!(scene_name("my.scene"), "my.scene");
        assert_eq!(scene_name("my.scene.gltf"), "my.scene");
    }

    /// `MINOS_REAL_DATA` = the shared datasets folder; the test is skipped when unset.
    fn real_data() -> Option<PathBuf> {
        match std::env::var_os("MINOS_REAL_DATA") {
            Some(d) => Some(PathBuf::from(d).join("habitat_episodes/objectnav_gibson_v1.1_semexp")),
            None => {
                println!("skipped: MINOS_REAL_DATA is not set");
                None
            }
        }
    }

    #[test]
    fn real_semexp_and_habitat_files_import() {
        let Some(dir) = real_data() else { return };
        let count = |p: &Path| read_json(p)["episodes"].as_array().unwrap().len();

        let obj_path = dir.join("Collierville_episodes.json.gz");
        let obj = import_habitat(&obj_path).unwrap();
        assert_eq!(obj.len(), count(&obj_path));
        assert_eq!(obj.len(), 200);
        let e = &obj[0];
        assert_eq!(e.episode_id, "Collierville:habitat:0");
        assert_eq!(e.scene_id, "Collierville");
        assert_eq!(e.task, Task::ObjectGoal);
        assert_eq!(
            e.start_position,
            [
                -0.3094837963581085f64 as f32,
                0.026745080947875977f64 as f32,
                -3.483508586883545f64 as f32
            ]
        );
        // [w, x, y, z] = [−0.2202, 0, 0.9755, 0]: the yaw reproduces it up to sign.
        let q = yaw_to_quaternion(e.start_yaw);
        assert!((q[1] * -0.22018953669540486 - q[3] * 0.9754571071707168).abs() < 1e-6);
        match &e.goal {
            Goal::Object { category, targets } => {
                assert_eq!(category, "toilet");
                assert_eq!(targets.len(), 1);
                assert_eq!(targets[0].id, "4");
                assert!(targets[0].position[0].is_nan());
            }
            other => panic!("expected an object goal, got {other:?}"),
        }
        assert!(e.euclidean_distance.is_nan() && e.geodesic_distance.is_nan());
        assert_eq!(e.success_radius, DEFAULT_OBJECT_SUCCESS_RADIUS);
        let chairs = obj
            .iter()
            .filter(|e| matches!(&e.goal, Goal::Object { category, .. } if category == "chair"))
            .count();
        assert!(chairs > 0 && chairs < 200);

        let point_path = dir.join("Collierville.glb.json.gz");
        let point = import_habitat(&point_path).unwrap();
        assert_eq!((point.len(), count(&point_path)), (1, 1));
        let p = &point[0];
        assert_eq!(p.task, Task::PointGoal);
        assert_eq!(p.scene_id, "Collierville");
        assert_eq!(p.geodesic_distance, 4.395505905151367f64 as f32);
        assert_eq!(p.difficulty, Difficulty::Medium);
        assert_eq!(p.success_radius, 0.2);
        let goal = [
            0.5122390389442444f64 as f32,
            0.03894525766372681f64 as f32,
            1.1862249374389648f64 as f32,
        ];
        assert_eq!(p.goal, Goal::Point { position: goal });
        assert!((p.euclidean_distance - distance(p.start_position, goal)).abs() < 1e-6);
        assert!(
            (f64::from(p.start_yaw) - 2.0 * 0.02223112828807172f64.atan2(0.9997528579279178)).abs()
                < 1e-6
        );

        let empty = import_habitat(&dir.join("val.json.gz")).unwrap();
        assert!(empty.is_empty());
    }
}
