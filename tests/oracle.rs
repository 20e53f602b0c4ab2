//! The oracle on MINOS's continuous agents: on generated houses baked for MINOS's body it
//! reaches and stops on every episode, for MINOS's continuous agent and for the paper's
//! agent (forward / turn left / turn right only, which its plans then use alone). Episodes
//! that fail with an error count as failures in every summary. Doors on the way are counted.

use crate::common;

use std::collections::BTreeSet;
use std::path::Path;

use arrow::array::{Array, StringArray};
use common::baked_houses_for;
use minos::body::{AgentBody, AgentPreset, BodyRule};
use minos::episode::sample::SampleConfig;
use minos::episode::{Episode, Task};
use minos::generate::GenerateConfig;
use minos::io::image_codec::ImageEncoding;
use minos::pipeline::episodes::sample_scenes;
use minos::pipeline::rollout::{rollout, AgentKind, RunConfig};
use minos::progress::NoProgress;
use minos::render::RendererChoice;
use minos::run::metrics::Reward;
use minos::shard::Shard;
use minos::sim::{AgentConfig, SensorSuite};
use minos::store::DataDir;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

/// House sets baked for MINOS's body — two-room houses (the paper's "small" houses) and
/// bigger ones with closed doors and a second level — each with episodes of every task:
/// PointGoal at MINOS's 0.4 m and at 0.2 m, ObjectGoal (doors) and RoomGoal.
type HouseSet = (DataDir, Vec<Episode>);

fn data() -> &'static (tempfile::TempDir, Vec<HouseSet>) {
    static DATA: std::sync::OnceLock<(tempfile::TempDir, Vec<HouseSet>)> =
        std::sync::OnceLock::new();
    DATA.get_or_init(|| {
        let dir = common::shared_tempdir();
        let mut sets = Vec::new();
        for (sub, cfg) in [
            (
                "small",
                GenerateConfig {
                    houses: 4,
                    seed: 7,
                    rooms: (2, 2),
                    levels: (1, 1),
                    closed_door_prob: 0.0,
                    ..Default::default()
                },
            ),
            (
                "medium",
                GenerateConfig {
                    houses: 2,
                    seed: 11,
                    rooms: (3, 5),
                    levels: (1, 2),
                    closed_door_prob: 0.25,
                    ..Default::default()
                },
            ),
        ] {
            let (d, ids) = baked_houses_for(&dir.path().join(sub), &cfg, AgentPreset::Minos);
            let scenes: Vec<(String, String)> = ids
                .iter()
                .map(|id| (id.clone(), "val".to_string()))
                .collect();
            let mut episodes = Vec::new();
            for (task, radius, per_scene) in [
                (Task::PointGoal, 0.4, 6),
                (Task::PointGoal, 0.2, 3),
                (Task::ObjectGoal, 0.2, 2),
                (Task::RoomGoal, 0.2, 2),
            ] {
                let sample = SampleConfig {
                    task,
                    per_scene,
                    seed: 3 + (radius * 10.0) as u64,
                    success_radius: radius,
                    ..Default::default()
                };
                let batch = sample_scenes(
                    &d,
                    &scenes,
                    &sample,
                    BodyRule::strict(AgentBody::MINOS),
                    Shard::ALL,
                    &NoProgress,
                );
                episodes.extend(batch.episodes.into_iter().map(|mut e| {
                    // Episode ids stay unique across the two samplings of PointGoal.
                    e.episode_id = format!("{}:r{radius}", e.episode_id);
                    e
                }));
            }
            sets.push((d, episodes));
        }
        (dir, sets)
    })
}

fn config(data: &DataDir, out: &Path, body: AgentConfig) -> RunConfig {
    RunConfig {
        batch: None,
        data: data.clone(),
        out: out.to_path_buf(),
        agent: AgentKind::Oracle,
        agent_config: body,
        sensors: SensorSuite {
            cameras: vec![],
            contact: None,
        },
        renderer: RendererChoice::Cpu,
        max_steps: None,
        seed: 1,
        shard: Shard::ALL,
        resume: false,
        reward: Reward::Geodesic,
        encoding: ImageEncoding::Raw,
        lerobot: false,
        lerobot_video: None,
        rerun: None,
        allow_body_mismatch: false,
        provenance: Default::default(),
    }
}

/// Every action name of a run's trajectory table.
fn actions(out: &Path) -> BTreeSet<String> {
    let file = std::fs::File::open(out.join("trajectories.parquet")).unwrap();
    let reader = ParquetRecordBatchReaderBuilder::try_new(file)
        .unwrap()
        .build()
        .unwrap();
    let mut names = BTreeSet::new();
    for batch in reader {
        let batch = batch.unwrap();
        let col = batch
            .column_by_name("action")
            .unwrap()
            .as_any()
            .downcast_ref::<StringArray>()
            .unwrap();
        names.extend((0..col.len()).map(|i| col.value(i).to_string()));
    }
    names
}

fn oracle_reaches_every_episode(body: AgentConfig, name: &str) -> BTreeSet<String> {
    let dir = tempfile::tempdir().unwrap();
    let mut used = BTreeSet::new();
    for (k, (data, episodes)) in data().1.iter().enumerate() {
        for task in [Task::PointGoal, Task::ObjectGoal, Task::RoomGoal] {
            assert!(
                episodes.iter().filter(|e| e.task == task).count() >= 2,
                "too few {task:?} episodes"
            );
        }
        let out = dir.path().join(format!("{name}{k}"));
        let report = rollout(&config(data, &out, body), episodes, &NoProgress).unwrap();
        assert!(report.failures.is_empty(), "{name}: {:?}", report.failures);
        let all = &report.groups["all"];
        assert_eq!(all.episodes, episodes.len());
        assert_eq!(all.success, 1.0, "{name}: oracle success {}", all.success);
        assert!(all.spl >= 0.75, "{name}: oracle SPL {}", all.spl);
        used.extend(actions(&out));
    }
    used
}

#[test]
fn the_oracle_reaches_every_episode_with_minos_continuous_agent() {
    let used = oracle_reaches_every_episode(AgentConfig::minos_continuous(), "minos");
    assert!(
        used.contains("forward") && used.contains("stop"),
        "{used:?}"
    );
}

#[test]
fn the_papers_agent_plans_with_forward_and_turns_only() {
    let body = AgentConfig::preset(AgentPreset::MinosPaper);
    assert_eq!(body.action_names(), ["forward", "turn_left", "turn_right"]);
    assert_eq!(body.eye_height, 1.09);
    assert_eq!(body.body, AgentBody::MINOS);
    let used = oracle_reaches_every_episode(body, "paper");
    let allowed: BTreeSet<String> = ["forward", "turn_left", "turn_right", "stop"]
        .into_iter()
        .map(String::from)
        .collect();
    assert!(used.is_subset(&allowed), "{used:?}");
    assert!(used.contains("turn_left") || used.contains("turn_right"));
}

#[test]
fn the_papers_sensors_are_grey_and_90_degrees() {
    let suite = SensorSuite::for_preset(AgentPreset::MinosPaper, 84);
    let grey = suite
        .cameras
        .iter()
        .find(|c| c.modality == minos::render::Modality::Gray)
        .expect("a grey camera");
    assert_eq!((grey.vfov, grey.resolution), (90.0, [84, 84]));
    assert!(suite
        .cameras
        .iter()
        .all(|c| c.modality != minos::render::Modality::Color));
    assert_eq!(
        SensorSuite::for_preset(AgentPreset::Minos, 84),
        SensorSuite::minos(84)
    );
}

#[test]
fn episodes_that_fail_with_an_error_count_as_failures_in_every_summary() {
    let (data, episodes) = &data().1[0];
    let two: Vec<Episode> = episodes
        .iter()
        .filter(|e| e.task == Task::PointGoal)
        .take(2)
        .cloned()
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let body = AgentConfig::minos_continuous();
    let oracle = rollout(
        &config(data, &dir.path().join("oracle"), body),
        &two,
        &NoProgress,
    )
    .unwrap();
    assert_eq!(oracle.groups["all"].success, 1.0);
    // Replaying the oracle's first episode succeeds; the second has nothing to replay, so
    // the replay agent fails on it with an error.
    let mut replay =
        minos::io::tables::read_replay(&dir.path().join("oracle/trajectories.parquet")).unwrap();
    replay.remove(&two[1].episode_id);
    let mut cfg = config(data, &dir.path().join("replay"), body);
    cfg.agent = AgentKind::Replay(replay);
    let report = rollout(&cfg, &two, &NoProgress).unwrap();
    assert_eq!(report.failures.len(), 1, "{:?}", report.failures);
    assert_eq!(report.failures[0].0, two[1].episode_id);
    for group in ["all", "task=pointgoal"] {
        let g = &report.groups[group];
        assert_eq!((g.episodes, g.failed), (2, 1), "{group}");
        assert_eq!(g.success, 0.5, "{group}: never a rate over the survivors");
        assert!(g.spl <= 0.5, "{group}: SPL {}", g.spl);
    }
    let table = minos::run::metrics::render_table(&report.groups);
    let all = table
        .lines()
        .find(|l| l.starts_with("all "))
        .expect("an `all` row");
    let cells: Vec<&str> = all.split_whitespace().collect();
    assert_eq!(cells[1..4], ["2", "1", "50.0%"], "{table}");
    let metrics: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("replay/metrics.json")).unwrap())
            .unwrap();
    assert_eq!(metrics["groups"]["all"]["success"], 0.5);
    assert_eq!(metrics["groups"]["all"]["failed"], 1);
    let failure = &metrics["failures"][0];
    assert_eq!(failure["episode_id"], two[1].episode_id.as_str());
    assert_eq!(failure["task"], "pointgoal");
    assert!(failure["error"].as_str().unwrap().contains("replay"));
    // Shards merged count the failure in the same groups: the unsharded run's bytes.
    let mut shards = Vec::new();
    for i in 0..2 {
        let mut c = cfg.clone();
        c.out = dir.path().join(format!("shard{i}"));
        c.shard = Shard { index: i, count: 2 };
        rollout(&c, &two, &NoProgress).unwrap();
        shards.push(c.out);
    }
    let merged = dir.path().join("merged");
    minos::pipeline::merge::run::merge_runs(
        &shards,
        &minos::pipeline::merge::run::RunMerge {
            out: merged.clone(),
            rerun: None,
            command: vec![],
            lock: minos::lock::LockMode::Fail,
        },
        &NoProgress,
    )
    .unwrap();
    assert_eq!(
        String::from_utf8(std::fs::read(merged.join("metrics.json")).unwrap()).unwrap(),
        String::from_utf8(std::fs::read(dir.path().join("replay/metrics.json")).unwrap()).unwrap()
    );
}

#[test]
fn paths_between_rooms_count_the_doorway_they_pass() {
    // Two-room houses with every door open: a path from one room to the other passes the
    // door or arch joining them.
    let (data, episodes) = &data().1[0];
    let crossing: Vec<&Episode> = episodes
        .iter()
        .filter(|e| e.task == Task::PointGoal && e.path_num_rooms >= 2)
        .collect();
    assert!(
        crossing.len() >= 3,
        "{} episodes cross rooms",
        crossing.len()
    );
    let mut through_arches = 0;
    for e in crossing {
        assert!(
            e.path_num_doors >= 1,
            "{}: no doorway counted",
            e.episode_id
        );
        let grid = data
            .read_grid(&minos::scene::SceneRef::parse(&e.scene_id))
            .unwrap();
        // The house's rooms are joined by an arch when an arch stands over walkable floor.
        let arch_joined = grid
            .span_objects
            .iter()
            .any(|&(_, o)| grid.objects[o as usize].arch);
        through_arches += usize::from(arch_joined);
    }
    assert!(
        through_arches > 0,
        "no path between rooms joined by an arch"
    );
}
