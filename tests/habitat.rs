//! Habitat-Lab export on generated houses: every task round-trips with a scene suffix, room
//! goals carry view points inside their room facing its centre, the files follow habitat-lab's
//! episode classes field by field, and — where Python can import habitat-lab — its own
//! `PointNavDatasetV1` / `ObjectNavDatasetV1` load them.
//!
//! That last test runs `tests/python/habitat_check.py` with `$MINOS_HABITAT_PYTHON` (else
//! `python3`) and skips, saying why, when it cannot import habitat-lab. habitat-lab 0.3.3
//! imports on Python 3.9/3.10 only (3.11's dataclasses reject its config defaults), e.g.
//! `python3.9 -m venv V && V/bin/pip install habitat-lab==0.3.320250127`, then
//! `MINOS_HABITAT_PYTHON=V/bin/python cargo test --release --test suite habitat::`.

use crate::common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use common::baked_houses;
use minos::body::{AgentBody, BodyRule};
use minos::episode::habitat::{export_habitat, import_habitat, yaw_from_quaternion, SceneIdStyle};
use minos::episode::interchange::read_text_bytes;
use minos::episode::sample::SampleConfig;
use minos::episode::vln::export::export_vlnce;
use minos::episode::vln::tokens::{tokenize, TOKENS_PER_INSTRUCTION};
use minos::episode::{Episode, Goal, Task};
use minos::generate::GenerateConfig;
use minos::navmesh::NavGrid;
use minos::pipeline::episodes::sample_scenes;
use minos::progress::NoProgress;
use minos::shard::Shard;
use minos::store::DataDir;
use serde_json::Value;

const TASKS: [Task; 3] = [Task::PointGoal, Task::ObjectGoal, Task::RoomGoal];
const PREFIX: &str = "data/scene_datasets/minos/";
const SUFFIX: &str = ".glb";

/// A baked DATA folder of generated houses, the episodes of each task on them (all in the
/// `val` subset), and their Habitat export with `PREFIX` and `SUFFIX` under `habitat/<task>`.
struct Fixture {
    dir: tempfile::TempDir,
    episodes: Vec<(Task, Vec<Episode>)>,
    /// VLN episodes, exported as VLN-CE under `habitat/vln`.
    vln: Vec<Episode>,
}

fn fixture() -> &'static Fixture {
    static F: std::sync::OnceLock<Fixture> = std::sync::OnceLock::new();
    F.get_or_init(|| {
        let dir = common::shared_tempdir();
        let cfg = GenerateConfig {
            houses: 3,
            seed: 14,
            rooms: (4, 7),
            levels: (1, 1),
            closed_door_prob: 0.0,
            ..Default::default()
        };
        let (data, ids) = baked_houses(dir.path(), &cfg);
        let scenes: Vec<(String, String)> =
            ids.into_iter().map(|id| (id, "val".to_string())).collect();
        let style = SceneIdStyle {
            prefix: PREFIX.into(),
            suffix: SUFFIX.into(),
        };
        let mut episodes = Vec::new();
        for task in TASKS {
            let sample = SampleConfig {
                task,
                per_scene: 4,
                seed: 3,
                categories: vec!["door".into(), "arch".into(), "bed".into()],
                ..SampleConfig::default()
            };
            let batch = sample_scenes(
                &data,
                &scenes,
                &sample,
                BodyRule::strict(AgentBody::HABITAT),
                Shard::ALL,
                &NoProgress,
            );
            assert!(
                batch.total >= 4,
                "{}: only {} episodes",
                task.name(),
                batch.total
            );
            export_habitat(
                &dir.path().join("habitat").join(task.name()),
                "val",
                &style,
                &batch.episodes,
            )
            .unwrap();
            episodes.push((task, batch.episodes));
        }
        let vln = sample_scenes(
            &data,
            &scenes,
            &SampleConfig {
                task: Task::Vln,
                per_scene: 4,
                seed: 3,
                min_geodesic: 3.0,
                min_rooms: 2,
                success_radius: 3.0,
                ..SampleConfig::default()
            },
            BodyRule::strict(AgentBody::HABITAT),
            Shard::ALL,
            &NoProgress,
        )
        .episodes;
        assert!(vln.len() >= 4, "only {} VLN episodes", vln.len());
        export_vlnce(&dir.path().join("habitat").join("vln"), "val", &style, &vln).unwrap();
        Fixture { dir, episodes, vln }
    })
}

fn export_dir(task: Task) -> PathBuf {
    fixture().dir.path().join("habitat").join(task.name())
}

fn content_files(task: Task) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(export_dir(task).join("val/content"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    files
}

fn read_json(path: &Path) -> Value {
    serde_json::from_slice(&read_text_bytes(path).unwrap()).unwrap()
}

fn grid(scene: &str) -> NavGrid {
    DataDir::new(fixture().dir.path().join("DATA"))
        .read_grid(&minos::scene::SceneRef::parse(scene))
        .unwrap()
}

#[test]
fn every_task_round_trips_with_a_scene_suffix() {
    for (task, eps) in &fixture().episodes {
        let mut back = Vec::new();
        for f in content_files(*task) {
            back.extend(import_habitat(&f).unwrap());
        }
        // Export groups by scene in sorted order, as the batch is.
        assert_eq!(back.len(), eps.len(), "{}", task.name());
        for (mut b, e) in back.into_iter().zip(eps) {
            let d = (b.start_yaw - e.start_yaw).rem_euclid(std::f32::consts::TAU);
            assert!(d.min(std::f32::consts::TAU - d) < 1e-4, "{}", e.episode_id);
            b.start_yaw = e.start_yaw;
            assert_eq!(&b, e);
        }
        // Habitat's own key: the basename of scene_id with its extension, then the category.
        for f in content_files(*task) {
            let content = read_json(&f);
            for ep in content["episodes"].as_array().unwrap() {
                let scene_id = ep["scene_id"].as_str().unwrap();
                assert!(scene_id.starts_with(PREFIX) && scene_id.ends_with(SUFFIX));
                assert_eq!(ep["info"]["minos_episode_id"], ep["episode_id"]);
                if let Some(cat) = ep["object_category"].as_str() {
                    let scene = scene_id.rsplit('/').next().unwrap();
                    let key = format!("{scene}_{cat}");
                    assert!(key.contains(".glb_"), "{key}");
                    assert!(content["goals_by_category"][&key].is_array(), "{key}");
                }
            }
        }
    }
}

#[test]
fn object_goals_name_the_room_their_object_stands_in() {
    let (_, eps) = &fixture().episodes[1];
    let mut checked = 0;
    for e in eps {
        let Goal::Object { targets, .. } = &e.goal else {
            panic!("{}: not an object goal", e.episode_id)
        };
        let g = grid(&e.scene_id);
        for t in targets {
            let room = t
                .room
                .as_ref()
                .unwrap_or_else(|| panic!("{}: no room", t.id));
            // Independently: the room holding the most of the spans (those in a room) from
            // which the object counts as reached.
            let object = g.objects.iter().position(|o| o.id == t.id).unwrap() as u32;
            let mut counts = std::collections::BTreeMap::new();
            for span in g.object_spans(object, e.success_radius) {
                let room = g.spans[span as usize].room;
                if (room as usize) < g.rooms.len() {
                    *counts.entry(room).or_insert(0usize) += 1;
                }
            }
            let most = counts.values().copied().max().unwrap();
            let r = g.rooms.iter().position(|r| r.id == room.id).unwrap() as u32;
            assert_eq!(counts.get(&r), Some(&most), "{}: {room:?}", t.id);
            let class = minos::scene::RoomClass::from_label(&room.class).unwrap();
            assert_eq!(class.index(), g.rooms[r as usize].class);
            checked += 1;
        }
    }
    assert!(checked > 0);
    // Exported as Habitat's room_id / room_name.
    for f in content_files(Task::ObjectGoal) {
        for goals in read_json(&f)["goals_by_category"]
            .as_object()
            .unwrap()
            .values()
        {
            for goal in goals.as_array().unwrap() {
                assert!(goal["room_id"].is_string(), "{goal}");
                assert!(goal["room_name"].is_string(), "{goal}");
            }
        }
    }
}

#[test]
fn room_goals_have_view_points_inside_the_room_facing_its_centre() {
    let (_, eps) = &fixture().episodes[2];
    let mut checked = 0;
    for e in eps {
        let Goal::Room { targets, .. } = &e.goal else {
            panic!("{}: not a room goal", e.episode_id)
        };
        let g = grid(&e.scene_id);
        for t in targets {
            assert!(!t.view_points.is_empty() && t.view_points.len() <= 16);
            let room = g.rooms.iter().position(|r| r.id == t.id).unwrap() as u32;
            for v in &t.view_points {
                let span = g.snap(glam::Vec3::from_array(*v)).unwrap();
                assert_eq!(g.spans[span as usize].room, room, "{} {v:?}", t.id);
                checked += 1;
            }
        }
    }
    assert!(checked > 0);
    // Exported rotations face the target's position.
    for f in content_files(Task::RoomGoal) {
        let content = read_json(&f);
        for goals in content["goals_by_category"].as_object().unwrap().values() {
            for goal in goals.as_array().unwrap() {
                let p: Vec<f64> = (0..3)
                    .map(|k| goal["position"][k].as_f64().unwrap())
                    .collect();
                for v in goal["view_points"].as_array().unwrap() {
                    let s = &v["agent_state"];
                    let q: Vec<f64> = (0..4).map(|k| s["rotation"][k].as_f64().unwrap()).collect();
                    let (yaw, _) = yaw_from_quaternion([q[0], q[1], q[2], q[3]]).unwrap();
                    let (dx, dz) = (
                        p[0] - s["position"][0].as_f64().unwrap(),
                        p[2] - s["position"][2].as_f64().unwrap(),
                    );
                    if dx.hypot(dz) < 1e-6 {
                        continue;
                    }
                    // Forward is −Z turned by the yaw: (−sin yaw, −cos yaw).
                    let yaw = f64::from(yaw);
                    let cos = (-yaw.sin() * dx - yaw.cos() * dz) / dx.hypot(dz);
                    assert!(cos > 1.0 - 1e-5, "view point {v} does not face {p:?}");
                }
            }
        }
    }
}

/// Field names of habitat-lab 0.3.3's attrs classes (`habitat/core/dataset.py`,
/// `habitat/tasks/nav/nav.py`, `habitat/tasks/nav/object_nav_task.py`,
/// `habitat/core/simulator.py`): the loaders pass each JSON object as keyword arguments, so a
/// key outside these lists raises `TypeError`.
mod schema {
    /// `Episode` (with `BaseEpisode`) and `NavigationEpisode`.
    pub const NAVIGATION_EPISODE: &[&str] = &[
        "episode_id",
        "scene_id",
        "scene_dataset_config",
        "additional_obj_config_paths",
        "start_position",
        "start_rotation",
        "info",
        "goals",
        "start_room",
        "shortest_paths",
    ];
    /// What `ObjectGoalNavEpisode` adds.
    pub const OBJECT_GOAL_NAV_EPISODE: &[&str] = &["object_category"];
    /// `NavigationGoal`.
    pub const NAVIGATION_GOAL: &[&str] = &["position", "radius"];
    /// What `ObjectGoal` adds.
    pub const OBJECT_GOAL: &[&str] = &[
        "object_id",
        "object_name",
        "object_name_id",
        "object_category",
        "room_id",
        "room_name",
        "view_points",
    ];
    /// `ObjectViewLocation`.
    pub const OBJECT_VIEW_LOCATION: &[&str] = &["agent_state", "iou"];
    /// `AgentState`.
    pub const AGENT_STATE: &[&str] = &["position", "rotation"];
    /// Fields with `not_none_validator` and no usable default.
    pub const EPISODE_REQUIRED: &[&str] = &[
        "episode_id",
        "scene_id",
        "start_position",
        "start_rotation",
        "goals",
    ];
}

fn keys_within(what: &str, v: &Value, allowed: &[&[&str]]) {
    let obj = v
        .as_object()
        .unwrap_or_else(|| panic!("{what}: not an object"));
    for k in obj.keys() {
        assert!(
            allowed.iter().any(|a| a.contains(&k.as_str())),
            "{what}: field `{k}` is not in habitat-lab's class"
        );
    }
}

fn numbers(what: &str, v: &Value, n: usize) {
    let a = v.as_array().unwrap_or_else(|| panic!("{what}: not a list"));
    assert_eq!(a.len(), n, "{what}");
    assert!(a.iter().all(Value::is_f64), "{what}: {v}");
}

#[test]
fn exported_files_follow_habitat_labs_episode_classes() {
    use schema::*;
    for task in TASKS {
        let split = read_json(&export_dir(task).join("val/val.json.gz"));
        assert_eq!(split["episodes"], serde_json::json!([]));
        let objects = task != Task::PointGoal;
        let mut episode_fields = vec![NAVIGATION_EPISODE];
        if objects {
            episode_fields.push(OBJECT_GOAL_NAV_EPISODE);
        }
        for f in content_files(task) {
            let content = read_json(&f);
            let name = f.display().to_string();
            if objects {
                // ObjectNavDatasetV1.from_json reads both maps from every file it loads.
                let maps = &content["category_to_task_category_id"];
                assert_eq!(maps, &split["category_to_task_category_id"], "{name}");
                assert_eq!(maps, &content["category_to_scene_annotation_category_id"]);
            }
            for (i, ep) in content["episodes"].as_array().unwrap().iter().enumerate() {
                let what = format!("{name}: episodes[{i}]");
                keys_within(&what, ep, &episode_fields);
                for k in EPISODE_REQUIRED {
                    assert!(!ep[*k].is_null(), "{what}: `{k}` missing");
                }
                assert!(ep["episode_id"].is_string() && ep["scene_id"].is_string());
                numbers(&what, &ep["start_position"], 3);
                numbers(&what, &ep["start_rotation"], 4);
                assert!(ep["info"].is_object());
                let goals = ep["goals"].as_array().unwrap();
                if !objects {
                    assert_eq!(goals.len(), 1, "{what}");
                    keys_within(&what, &goals[0], &[NAVIGATION_GOAL]);
                    numbers(&what, &goals[0]["position"], 3);
                    continue;
                }
                assert!(
                    goals.is_empty(),
                    "{what}: goals belong in goals_by_category"
                );
                let cat = ep["object_category"].as_str().unwrap();
                assert!(content["category_to_task_category_id"][cat].is_u64());
                let base = ep["scene_id"].as_str().unwrap().rsplit('/').next().unwrap();
                let list = content["goals_by_category"][format!("{base}_{cat}")]
                    .as_array()
                    .unwrap_or_else(|| panic!("{what}: no goals for its key"));
                assert!(!list.is_empty());
            }
            let mut numbers_seen = BTreeSet::new();
            for (key, list) in content["goals_by_category"]
                .as_object()
                .into_iter()
                .flatten()
            {
                for (j, g) in list.as_array().unwrap().iter().enumerate() {
                    let what = format!("{name}: goals_by_category[{key}][{j}]");
                    keys_within(&what, g, &[NAVIGATION_GOAL, OBJECT_GOAL]);
                    assert!(g["object_id"].is_string(), "{what}");
                    numbers(&what, &g["position"], 3);
                    numbers_seen.insert(g["object_name_id"].as_u64().unwrap());
                    if task == Task::RoomGoal {
                        assert_eq!(g["room_id"], g["object_id"], "{what}");
                        assert_eq!(g["room_name"], g["object_category"], "{what}");
                    }
                    let views = g["view_points"].as_array().unwrap();
                    assert!(!views.is_empty(), "{what}: no view points");
                    for v in views {
                        keys_within(&what, v, &[OBJECT_VIEW_LOCATION]);
                        keys_within(&what, &v["agent_state"], &[AGENT_STATE]);
                        numbers(&what, &v["agent_state"]["position"], 3);
                        numbers(&what, &v["agent_state"]["rotation"], 4);
                    }
                }
            }
            // object_name_id numbers the file's distinct goals from 0.
            if objects {
                let n = numbers_seen.len() as u64;
                assert_eq!(numbers_seen, (0..n).collect(), "{name}");
            }
        }
    }
}

/// The Python that runs habitat-lab: `$MINOS_HABITAT_PYTHON`, else `python3`.
fn habitat_python() -> String {
    std::env::var("MINOS_HABITAT_PYTHON").unwrap_or_else(|_| "python3".into())
}

#[test]
fn habitat_labs_own_loaders_read_the_exports() {
    let python = habitat_python();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/habitat_check.py");
    let out = fixture().dir.path().join("habitat");
    let run = std::process::Command::new(&python)
        .arg(&script)
        .arg(&out)
        .arg("val")
        .arg(SUFFIX)
        .output();
    let run = match run {
        Ok(r) => r,
        Err(e) => {
            common::skip(format!(
                "cannot run `{python}` ({e}); set MINOS_HABITAT_PYTHON"
            ));
            return;
        }
    };
    let stdout = String::from_utf8_lossy(&run.stdout);
    if run.status.code() == Some(3) {
        common::skip(format!(
            "`{python}` cannot import habitat-lab ({}); set MINOS_HABITAT_PYTHON",
            stdout.trim()
        ));
        return;
    }
    assert!(
        run.status.success(),
        "habitat-lab rejected the export:\n{stdout}\n{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let summary: Value = serde_json::from_str(stdout.lines().last().unwrap_or("")).unwrap();
    println!("habitat-lab {}: {summary}", summary["habitat_lab"]);
    for (task, eps) in &fixture().episodes {
        let s = &summary[task.name()];
        assert_eq!(s["episodes_via_split"].as_u64(), Some(eps.len() as u64));
        assert_eq!(s["episodes_alone"].as_u64(), Some(eps.len() as u64));
        let ids: Vec<&str> = eps.iter().map(|e| e.episode_id.as_str()).collect();
        let theirs: Vec<&str> = s["minos_ids"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap())
            .collect();
        assert_eq!(theirs, ids, "{}", task.name());
        if *task != Task::PointGoal {
            let views: usize = eps
                .iter()
                .map(|e| match &e.goal {
                    Goal::Object { targets, .. } | Goal::Room { targets, .. } => {
                        targets.iter().map(|t| t.view_points.len()).sum()
                    }
                    Goal::Point { .. } => 0,
                })
                .sum();
            assert!(views > 0);
            assert_eq!(
                s["view_points"].as_u64(),
                Some(views as u64),
                "{}",
                task.name()
            );
        }
    }
    // VLN-CE: one episode per instruction, in order, the same texts.
    let s = &summary["vln"];
    let texts: Vec<String> = fixture()
        .vln
        .iter()
        .flat_map(|e| e.route.as_ref().unwrap().instructions.clone())
        .collect();
    assert_eq!(s["episodes_via_split"].as_u64(), Some(texts.len() as u64));
    let theirs: Vec<&str> = s["instructions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(theirs, texts);
    assert_eq!(s["trajectories"].as_u64(), Some(fixture().vln.len() as u64));
}

/// habitat-lab 0.3.3's `VLNEpisode` attributes and `InstructionData` fields.
const VLN_EPISODE: &[&str] = &[
    "episode_id",
    "scene_id",
    "scene_dataset_config",
    "additional_obj_config_paths",
    "start_position",
    "start_rotation",
    "info",
    "goals",
    "start_room",
    "shortest_paths",
    "reference_path",
    "instruction",
    "trajectory_id",
];
const INSTRUCTION_DATA: &[&str] = &["instruction_text", "instruction_tokens"];

#[test]
fn vlnce_export_follows_habitat_labs_vln_episode_and_r2r_tokens() {
    let file = read_json(&fixture().dir.path().join("habitat/vln/val/val.json.gz"));
    let words: Vec<&str> = file["instruction_vocab"]["word_list"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    assert_eq!(&words[..2], &["<pad>", "<unk>"]);
    let episodes = file["episodes"].as_array().unwrap();
    let mut k = 0;
    for (t, e) in fixture().vln.iter().enumerate() {
        let route = e.route.as_ref().unwrap();
        for text in &route.instructions {
            let ep = &episodes[k];
            k += 1;
            let what = format!("episodes[{k}]");
            keys_within(&what, ep, &[VLN_EPISODE]);
            keys_within(&what, &ep["instruction"], &[INSTRUCTION_DATA]);
            assert_eq!(ep["episode_id"].as_u64(), Some(k as u64));
            assert_eq!(ep["trajectory_id"].as_u64(), Some(t as u64 + 1));
            assert_eq!(
                ep["instruction"]["instruction_text"].as_str(),
                Some(text.as_str())
            );
            // Tokens: the vocabulary's words of R2R's tokens, padded with <pad>.
            let tokens: Vec<&str> = ep["instruction"]["instruction_tokens"]
                .as_array()
                .unwrap()
                .iter()
                .map(|i| words[i.as_u64().unwrap() as usize])
                .collect();
            assert_eq!(tokens.len(), TOKENS_PER_INSTRUCTION);
            let expected = tokenize(text);
            assert_eq!(&tokens[..expected.len()], expected.as_slice());
            assert!(tokens[expected.len()..].iter().all(|w| *w == "<pad>"));
            // The reference path runs from the start to the goal.
            let path = ep["reference_path"].as_array().unwrap();
            // Compared as the f32s the episode holds: serde_json's default float parser
            // (no `float_roundtrip`) may read a 17-digit number one f64 ulp off.
            let first: Vec<f32> = path[0]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap() as f32)
                .collect();
            assert_eq!(first, e.start_position);
            assert_eq!(path.last().unwrap(), &ep["goals"][0]["position"]);
            assert_eq!(ep["goals"][0]["radius"].as_f64(), Some(3.0));
            assert_eq!(ep["info"]["levels_crossed"].as_u64(), Some(0));
            assert!(ep["scene_id"].as_str().unwrap().ends_with(SUFFIX));
        }
    }
    assert_eq!(k, episodes.len());
}
