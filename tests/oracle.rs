//! The oracle on MINOS's continuous agents: on generated houses baked for MINOS's body it
//! reaches and stops on every episode, for MINOS's continuous agent and for the paper's
//! agent (forward / turn left / turn right only, which its plans then use alone). Episodes
//! that fail with an error count as failures in every summary. Doors on the way are counted.
//! From a pocket of floor the grid closes off but the body squeezes into, it finds the way
//! out and on to the goal.

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

/// A room split by a wall (z 4.9–5.0, x 0–7; the way round is past x = 7) with an alcove on
/// the start's side of it (x 1.5–2.9, z 5.0–6.3) whose far wall has a 0.4 m gap (x 2.0–2.4):
/// wide enough for MINOS's body (radius 0.1), closed on a grid baked for a body of radius
/// 0.25, so the alcove is a pocket of floor the grid's distance field does not reach.
fn pocket_sim(agent: AgentConfig) -> minos::sim::Simulator {
    pocket_sim_with_gap(agent, 2.0, 2.4)
}

/// [`pocket_sim`] with the gap in the alcove's far wall from x = `gap_from` to `gap_to`.
fn pocket_sim_with_gap(agent: AgentConfig, gap_from: f32, gap_to: f32) -> minos::sim::Simulator {
    use common::scenes::SceneBuilder;
    use minos::navmesh::NavParams;
    use minos::scene::RoomClass;

    let wall = |x0: f32, z0: f32, x1: f32, z1: f32| ([x0, 0.0, z0], [x1, 2.7, z1]);
    let scene = SceneBuilder::new("pocket")
        .room(
            "r",
            RoomClass::Hallway,
            [0.0, 0.0, 10.0, 10.0],
            0.0,
            &[
                wall(0.0, 4.9, 7.0, 5.0),
                wall(1.4, 5.0, 1.5, 6.4),
                wall(2.9, 5.0, 3.0, 6.4),
                wall(1.4, 6.3, gap_from, 6.4),
                wall(gap_to, 6.3, 3.0, 6.4),
            ],
        )
        .build();
    let fat = AgentBody {
        radius: 0.25,
        ..agent.body
    };
    blind_sim(&scene, &NavParams::for_body(fat), agent)
}

/// A blind simulator of `agent` in `scene`, on a grid built with `params` (baked for another
/// body than the agent's where a test needs the grid and the body to disagree).
fn blind_sim(
    scene: &minos::scene::Scene,
    params: &minos::navmesh::NavParams,
    agent: AgentConfig,
) -> minos::sim::Simulator {
    use minos::render::Renderer;
    use minos::sim::{SceneAssets, Simulator};
    use std::sync::Arc;

    let grid = minos::navmesh::build::build(scene, params).unwrap();
    let assets = Arc::new(SceneAssets::new_allowing_body_mismatch(scene, grid, &agent).unwrap());
    let renderer = Arc::new(Renderer::new(RendererChoice::Cpu, &assets.render).unwrap());
    let blind = SensorSuite {
        cameras: vec![],
        contact: None,
    };
    Simulator::new(assets, renderer, agent, blind, 500, 0)
}

#[test]
fn the_oracle_leads_the_agent_out_of_a_pocket_the_grid_closes_off() {
    leads_out_of_the_pocket(pocket_sim(AgentConfig::minos_paper()), 2.2);
}

#[test]
fn the_oracle_finds_a_gap_with_no_room_to_spare_out_of_a_pocket() {
    // The body slides along what it touches, so it enters pockets through gaps a lattice of
    // collision-free points has no point in: here 1 cm to spare, its centre's way through
    // at x 2.10-2.11 for MINOS's body (radius 0.1 m), where the 2 cm lattice from x = 2.195
    // has points at 2.095 and 2.115.
    // Before, the walk out found no way and the oracle answered "no plan" at once (a random
    // drive of MINOS's agent in door-small-furnished's houses: 385 states of 16,000 in one
    // such pocket).
    let radius = AgentConfig::minos_paper().body.radius;
    let sim = pocket_sim_with_gap(AgentConfig::minos_paper(), 2.0, 2.01 + 2.0 * radius);
    leads_out_of_the_pocket(sim, 2.195);
}

#[test]
fn the_oracle_leads_a_discrete_agent_out_of_a_pocket_too() {
    // Before, the discrete planner answered "no plan" at once from a pocket: a random
    // walk of Habitat's agent in generated furnished houses ended one in about 3,000 steps
    // in such a pocket, and DAgger's states there went unlabelled.
    leads_out_of_the_pocket(pocket_sim(AgentConfig::habitat()), 2.2);
}

/// From inside the pocket of `sim` ([`pocket_sim_with_gap`]) at x = `x`, facing three ways,
/// the oracle leaves through the gap and stops at the goal behind the wall, with forward and
/// turns only.
fn leads_out_of_the_pocket(mut sim: minos::sim::Simulator, x: f32) {
    use glam::Vec3;
    use minos::run::agents::{Agent, Decision};
    use minos::run::oracle::OracleAgent;
    use minos::sim::{Actions, GoalSpec, Observation};

    let goal = Vec3::new(2.2, 0.0, 2.0);
    let inside = Vec3::new(x, 0.0, 5.6);
    let outside = Vec3::new(2.2, 0.0, 8.0);
    let grid = &sim.assets().grid;
    // The pocket: walkable floor on another island than the room's; the body fits the gap.
    let (pocket, room) = (grid.island_of(inside), grid.island_of(outside));
    assert!(
        pocket.is_some() && room.is_some() && pocket != room,
        "{pocket:?} {room:?}"
    );
    assert!(grid.island_of(goal) == room);
    for yaw in [0.0, 1.5, std::f32::consts::PI] {
        let id = format!("pocket:{yaw}");
        let episode = Episode::point("pocket", &id, inside, yaw, goal, 0.4, 500);
        sim.reset(
            inside,
            yaw,
            Some(GoalSpec::Point(goal)),
            &episode.episode_id,
        );
        // Before, the planner took the straight line to the goal for the distance from a
        // pocket, led the agent to the alcove's wall nearest the goal and found no plan.
        let mut oracle = OracleAgent::new();
        oracle.reset(&episode, &sim).unwrap();
        let mut left_the_pocket = false;
        let mut steps = 0;
        loop {
            match oracle.decide(&Observation::blind(), &sim).unwrap() {
                Decision::Stop => break,
                Decision::Act(a) => {
                    assert!(
                        a == Actions::single("forward").unwrap()
                            || a == Actions::single("turn_left").unwrap()
                            || a == Actions::single("turn_right").unwrap(),
                        "{a:?}"
                    );
                    sim.advance(a);
                }
            }
            steps += 1;
            let p = Vec3::from_array(sim.state().position);
            left_the_pocket |= p.z > 6.5;
            assert!(
                steps < 500,
                "yaw {yaw}: not at the goal after 500 steps, at {p}"
            );
        }
        let end = Vec3::from_array(sim.state().position);
        assert!(left_the_pocket, "yaw {yaw}: never left through the gap");
        assert!(end.distance(goal) <= 0.4, "yaw {yaw}: stopped at {end}");
    }
}

#[test]
fn the_oracle_plans_when_momentum_carries_the_agent_into_a_pocket() {
    use glam::Vec3;
    use minos::run::agents::{Agent, Decision};
    use minos::run::oracle::OracleAgent;
    use minos::sim::{Actions, GoalSpec, Observation};

    // Running at the alcove's gap from the room (yaw 0 faces -z): a few presses in, every
    // action leads into the pocket, since momentum carries the body on.
    let start = Vec3::new(2.2, 0.0, 7.6);
    let goal = Vec3::new(5.0, 0.0, 8.5);
    let mut sim = pocket_sim(AgentConfig::minos_paper());
    let forward = Actions::single("forward").unwrap();
    let mut on_field_at_speed = 0;
    for presses in 0..12 {
        let id = format!("run-in:{presses}");
        let episode = Episode::point("pocket", &id, start, 0.0, goal, 0.4, 500);
        sim.reset(start, 0.0, Some(GoalSpec::Point(goal)), &episode.episode_id);
        for _ in 0..presses {
            sim.advance(forward);
        }
        let here = Vec3::from_array(sim.state().position);
        if sim.goal_field_distance(here).is_some() && sim.state().velocity[1] < -0.1 {
            on_field_at_speed += 1;
        }
        let mut oracle = OracleAgent::new();
        oracle
            .reset(&episode, &sim)
            .unwrap_or_else(|e| panic!("{presses} presses, at {here}: {e}"));
        let mut steps = 0;
        while let Decision::Act(a) = oracle.decide(&Observation::blind(), &sim).unwrap() {
            sim.advance(a);
            steps += 1;
            assert!(
                steps < 500,
                "{presses} presses: not at the goal after 500 steps"
            );
        }
        let end = Vec3::from_array(sim.state().position);
        assert!(
            end.distance(goal) <= 0.4,
            "{presses} presses: stopped at {end}"
        );
    }
    assert!(
        on_field_at_speed > 0,
        "never on the field at speed towards the gap"
    );
}

/// A room split by a wall at z 4.9–5.0 with one 0.19 m gap (x 5.0–5.19): open on a 2 cm grid
/// baked for a body of radius 0.03, too narrow for MINOS's (radius 0.1).
fn too_narrow_sim() -> minos::sim::Simulator {
    use common::scenes::SceneBuilder;
    use minos::navmesh::NavParams;
    use minos::scene::RoomClass;

    let wall = |x0: f32, z0: f32, x1: f32, z1: f32| ([x0, 0.0, z0], [x1, 2.7, z1]);
    let scene = SceneBuilder::new("narrow")
        .room(
            "r",
            RoomClass::Hallway,
            [0.0, 0.0, 10.0, 10.0],
            0.0,
            &[wall(0.0, 4.9, 5.0, 5.0), wall(5.19, 4.9, 10.0, 5.0)],
        )
        .build();
    let agent = AgentConfig::minos_paper();
    let thin = AgentBody {
        radius: 0.03,
        ..agent.body
    };
    let params = NavParams {
        cell_size: 0.02,
        ..NavParams::for_body(thin)
    };
    blind_sim(&scene, &params, agent)
}

#[test]
fn the_oracle_gives_up_on_a_goal_its_body_cannot_reach() {
    use glam::Vec3;
    use minos::run::agents::{Agent, AgentError};
    use minos::run::oracle::OracleAgent;
    use minos::sim::GoalSpec;

    // The grid's field reaches the goal through the gap; the body does not pass it. The
    // planner's searches fail on the field, where no pocket and no momentum is to blame:
    // the plan ends there ("no plan"), rather than searching on from state to state.
    let (start, goal) = (Vec3::new(5.095, 0.0, 7.0), Vec3::new(5.095, 0.0, 3.0));
    let mut sim = too_narrow_sim();
    let here = sim.assets().grid.island_of(start);
    assert!(here.is_some() && sim.assets().grid.island_of(goal) == here);
    let episode = Episode::point("narrow", "narrow:0", start, 0.0, goal, 0.4, 500);
    sim.reset(start, 0.0, Some(GoalSpec::Point(goal)), &episode.episode_id);
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(OracleAgent::new().reset(&episode, &sim));
    });
    let answer = rx
        .recv_timeout(std::time::Duration::from_secs(120))
        .expect("the planner still searching after two minutes");
    assert!(matches!(answer, Err(AgentError::NoPlan(_))), "{answer:?}");
}
