//! Rollouts: the oracle succeeds on every reachable episode with a high SPL, random agents are
//! measured alongside; Parquet outputs read back equal the simulator's observations; replays
//! reproduce poses; an interrupted run resumed gives identical bytes.

use crate::common;

use std::path::Path;
use std::sync::Arc;

use arrow::array::{Array, BinaryArray, Float32Array, StringArray, UInt32Array};
use common::{baked_houses, every_task_episodes};
use minos::episode::{Episode, Task};
use minos::generate::GenerateConfig;
use minos::io::image_codec::ImageEncoding;
use minos::pipeline::rollout::{rollout, AgentKind, EpisodeError, EpisodeFailure, RunConfig};
use minos::progress::NoProgress;
use minos::render::RendererChoice;
use minos::run::agents::Decision;
use minos::run::metrics::Reward;
use minos::shard::Shard;
use minos::sim::{AgentConfig, SensorSuite};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

fn data() -> &'static (tempfile::TempDir, Vec<Episode>) {
    static DATA: std::sync::OnceLock<(tempfile::TempDir, Vec<Episode>)> =
        std::sync::OnceLock::new();
    DATA.get_or_init(|| {
        let dir = common::shared_tempdir();
        let (data, ids) = baked_houses(
            dir.path(),
            &GenerateConfig {
                houses: 5,
                seed: 31,
                rooms: (3, 6),
                levels: (1, 2),
                closed_door_prob: 0.25,
                ..Default::default()
            },
        );
        let scenes: Vec<(String, String)> =
            ids.into_iter().map(|id| (id, "val".to_string())).collect();
        let episodes = every_task_episodes(&data, &scenes, 4, 2);
        (dir, episodes)
    })
}

fn config(out: &Path, agent: AgentKind, sensors: SensorSuite) -> RunConfig {
    RunConfig {
        batch: None,
        data: minos::store::DataDir::new(data().0.path().join("DATA")),
        out: out.to_path_buf(),
        agent,
        agent_config: AgentConfig::habitat(),
        sensors,
        renderer: RendererChoice::Cpu,
        max_steps: None,
        seed: 5,
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

/// The first `n` episodes of the shared data set whose task passes `keep`.
fn first_episodes(keep: impl Fn(Task) -> bool, n: usize) -> Vec<Episode> {
    data()
        .1
        .iter()
        .filter(|e| keep(e.task))
        .take(n)
        .cloned()
        .collect()
}

fn blind() -> SensorSuite {
    SensorSuite {
        cameras: vec![],
        contact: SensorSuite::minos(8).contact,
    }
}

#[test]
fn the_oracle_succeeds_on_every_episode_and_random_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let episodes = &data().1;
    assert!(episodes.len() >= 40, "{} episodes", episodes.len());
    let report = rollout(
        &config(&dir.path().join("oracle"), AgentKind::Oracle, blind()),
        episodes,
        &NoProgress,
    )
    .unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let all = &report.groups["all"];
    assert_eq!(all.episodes, episodes.len());
    assert_eq!(all.success, 1.0, "oracle success {}", all.success);
    assert!(all.spl >= 0.9, "oracle SPL {}", all.spl);
    let random = rollout(
        &config(&dir.path().join("random"), AgentKind::Random, blind()),
        episodes,
        &NoProgress,
    )
    .unwrap();
    assert!(
        random.groups["all"].success < 0.5,
        "random success {}",
        random.groups["all"].success
    );
    let metrics: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("random/metrics.json")).unwrap())
            .unwrap();
    assert!(metrics["groups"]["task=pointgoal"]["success"].is_number());
}

/// The first record batch of a Parquet file.
fn first_batch(path: &Path) -> arrow::array::RecordBatch {
    ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(path).unwrap())
        .unwrap()
        .build()
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
}

fn column<'a, T: 'static>(batch: &'a arrow::array::RecordBatch, name: &str) -> &'a T {
    batch
        .column_by_name(name)
        .unwrap()
        .as_any()
        .downcast_ref::<T>()
        .unwrap()
}

#[test]
fn observations_read_back_bit_for_bit_and_replays_reproduce_poses() {
    let dir = tempfile::tempdir().unwrap();
    let episodes = first_episodes(|t| t == Task::PointGoal, 3);
    let sensors = SensorSuite::minos(32);
    let out = dir.path().join("oracle");
    rollout(
        &config(&out, AgentKind::Oracle, sensors.clone()),
        &episodes,
        &NoProgress,
    )
    .unwrap();
    // Re-simulate the first episode step by step and compare with the stored images and poses.
    let traj = first_batch(&out.join("trajectories.parquet"));
    let obs_reader = ParquetRecordBatchReaderBuilder::try_new(
        std::fs::File::open(out.join("observations.parquet")).unwrap(),
    )
    .unwrap();
    let schema = obs_reader.schema().clone();
    let color = schema.field_with_name("color").unwrap();
    assert_eq!(color.metadata()["dtype"], "uint8");
    assert_eq!(color.metadata()["shape"], "[32, 32, 3]");
    let obs: Vec<_> = obs_reader.build().unwrap().map(|b| b.unwrap()).collect();
    let e = &episodes
        .iter()
        .min_by(|a, b| a.episode_id.cmp(&b.episode_id))
        .unwrap();
    let data_dir = data().0.path().join("DATA");
    let (_, scene) = minos::store::DataDir::new(&data_dir)
        .read_scene(&e.scene_id)
        .unwrap();
    let grid = minos::store::DataDir::new(&data_dir)
        .read_grid(&minos::scene::SceneRef::parse(&e.scene_id))
        .unwrap();
    let body = AgentConfig::habitat();
    let assets = Arc::new(minos::sim::SceneAssets::new(&scene, grid, &body).unwrap());
    let mut sim = minos::sim::Simulator::new(
        assets,
        Arc::new(minos::render::Renderer::Cpu),
        body,
        sensors,
        500,
        5,
    );
    sim.reset_episode(e);
    let mut o = sim.observe().unwrap();
    let (ids, steps, actions) = (
        column::<StringArray>(&traj, "episode_id"),
        column::<UInt32Array>(&traj, "step"),
        column::<StringArray>(&traj, "action"),
    );
    let xs = column::<Float32Array>(&traj, "x");
    let mut row = 0;
    let mut checked = 0;
    for batch in &obs {
        let (oid, ostep) = (
            column::<StringArray>(batch, "episode_id"),
            column::<UInt32Array>(batch, "step"),
        );
        for r in 0..batch.num_rows() {
            if oid.value(r) != e.episode_id {
                continue;
            }
            assert_eq!(ostep.value(r), checked);
            for (name, image) in &o.images {
                assert_eq!(
                    column::<BinaryArray>(batch, name).value(r),
                    &image.to_le_bytes()[..],
                    "{name} at step {checked}"
                );
            }
            while ids.value(row) != e.episode_id || steps.value(row) != checked {
                row += 1;
            }
            assert_eq!(xs.value(row), sim.state().position[0]);
            if let Some(Decision::Act(a)) = Decision::from_name(actions.value(row)) {
                o = sim.step(a).unwrap();
            }
            checked += 1;
        }
    }
    assert!(checked > 3);
    // Replay the whole run from its trajectories: same poses.
    let replay_out = dir.path().join("replay");
    let mut by_episode: std::collections::HashMap<String, Vec<Decision>> =
        std::collections::HashMap::new();
    for i in 0..traj.num_rows() {
        by_episode
            .entry(ids.value(i).to_string())
            .or_default()
            .push(Decision::from_name(actions.value(i)).unwrap());
    }
    rollout(
        &config(
            &replay_out,
            AgentKind::Replay(by_episode),
            SensorSuite {
                cameras: vec![],
                contact: None,
            },
        ),
        &episodes,
        &NoProgress,
    )
    .unwrap();
    let replayed = first_batch(&replay_out.join("trajectories.parquet"));
    for c in ["x", "z", "yaw"] {
        let (a, b) = (
            column::<Float32Array>(&traj, c),
            column::<Float32Array>(&replayed, c),
        );
        assert_eq!(a.len(), b.len());
        assert!(
            (0..a.len()).all(|i| a.value(i) == b.value(i)),
            "{c} differs"
        );
    }
}

#[test]
fn a_killed_run_resumed_gives_identical_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let episodes = &data().1;
    let eps_file = dir.path().join("eps.parquet");
    minos::episode::format::write_episodes(&eps_file, episodes).unwrap();
    let data_dir = data().0.path().join("DATA");
    let cmd = |out: &Path, resume: bool| {
        let mut c = common::minos();
        c.args(["run", "--agent", "oracle", "--size", "24", "-q", "--data"])
            .arg(&data_dir)
            .arg("--episodes")
            .arg(&eps_file)
            .arg("--out")
            .arg(out)
            .arg("--rerun")
            .arg(out.with_extension("rrd"))
            .args(["--rerun-episodes", "2"]);
        if resume {
            c.arg("--resume");
        }
        c
    };
    let full = dir.path().join("full");
    assert!(cmd(&full, false).status().unwrap().success());
    let killed = dir.path().join("killed");
    let mut child = cmd(&killed, false).spawn().unwrap();
    let parts = killed.join(".parts");
    // The `.json` files of the part folder: each finished episode's metrics, and `run.json`.
    let finished = |p: &Path| {
        std::fs::read_dir(p)
            .map(|d| {
                d.flatten()
                    .filter(|e| e.path().extension().is_some_and(|x| x == "json"))
                    .count()
            })
            .unwrap_or(0)
    };
    let start = std::time::Instant::now();
    loop {
        let done = finished(&parts);
        if done >= 3 || start.elapsed().as_secs() > 60 {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    child.kill().unwrap();
    let _ = child.wait();
    let interrupted = !killed.join("episodes.parquet").exists();
    if interrupted {
        // Run again with another seed, it refuses, keeps the finished episodes and says how.
        let before = finished(&parts);
        let again = cmd(&killed, false).args(["--seed", "1"]).output().unwrap();
        let stderr = String::from_utf8_lossy(&again.stderr);
        assert!(!again.status.success(), "{stderr}");
        assert!(
            stderr.contains(&format!(
                "holds {} finished episodes of an interrupted run with another `seed`",
                before - 1 // the record is a .json file too
            )),
            "{stderr}"
        );
        assert_eq!(finished(&parts), before, "the finished episodes are kept");
    }
    // Run again as it was (no --resume needed), it continues.
    assert!(cmd(&killed, false).status().unwrap().success());
    for f in [
        "trajectories.parquet",
        "observations.parquet",
        "episodes.parquet",
    ] {
        let what = common::first_difference(&full.join(f), &killed.join(f));
        assert!(what == "identical", "{f} differs: {what}");
    }
    assert!(
        interrupted,
        "the run finished before it could be killed; the resume was not exercised"
    );
    // The resumed run's recording holds the same two episodes, complete.
    let recorded = |out: &Path| entities_via_footer(&out.with_extension("rrd"));
    let (a, b) = (recorded(&full), recorded(&killed));
    assert_eq!(a.len(), 2);
    assert_eq!(a, b);
    // Message for message the same bytes (only rerun's footer index may be ordered
    // differently).
    assert!(
        rrd_messages(&full.with_extension("rrd")) == rrd_messages(&killed.with_extension("rrd")),
        "the recordings differ"
    );
}

/// The messages of an `.rrd` file, as rerun's decoder reads them.
fn rrd_messages(path: &Path) -> Vec<rerun::log::LogMsg> {
    let reader = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    re_log_encoding::DecoderApp::decode_eager(reader)
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

#[test]
fn an_external_process_drives_the_agent_over_json_lines() {
    let dir = tempfile::tempdir().unwrap();
    let episodes = first_episodes(|t| t == Task::PointGoal, 2);
    // A policy in plain sh: read a line, answer forward, stop after 5 steps of an episode.
    let script = dir.path().join("policy.sh");
    std::fs::write(
        &script,
        "n=0\nwhile read -r line; do\n  case \"$line\" in\n    *'\"type\":\"reset\"'*) n=0; continue;;\n  esac\n  \
         n=$((n+1))\n  if [ $n -gt 5 ]; then echo '{\"stop\": true}'; else echo '{\"action\": \"forward\"}'; fi\ndone\n",
    )
    .unwrap();
    let cmd = format!("sh {}", script.display());
    let out = dir.path().join("ext");
    let report = rollout(
        &config(&out, AgentKind::External(cmd), SensorSuite::minos(8)),
        &episodes,
        &NoProgress,
    )
    .unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    assert!(
        report.episodes.iter().all(|(_, m)| m.steps == 6),
        "{:?}",
        report
            .episodes
            .iter()
            .map(|(_, m)| m.steps)
            .collect::<Vec<_>>()
    );
    // A policy that answers garbage fails its episodes with a message naming the step.
    let bad = rollout(
        &config(
            &dir.path().join("bad"),
            AgentKind::External("while read l; do echo nope; done".into()),
            blind(),
        ),
        &episodes,
        &NoProgress,
    )
    .unwrap();
    assert_eq!(bad.failures.len(), 2);
    let failure = &bad.failures[0].1;
    let line = minos::escape::error_line(failure);
    assert!(line.contains("not JSON"), "{line}");
    // The cause is kept typed: the agent's own error, not a flattened line.
    assert!(
        matches!(failure, EpisodeFailure::Run(e) if matches!(**e, EpisodeError::Agent(_))),
        "{failure:?}"
    );
    // Down to the protocol fault: the reply as read, the JSON parser's error as its source.
    let mut chain: Vec<&(dyn std::error::Error + 'static)> = vec![failure];
    while let Some(next) = chain.last().and_then(|e| e.source()) {
        chain.push(next);
    }
    let fault = chain
        .iter()
        .find_map(|e| e.downcast_ref::<minos::run::agents::ExternalFault>())
        .expect("the external fault in the chain");
    assert!(
        matches!(fault, minos::run::agents::ExternalFault::NotJson { reply, .. } if reply == "nope"),
        "{fault:?}"
    );
    assert!(
        chain.iter().any(|e| e.is::<serde_json::Error>()),
        "{chain:?}"
    );
    let line = minos::escape::error_line(failure);
    assert_eq!(line.matches("is not JSON").count(), 1, "{line}");
    // A command that cannot start (sh exits at once): the run goes on, the episode fails.
    let gone = rollout(
        &config(
            &dir.path().join("gone"),
            AgentKind::External("exit 0".into()),
            blind(),
        ),
        &episodes,
        &NoProgress,
    )
    .unwrap();
    assert_eq!(gone.failures.len(), 2);
    let line = minos::escape::error_line(&gone.failures[0].1);
    assert!(
        line.contains("closed its output") || line.contains("write: "),
        "{line}"
    );
}

/// What a recording logged at one entity.
#[derive(Debug, Default)]
struct Logged {
    /// Components logged statically (`Archetype:field`).
    statics: std::collections::BTreeSet<String>,
    /// Components logged on the `step` timeline.
    temporal: std::collections::BTreeSet<String>,
    /// Steps at which something was logged.
    steps: std::collections::BTreeSet<i64>,
    /// Translations logged (Transform3D), in step order.
    translations: std::collections::BTreeMap<i64, [f32; 3]>,
}

/// Reads an `.rrd` file with rerun's own decoder: (recording id, entity path) → what was
/// logged there.
fn read_rrd(path: &Path) -> std::collections::BTreeMap<(String, String), Logged> {
    use rerun::log::{Chunk, LogMsg};
    let reader = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let mut out: std::collections::BTreeMap<(String, String), Logged> = Default::default();
    for msg in re_log_encoding::DecoderApp::decode_eager(reader).unwrap() {
        let LogMsg::ArrowMsg(store, arrow) = msg.unwrap() else {
            continue;
        };
        let chunk = Chunk::from_arrow_msg(&arrow).unwrap();
        let key = (
            store.recording_id().to_string(),
            chunk
                .entity_path()
                .to_string()
                .trim_start_matches('/')
                .to_string(),
        );
        let logged = out.entry(key).or_default();
        let names = chunk
            .component_descriptors()
            .map(|d| d.component.to_string());
        if chunk.is_static() {
            logged.statics.extend(names);
            continue;
        }
        logged.temporal.extend(names);
        let Some(steps) = chunk.timelines().get(&"step".into()) else {
            continue;
        };
        logged.steps.extend(steps.times_raw());
        let translation = rerun::archetypes::Transform3D::descriptor_translation().component;
        for (step, t) in steps
            .times_raw()
            .iter()
            .zip(chunk.iter_component::<rerun::components::Translation3D>(translation))
        {
            if let Some(t) = t.first() {
                logged.translations.insert(*step, [t.x(), t.y(), t.z()]);
            }
        }
    }
    out
}

/// Polls a future that never waits (rerun's file reads are blocking) to completion.
fn block_on<F: std::future::Future>(f: F) -> F::Output {
    let mut f = std::pin::pin!(f);
    let mut cx = std::task::Context::from_waker(std::task::Waker::noop());
    loop {
        if let std::task::Poll::Ready(v) = f.as_mut().poll(&mut cx) {
            return v;
        }
        std::thread::yield_now();
    }
}

/// Loads every chunk the way the viewer does for random access — through the footer's
/// per-recording manifest of byte offsets — and returns recording id → entity paths.
fn entities_via_footer(
    path: &Path,
) -> std::collections::BTreeMap<String, std::collections::BTreeSet<String>> {
    use re_log_encoding::{ChunkProvider, RrdChunkProvider};
    let file = std::fs::File::open(path).unwrap();
    let footer = block_on(re_log_encoding::read_rrd_footer(&file))
        .unwrap()
        .expect("a footer");
    let mut out = std::collections::BTreeMap::new();
    for (store, raw) in footer.manifests {
        let provider = RrdChunkProvider::from_reader(
            std::fs::File::open(path).unwrap(),
            "test",
            std::sync::Arc::new(raw),
        )
        .unwrap();
        let ids = provider.manifest().col_chunk_ids().to_vec();
        let chunks = block_on(provider.load_chunks(&ids)).unwrap();
        assert_eq!(chunks.len(), ids.len());
        out.insert(
            store.recording_id().to_string(),
            chunks
                .iter()
                .map(|c| {
                    c.entity_path()
                        .to_string()
                        .trim_start_matches('/')
                        .to_string()
                })
                .collect(),
        );
    }
    out
}

#[test]
fn a_run_records_one_pose_and_image_per_step_and_leaves_the_tables_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let episodes = first_episodes(|t| t != Task::ObjectGoal, 4);
    let sensors = SensorSuite::minos(16);
    let plain = dir.path().join("plain");
    rollout(
        &config(&plain, AgentKind::Oracle, sensors.clone()),
        &episodes,
        &NoProgress,
    )
    .unwrap();
    let out = dir.path().join("recorded");
    let rrd = dir.path().join("rec/run.rrd");
    let mut cfg = config(&out, AgentKind::Oracle, sensors);
    cfg.rerun = Some(minos::pipeline::rollout::RerunOutput {
        path: rrd.clone(),
        episodes: 2,
    });
    let report = rollout(&cfg, &episodes, &NoProgress).unwrap();
    assert_eq!(report.recorded, 2);
    // Recording never changes the tables.
    for f in ["trajectories.parquet", "observations.parquet"] {
        let what = common::first_difference(&plain.join(f), &out.join(f));
        assert!(what == "identical", "{f} differs with --rerun: {what}");
    }
    // Only the finished file is left: no temporary names, no parts.
    let names: Vec<_> = std::fs::read_dir(rrd.parent().unwrap())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("run.rrd")]);
    assert!(!out.join(".parts").exists());

    let logged = read_rrd(&rrd);
    let mut sorted = episodes.clone();
    sorted.sort_by(|a, b| a.episode_id.cmp(&b.episode_id));
    let recordings: std::collections::BTreeSet<&str> =
        logged.keys().map(|(r, _)| r.as_str()).collect();
    let expected: std::collections::BTreeSet<&str> =
        sorted[..2].iter().map(|e| e.episode_id.as_str()).collect();
    assert_eq!(recordings, expected, "the first two episodes are recorded");
    // The footer indexes both recordings at the right offsets (random access in the viewer).
    let indexed = entities_via_footer(&rrd);
    for (recording, entities) in &indexed {
        let decoded: std::collections::BTreeSet<String> = logged
            .keys()
            .filter(|(r, _)| r == recording)
            .map(|(_, e)| e.clone())
            .collect();
        assert_eq!(entities, &decoded, "{recording}");
    }
    assert_eq!(
        indexed
            .keys()
            .map(String::as_str)
            .collect::<std::collections::BTreeSet<_>>(),
        expected
    );
    let traj = first_batch(&out.join("trajectories.parquet"));
    let ids = column::<StringArray>(&traj, "episode_id");
    for ep in &sorted[..2] {
        let at = |entity: &str| {
            logged
                .get(&(ep.episode_id.clone(), entity.to_string()))
                .unwrap_or_else(|| panic!("{}: no {entity}", ep.episode_id))
        };
        let rows = (0..traj.num_rows())
            .filter(|&r| ids.value(r) == ep.episode_id)
            .count() as i64;
        assert!(rows > 1);
        // The oracle ends with a stop, so the agent has one pose per trajectory row.
        let steps: Vec<i64> = (0..rows).collect();
        let agent = at("world/agent");
        assert_eq!(agent.steps.iter().copied().collect::<Vec<_>>(), steps);
        assert!(agent.temporal.contains("Transform3D:translation"));
        let start = agent.translations[&0];
        for k in 0..3 {
            assert!((start[k] - ep.start_position[k]).abs() < 1e-4, "{start:?}");
        }
        assert_eq!(
            at("world/trajectory").steps.len() as i64,
            rows,
            "a trajectory strip per step"
        );
        for (camera, archetype) in [
            ("color", "Image:buffer"),
            ("depth", "DepthImage:buffer"),
            ("semantic", "SegmentationImage:buffer"),
        ] {
            let image = at(&format!("world/cameras/{camera}/image"));
            assert!(image.temporal.contains(archetype), "{camera}: {image:?}");
            assert!(image.statics.contains("Pinhole:image_from_camera"));
            assert_eq!(image.steps.iter().copied().collect::<Vec<_>>(), steps);
            assert_eq!(
                at(&format!("world/cameras/{camera}")).steps.len() as i64,
                rows
            );
        }
        assert_eq!(at("metrics/geodesic").steps.len() as i64, rows);
        assert_eq!(at("metrics/reward").steps.len() as i64, rows);
        assert!(at("world/scene/mesh")
            .statics
            .contains("Mesh3D:vertex_positions"));
        assert!(at("semantic/mesh").statics.contains("Mesh3D:vertex_colors"));
        assert!(at("world/nav/walkable")
            .statics
            .contains("Points3D:positions"));
        assert!(at("world/episode/shortest_path")
            .statics
            .contains("LineStrips3D:strips"));
        assert!(at("nav/L0").statics.contains("Image:buffer"));
    }
}

#[test]
fn minos_view_records_a_scene_with_its_episodes_shortest_paths() {
    let dir = tempfile::tempdir().unwrap();
    let episodes = &data().1;
    let eps_file = dir.path().join("eps.parquet");
    minos::episode::format::write_episodes(&eps_file, episodes).unwrap();
    let data_dir = data().0.path().join("DATA");
    let scene = episodes[0].scene_id.clone();
    let of_scene: Vec<&Episode> = episodes.iter().filter(|e| e.scene_id == scene).collect();
    let rrd = dir.path().join("view.rrd");
    let status = common::minos()
        .args(["view", "-q", "--scene", &scene, "--data"])
        .arg(&data_dir)
        .arg("--episodes")
        .arg(&eps_file)
        .arg("--out")
        .arg(&rrd)
        .status()
        .unwrap();
    assert!(status.success());
    let logged = read_rrd(&rrd);
    assert!(logged.keys().all(|(r, _)| *r == scene), "one recording");
    let has = |entity: &str, component: &str| {
        logged
            .get(&(scene.clone(), entity.to_string()))
            .is_some_and(|l| l.statics.contains(component) && l.steps.is_empty())
    };
    assert!(has("world/scene/mesh", "Mesh3D:vertex_colors"));
    assert!(has("world/nav/walkable", "Points3D:positions"));
    // Sampled episodes are reachable: each has its start, goals and shortest path.
    for e in &of_scene {
        let base = minos::io::rrd::scene::episode_entity(&e.episode_id).to_string();
        let base = base.trim_start_matches('/');
        assert!(
            has(&format!("{base}/start"), "Points3D:positions"),
            "{base}"
        );
        assert!(has(&format!("{base}/goal"), "Points3D:positions"), "{base}");
        assert!(
            has(&format!("{base}/shortest_path"), "LineStrips3D:strips"),
            "{base}"
        );
    }
    let drawn = logged
        .keys()
        .filter(|(_, e)| e.starts_with("world/episodes/"))
        .filter(|(_, e)| e.ends_with("/start"))
        .count();
    assert_eq!(drawn, of_scene.len(), "only the scene's episodes are drawn");
    // The footer indexes every chunk at the right offset (random access in the viewer).
    let indexed = entities_via_footer(&rrd);
    let decoded: std::collections::BTreeSet<String> =
        logged.keys().map(|(_, e)| e.clone()).collect();
    assert_eq!(indexed.get(&scene), Some(&decoded));
    // Recording the scene again writes the same messages: ids come from a counter, not a
    // clock, and no wall-clock timeline is added.
    let again = dir.path().join("again.rrd");
    let status = common::minos()
        .args(["view", "-q", "--scene", &scene, "--data"])
        .arg(&data_dir)
        .arg("--episodes")
        .arg(&eps_file)
        .arg("--out")
        .arg(&again)
        .status()
        .unwrap();
    assert!(status.success());
    let (a, b) = (rrd_messages(&rrd), rrd_messages(&again));
    assert!(a.len() > 3 && a == b, "the recordings differ");
    // A scene that was never ingested is a one-line error naming the file.
    let out = common::minos()
        .args(["view", "-q", "--scene", "nope", "--data"])
        .arg(&data_dir)
        .arg("--out")
        .arg(dir.path().join("nope.rrd"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("nope") && err.lines().count() == 1, "{err}");
    assert!(!dir.path().join("nope.rrd").exists());
}

#[test]
fn an_episodes_drawn_shortest_path_starts_at_its_start_and_has_its_geodesic_length() {
    let data_dir = data().0.path().join("DATA");
    let mut grids = std::collections::HashMap::new();
    for e in &data().1 {
        let grid = grids.entry(e.scene_id.clone()).or_insert_with(|| {
            minos::store::DataDir::new(&data_dir)
                .read_grid(&minos::scene::SceneRef::parse(&e.scene_id))
                .unwrap()
        });
        let path = minos::episode::goal::shortest_path(grid, e)
            .unwrap_or_else(|| panic!("{}: no path", e.episode_id));
        let first = path[0];
        assert!(
            (first.x - e.start_position[0]).abs() < 1e-5
                && (first.z - e.start_position[2]).abs() < 1e-5,
            "{}: path starts at {first:?}",
            e.episode_id
        );
        let length: f32 = path.windows(2).map(|w| w[0].distance(w[1])).sum();
        // Within a fraction of a 5 cm cell: the goal field's path and the point-to-point
        // route that measured the episode refine their corners separately.
        assert!(
            (length - e.geodesic_distance).abs() <= 0.03,
            "{}: drawn {length} m, stored {} m",
            e.episode_id,
            e.geodesic_distance
        );
    }
}

/// `minos run --agent AGENT` over `episodes` (written under `dir`) on the shared DATA folder,
/// writing into `dir/out`.
fn run_cli(dir: &Path, episodes: &[Episode], agent: &str, extra: &[&str]) -> std::process::Output {
    let eps_file = dir.join("eps.parquet");
    minos::episode::format::write_episodes(&eps_file, episodes).unwrap();
    common::minos()
        .args(["run", "--size", "8", "--agent", agent, "--data"])
        .arg(data().0.path().join("DATA"))
        .arg("--episodes")
        .arg(&eps_file)
        .arg("--out")
        .arg(dir.join("out"))
        .args(extra)
        .output()
        .unwrap()
}

/// The one error line of a failed command.
fn one_error(out: &std::process::Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error")).collect();
    assert_eq!(errors.len(), 1, "{stderr}");
    errors[0].to_string()
}

#[test]
fn minos_random_presses_forward_and_turns_together_and_repeats_for_a_seed() {
    let dir = tempfile::tempdir().unwrap();
    let episodes = first_episodes(|t| t == Task::PointGoal, 4);
    let run_into = |dir: &Path| {
        let out = run_cli(dir, &episodes, "minos-random", &["--max-steps", "60"]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    run_into(dir.path());
    let table = dir.path().join("out/trajectories.parquet");
    let (mut steps, mut forward, mut together) = (0usize, 0usize, 0usize);
    for b in all_batches(&table) {
        let strengths = column::<arrow::array::ListArray>(&b, "action_strengths");
        let actions = column::<StringArray>(&b, "action");
        for r in 0..b.num_rows() {
            if actions.value(r) == "stop" {
                continue;
            }
            let v = strengths.value(r);
            let v = v.as_any().downcast_ref::<Float32Array>().unwrap();
            // forward, backward, strafe left/right, turn left/right, look up/down
            let s: Vec<f32> = (0..v.len()).map(|k| v.value(k)).collect();
            assert!(s.iter().all(|x| *x == 0.0 || *x == 1.0), "{s:?}");
            assert_eq!((s[1], s[2], s[3], s[6], s[7]), (0.0, 0.0, 0.0, 0.0, 0.0));
            steps += 1;
            forward += usize::from(s[0] == 1.0);
            together += usize::from(s[0] == 1.0 && (s[4] == 1.0) != (s[5] == 1.0));
        }
    }
    // Forward on half the steps (the uniform `random` agent: a third), moving and turning at
    // once on a quarter.
    assert!(steps >= 100, "{steps} steps");
    let share = |n: usize| n as f64 / steps as f64;
    assert!(
        (0.4..0.6).contains(&share(forward)),
        "forward on {forward} of {steps}"
    );
    assert!(
        (0.15..0.35).contains(&share(together)),
        "together on {together} of {steps}"
    );
    // The same seed replays the same button presses.
    let again = tempfile::tempdir().unwrap();
    run_into(again.path());
    assert_eq!(
        std::fs::read(&table).unwrap(),
        std::fs::read(again.path().join("out/trajectories.parquet")).unwrap()
    );
}

#[test]
fn run_checks_every_scene_once_before_writing_anything() {
    let dir = tempfile::tempdir().unwrap();
    let episodes = &data().1;
    let scenes: std::collections::BTreeSet<&str> =
        episodes.iter().map(|e| e.scene_id.as_str()).collect();
    // The grids are baked for Habitat's body; MINOS's agent is another.
    let err = one_error(&run_cli(
        dir.path(),
        episodes,
        "forward",
        &["--preset", "minos"],
    ));
    let n = scenes.len();
    assert!(
        err.contains(&format!("{n} of the {n} scenes"))
            && err.contains("baked for body")
            && err.contains("minos bake --preset minos"),
        "{err}"
    );
    assert!(
        !dir.path().join("out").exists(),
        "an output folder was created"
    );
    // A scene that was never ingested, among good ones.
    let mut some = first_episodes(|_| true, 3);
    some[0].scene_id = "ghost".into();
    let err = one_error(&run_cli(dir.path(), &some, "forward", &[]));
    assert!(
        err.contains("1 of the") && err.contains("not ingested") && err.contains("scene ghost"),
        "{err}"
    );
    assert!(
        !dir.path().join("out").exists(),
        "an output folder was created"
    );
}

#[test]
fn a_replay_without_some_episode_is_refused_up_front_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let episodes = first_episodes(|_| true, 3);
    // A trajectory table of the first episode only.
    let first = dir.path().join("first");
    let mut cfg = config(&first, AgentKind::Forward, blind());
    cfg.max_steps = Some(3);
    rollout(&cfg, &episodes[..1], &NoProgress).unwrap();
    let table = first.join("trajectories.parquet");
    let agent = format!("replay:{}", table.display());
    let err = one_error(&run_cli(dir.path(), &episodes, &agent, &[]));
    assert!(
        err.contains(&format!(
            "{} has no steps for 2 of the 3 episodes",
            table.display()
        )),
        "{err}"
    );
    assert!(
        !dir.path().join("out").exists(),
        "an output folder was created"
    );
    // The episode it has replays.
    let ok = run_cli(dir.path(), &episodes[..1], &agent, &[]);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
}

#[test]
fn one_scenes_episodes_split_across_threads_give_the_one_thread_bytes() {
    // A scan-sized scene is often the only one: its episodes are shared among the threads,
    // each with its own simulator and agent. Random agents (an RNG per episode) and cameras
    // make any dependence on the split visible.
    let dir = tempfile::tempdir().unwrap();
    let scene = data().1[0].scene_id.clone();
    let episodes: Vec<Episode> = data()
        .1
        .iter()
        .filter(|e| e.scene_id == scene)
        .take(7)
        .cloned()
        .collect();
    assert!(episodes.len() >= 5, "{} episodes", episodes.len());
    let sensors = SensorSuite::minos(16);
    let out = |threads: usize| {
        let out = dir.path().join(format!("t{threads}"));
        let report = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                rollout(
                    &config(&out, AgentKind::Random, sensors.clone()),
                    &episodes,
                    &NoProgress,
                )
            })
            .unwrap();
        assert!(report.failures.is_empty(), "{:?}", report.failures);
        out
    };
    let one = out(1);
    for threads in [2, 3] {
        let many = out(threads);
        for file in [
            "episodes.parquet",
            "trajectories.parquet",
            "observations.parquet",
            "metrics.json",
        ] {
            let what = common::first_difference(&one.join(file), &many.join(file));
            assert!(what == "identical", "{file} with {threads} threads: {what}");
        }
    }
}

/// Every row of a Parquet file.
fn all_batches(path: &Path) -> Vec<arrow::array::RecordBatch> {
    ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(path).unwrap())
        .unwrap()
        .build()
        .unwrap()
        .map(|b| b.unwrap())
        .collect()
}

/// One step as both drivers see it: pose before, action, reward, collision, done, success
/// (floats as bits: equal means identical), and the features the agent was given before the
/// action (goal measurement bits, goal room and object, at goal, contacts, previous action
/// and collision, steps left; see [`features_key`]).
type StepKey = (String, [u32; 5], String, u32, bool, bool, bool, String);

/// The per-step features as one comparable string.
#[allow(clippy::too_many_arguments)]
fn features_key(
    goal: Option<[f32; 3]>,
    goal_room: Option<&str>,
    goal_object: Option<&str>,
    at_goal: bool,
    contacts: &[bool],
    previous_action: Option<&str>,
    previous_collision: bool,
    steps_left: u32,
) -> String {
    format!(
        "{:?} {goal_room:?} {goal_object:?} {at_goal} {contacts:?} {previous_action:?} \
         {previous_collision} {steps_left}",
        goal.map(|g| g.map(f32::to_bits)),
    )
}

/// The trajectories of a run's table, by episode id, in step order.
fn trajectories(path: &Path) -> std::collections::BTreeMap<String, Vec<StepKey>> {
    let mut by_episode: std::collections::BTreeMap<String, Vec<StepKey>> = Default::default();
    for b in all_batches(path) {
        let ids = column::<StringArray>(&b, "episode_id");
        let f = |name: &str| column::<Float32Array>(&b, name).clone();
        let (x, y, z, yaw, tilt, reward) =
            (f("x"), f("y"), f("z"), f("yaw"), f("tilt"), f("reward"));
        let actions = column::<StringArray>(&b, "action");
        let flag = |name: &str| column::<arrow::array::BooleanArray>(&b, name).clone();
        let (collision, done, success) = (flag("collision"), flag("done"), flag("success"));
        let (at_goal, previous_collision) = (flag("at_goal"), flag("previous_collision"));
        let (euclidean, right, forward) =
            (f("euclidean_distance"), f("goal_right"), f("goal_forward"));
        let text = |name: &str| column::<StringArray>(&b, name).clone();
        let (room, object, previous) = (
            text("goal_room"),
            text("goal_object"),
            text("previous_action"),
        );
        let steps_left = column::<UInt32Array>(&b, "steps_left");
        let contacts = column::<arrow::array::ListArray>(&b, "contacts");
        for r in 0..b.num_rows() {
            let opt = |c: &StringArray| (!c.is_null(r)).then(|| c.value(r).to_string());
            let bits = contacts.value(r);
            let bits = bits
                .as_any()
                .downcast_ref::<arrow::array::BooleanArray>()
                .unwrap();
            let key = features_key(
                (!euclidean.is_null(r))
                    .then(|| [euclidean.value(r), right.value(r), forward.value(r)]),
                opt(&room).as_deref(),
                opt(&object).as_deref(),
                at_goal.value(r),
                &(0..bits.len()).map(|k| bits.value(k)).collect::<Vec<_>>(),
                opt(&previous).as_deref(),
                previous_collision.value(r),
                steps_left.value(r),
            );
            by_episode
                .entry(ids.value(r).to_string())
                .or_default()
                .push((
                    ids.value(r).to_string(),
                    [&x, &y, &z, &yaw, &tilt].map(|c| c.value(r).to_bits()),
                    actions.value(r).to_string(),
                    reward.value(r).to_bits(),
                    collision.value(r),
                    done.value(r),
                    success.value(r),
                    key,
                ));
        }
    }
    by_episode
}

/// Drives `episodes` through a vector environment of `num_envs` environments on `threads`
/// threads, each episode's decisions taken from `actions` (its action names in step order),
/// until every episode ended once (with `oracle`, checking that the environments' oracle
/// asks for those decisions); returns each episode's steps and metrics.
fn vector_env_trajectories(
    cfg: &minos::pipeline::vector_env::VectorEnvConfig,
    episodes: &[Episode],
    actions: &std::collections::BTreeMap<String, Vec<String>>,
    oracle: bool,
) -> std::collections::BTreeMap<String, (Vec<StepKey>, String)> {
    use minos::pipeline::vector_env::VectorEnv;
    let mut env = VectorEnv::new(cfg, episodes.to_vec()).unwrap();
    let names = env.action_names();
    let mut out: std::collections::BTreeMap<String, (Vec<StepKey>, String)> = Default::default();
    let outs = env.reset(None).unwrap();
    assert!(outs.iter().all(|o| o.reset && o.reward == 0.0));
    let mut current: Vec<usize> = outs.iter().map(|o| o.episode).collect();
    // Each episode's first run is the one compared (environments wrap around the order).
    let mut claimed = std::collections::BTreeSet::new();
    let mut recording: Vec<bool> = current.iter().map(|&e| claimed.insert(e)).collect();
    let mut finished = std::collections::BTreeSet::new();
    let mut guard = 0;
    while finished.len() < episodes.len() {
        guard += 1;
        assert!(
            guard < 100_000,
            "the vector environment never ended every episode"
        );
        let mut chosen = Vec::with_capacity(current.len());
        let mut poses = Vec::with_capacity(current.len());
        let mut seen = Vec::with_capacity(current.len());
        for (i, &e) in current.iter().enumerate() {
            let f = env.features(i).unwrap();
            seen.push(features_key(
                f.euclidean.map(|_| f.goal),
                f.goal_room.map(|c| c.name()),
                f.goal_object.as_deref(),
                f.at_goal,
                &f.contacts,
                f.previous_action.map(|d| d.name()).as_deref(),
                f.collision,
                f.steps_left,
            ));
            let id = &env.episodes()[e].episode_id;
            let t = env.stepper(i).unwrap().decisions() as usize;
            let name = actions[id].get(t).cloned().unwrap_or_else(|| "stop".into());
            chosen.push(names.iter().position(|n| *n == name).unwrap());
            let s = env.stepper(i).unwrap().sim().state();
            poses.push([s.position[0], s.position[1], s.position[2], s.yaw, s.tilt]);
        }
        if oracle {
            // The environments' own oracle decides as the run's did.
            let asked = env.oracle_actions().unwrap();
            for (i, &e) in current.iter().enumerate() {
                if recording[i] && !finished.contains(&env.episodes()[e].episode_id) {
                    assert_eq!(asked[i], Some(chosen[i]), "the oracle of environment {i}");
                }
            }
        }
        let outs = env.step(&chosen).unwrap();
        for (i, o) in outs.iter().enumerate() {
            let e = current[i];
            let id = env.episodes()[e].episode_id.clone();
            if o.reset {
                current[i] = o.episode;
                recording[i] = claimed.insert(o.episode);
                continue;
            }
            if !recording[i] || finished.contains(&id) {
                continue;
            }
            let entry = out.entry(id.clone()).or_default();
            entry.0.push((
                id.clone(),
                poses[i].map(f32::to_bits),
                names[chosen[i]].to_string(),
                o.reward.to_bits(),
                o.collision,
                o.terminated || o.truncated,
                o.success,
                seen[i].clone(),
            ));
            if o.terminated || o.truncated {
                entry.1 = format!("{:?}", env.stepper(i).unwrap().metrics().unwrap());
                finished.insert(id);
            }
        }
    }
    out
}

#[test]
fn the_rollout_and_the_vector_env_step_the_same_episodes_alike() {
    // `minos run` (the rollout) and the Gym environments (the vector environment) step
    // episodes through the same stepper: the same decisions give the same poses, rewards,
    // collisions, ends and metrics. Random agents (arrival ends an episode; many
    // collisions; the step limit) and the oracle (success needs its stop) on every task.
    use minos::pipeline::vector_env::VectorEnvConfig;
    let dir = tempfile::tempdir().unwrap();
    let mut episodes = first_episodes(|t| t == Task::PointGoal, 3);
    episodes.extend(first_episodes(|t| t != Task::PointGoal, 3));
    let sensors = SensorSuite::minos(8);
    for (agent, require_stop, max_steps) in [
        (AgentKind::Random, false, Some(40)),
        (AgentKind::Oracle, true, None),
    ] {
        let out = dir.path().join(format!("{agent:?}"));
        let mut cfg = config(&out, agent.clone(), sensors.clone());
        cfg.max_steps = max_steps;
        let report = rollout(&cfg, &episodes, &NoProgress).unwrap();
        assert!(report.failures.is_empty(), "{:?}", report.failures);
        let rollout = trajectories(&out.join("trajectories.parquet"));
        assert_eq!(rollout.len(), episodes.len());
        let actions = rollout
            .iter()
            .map(|(id, steps)| (id.clone(), steps.iter().map(|s| s.2.clone()).collect()))
            .collect();
        for (num_envs, threads) in [(1, None), (4, Some(3))] {
            let env_cfg = VectorEnvConfig {
                data: cfg.data.clone(),
                num_envs,
                agent_config: cfg.agent_config,
                sensors: sensors.clone(),
                renderer: cfg.renderer,
                reward: cfg.reward,
                seed: cfg.seed,
                max_steps,
                require_stop,
                allow_body_mismatch: false,
                threads,
            };
            let stepped = vector_env_trajectories(&env_cfg, &episodes, &actions, require_stop);
            for (e, m) in &report.episodes {
                let (steps, metrics) = &stepped[&e.episode_id];
                assert_eq!(
                    steps, &rollout[&e.episode_id],
                    "{agent:?}, {num_envs} envs: the steps of {}",
                    e.episode_id
                );
                assert_eq!(metrics, &format!("{m:?}"), "{agent:?}: the metrics");
            }
            if matches!(agent, AgentKind::Oracle) {
                assert!(report.episodes.iter().all(|(_, m)| m.success));
            }
        }
    }
}

#[test]
fn vector_envs_of_1_to_32_environments_on_1_to_32_threads_reset_and_step() {
    // `VectorNavEnv(num_envs=N, threads=N)` hung for N >= 8: the environments' simulators
    // were made on the pool's threads, the first building the scene's ray-casting BVH (rayon
    // work inside a once-only cell) while the others waited on the cell, until the builder,
    // waiting on its own stolen work, took one of their pending simulators and waited on
    // itself. Every count of environments and threads (more threads than cores included)
    // must reset and step, each scene loaded afresh (its BVH not built yet), under a
    // deadline: a hang fails the test instead of stalling it.
    use minos::generate::{generate, GenerateConfig, OutputFormat, ScanOptions};
    use minos::pipeline::ingest::{ingest, DatasetFormat, IngestConfig};
    use minos::pipeline::vector_env::{VectorEnv, VectorEnvConfig};
    use minos::render::cpu::Method;
    use std::sync::atomic::{AtomicUsize, Ordering};
    // A scan-like house of 40,000 triangles: its BVH build forks rayon work (which the old
    // set-up deadlocked on most times for N >= 8; a small house's build rarely does).
    let dir = tempfile::tempdir().unwrap();
    let (root, data_path) = (dir.path().join("scans"), dir.path().join("DATA"));
    let gen = GenerateConfig {
        houses: 1,
        seed: 3,
        rooms: (4, 6),
        levels: (1, 1),
        closed_door_prob: 0.0,
        ..Default::default()
    };
    let format = OutputFormat::Mp3dScan(ScanOptions {
        triangles: 40_000,
        noise: 0.003,
    });
    generate(&gen, format, &root, false, &NoProgress).unwrap();
    let data_dir = minos::store::DataDir::new(&data_path);
    ingest(
        &IngestConfig {
            format: DatasetFormat::Mp3d,
            root,
            data: data_dir.clone(),
            ids: None,
            force: false,
            categories: None,
            models: None,
        },
        &NoProgress,
    )
    .unwrap();
    let ids = data_dir.ingested_ids().unwrap();
    let baked = minos::pipeline::bake::bake_scenes(
        &minos::pipeline::bake::BakeConfig {
            data: data_dir.clone(),
            scenes: ids.iter().map(|id| id.parse().unwrap()).collect(),
            params: minos::navmesh::NavParams::default(),
            force: false,
            previews: false,
        },
        &NoProgress,
    );
    assert_eq!(baked.failures().count(), 0);
    let scenes: Vec<(String, String)> = ids.iter().map(|id| (id.clone(), String::new())).collect();
    let episodes: Vec<Episode> = common::every_task_episodes(&data_dir, &scenes, 2, 4);
    assert!(episodes.len() >= 3, "{} episodes", episodes.len());
    let (_, compiled) = data_dir.read_scene(&ids[0]).unwrap();
    let triangles = minos::render::RenderScene::new(&compiled).triangle_count();
    let sensors = SensorSuite::minos(8);
    assert_eq!(
        Method::for_size(triangles, 8, 8),
        Method::RayCast,
        "the cameras must ray cast (BVH) for the test to mean anything: {triangles} triangles"
    );
    let cfg = VectorEnvConfig {
        data: data_dir,
        num_envs: 1,
        agent_config: AgentConfig::habitat(),
        sensors,
        renderer: RendererChoice::Cpu,
        reward: Reward::Geodesic,
        seed: 5,
        max_steps: Some(3),
        require_stop: true,
        allow_body_mismatch: false,
        threads: None,
    };
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let max = 32.max(cores + 2);
    let grid: Vec<(usize, usize)> = (1..=max)
        .flat_map(|e| (1..=max).map(move |t| (e, t)))
        .collect();
    let done = std::sync::Arc::new(AtomicUsize::new(0));
    let (tx, rx) = std::sync::mpsc::channel();
    let worker = {
        let (done, grid) = (done.clone(), grid.clone());
        std::thread::spawn(move || {
            for (num_envs, threads) in grid {
                let cfg = VectorEnvConfig {
                    num_envs,
                    threads: Some(threads),
                    ..cfg.clone()
                };
                let mut env = VectorEnv::new(&cfg, episodes.clone()).unwrap();
                let outs = env.reset(None).unwrap();
                assert_eq!(outs.len(), num_envs);
                assert!(outs.iter().all(|o| o.reset));
                for _ in 0..2 {
                    let outs = env.step(&vec![0; num_envs]).unwrap();
                    assert_eq!(outs.len(), num_envs);
                    assert!(outs.iter().all(|o| !o.reset));
                }
                done.fetch_add(1, Ordering::Relaxed);
            }
            let _ = tx.send(());
        })
    };
    // A pair takes well under a second; a minute without progress is a hang.
    let patience = std::time::Duration::from_secs(60);
    let mut last = (0, std::time::Instant::now());
    loop {
        match rx.recv_timeout(std::time::Duration::from_secs(1)) {
            Ok(()) => break,
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                // The worker panicked: its failure is the test's.
                if let Err(e) = worker.join() {
                    std::panic::resume_unwind(e);
                }
                panic!("the worker ended without finishing the grid");
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                let k = done.load(Ordering::Relaxed);
                if k != last.0 {
                    last = (k, std::time::Instant::now());
                } else if last.1.elapsed() > patience {
                    panic!(
                        "hung: {} environments on {} threads did not reset and step within \
                         {patience:?} ({k} of {} pairs done)",
                        grid[k].0,
                        grid[k].1,
                        grid.len(),
                    );
                }
            }
        }
    }
    assert_eq!(done.load(Ordering::Relaxed), grid.len());
}

#[test]
fn the_stepper_numbers_actions_once_and_refuses_steps_outside_an_episode() {
    use minos::episode::interchange::DEFAULT_MAX_STEPS;
    use minos::run::stepper::{
        step_many, ActionSpace, Command, EpisodeStepper, StepError, StepperConfig,
    };
    // The action set: the motion model's single actions, then stop; indices round-trip.
    for body in [
        AgentConfig::habitat(),
        AgentConfig::minos_continuous(),
        AgentConfig::preset(minos::body::AgentPreset::MinosPaper),
    ] {
        let set = ActionSpace::of(&body);
        let names = set.names();
        assert_eq!(names.len(), set.len());
        assert_eq!(names.last(), Some(&"stop"));
        assert_eq!(&names[..names.len() - 1], body.action_names());
        for (i, name) in names.iter().enumerate() {
            let d = set.decision(i).unwrap();
            assert_eq!(set.index_of(&d), Some(i), "{name}");
            assert_eq!(&d.name(), name);
        }
        assert_eq!(set.decision(set.len()), None);
    }
    assert_eq!(
        ActionSpace::of(&AgentConfig::habitat()).names(),
        ["forward", "turn_left", "turn_right", "stop"]
    );
    // The MINOS paper's agent: continuous motion, forward and turns only.
    assert_eq!(
        ActionSpace::of(&AgentConfig::preset(minos::body::AgentPreset::MinosPaper)).names(),
        ["forward", "turn_left", "turn_right", "stop"]
    );
    // Stepping before a reset, after the end, or a batch of the wrong size is an error.
    let ep = first_episodes(|t| t == Task::PointGoal, 1).remove(0);
    let body = AgentConfig::habitat();
    let (assets, renderer) = minos::pipeline::rollout::load_scene_assets(
        &minos::store::DataDir::new(data().0.path().join("DATA")),
        &ep.scene_id,
        &body,
        RendererChoice::Cpu,
        false,
    )
    .unwrap();
    let sim = minos::sim::Simulator::new(assets, renderer, body, blind(), DEFAULT_MAX_STEPS, 0);
    let cfg = StepperConfig {
        max_steps: Some(2),
        ..StepperConfig::default()
    };
    let mut stepper = EpisodeStepper::new(sim, cfg);
    let turn = Decision::from_name("turn_left").unwrap();
    assert!(matches!(stepper.step(turn), Err(StepError::NotReset)));
    assert!(matches!(stepper.metrics(), Err(StepError::NotReset)));
    stepper.reset(&ep).unwrap();
    let first = stepper.step(turn).unwrap();
    assert!(!first.done() && first.steps == 1 && !first.reset);
    let last = stepper.step(turn).unwrap();
    assert!(
        last.truncated && !last.terminated && !last.success,
        "{last:?}"
    );
    assert!(matches!(stepper.step(turn), Err(StepError::Ended(id)) if id == ep.episode_id));
    let m = stepper.metrics().unwrap();
    assert_eq!((m.steps, m.success), (2, false));
    // A stop ends the episode without moving; a reset command starts it over.
    let restarted = stepper.run(Command::Reset(&ep)).unwrap();
    assert!(restarted.reset && restarted.reward == 0.0 && restarted.steps == 0);
    let stopped = stepper.step(Decision::Stop).unwrap();
    assert!(stopped.stopped && stopped.terminated && !stopped.success);
    assert_eq!(stepper.metrics().unwrap().path_length, 0.0);
    let mut batch = vec![stepper];
    assert!(matches!(
        step_many(&mut batch, &[]),
        Err(StepError::Batch {
            steppers: 1,
            commands: 0
        })
    ));
    let outs = step_many(&mut batch, &[Command::Reset(&ep)]).unwrap();
    assert!(outs[0].reset);
    // Prepared without observing (as a batch's start beside the lockstep): neither a step
    // nor a second observation before its first observation, which is the reset's own.
    let reset_obs = batch[0].reset(&ep).unwrap().clone();
    assert!(matches!(
        step_many(&mut batch, &[Command::Observe]),
        Err(StepError::NotPrepared)
    ));
    batch[0].prepare_in(&ep, None);
    assert!(matches!(batch[0].step(turn), Err(StepError::NotPrepared)));
    let outs = step_many(&mut batch, &[Command::Observe]).unwrap();
    assert!(outs[0].reset && outs[0].steps == 0 && outs[0].reward == 0.0);
    assert_eq!(
        outs[0].obs, &reset_obs,
        "the first observation is the reset's"
    );
    assert!(batch[0].step(turn).unwrap().steps == 1);
}

#[test]
fn every_step_carries_goal_features_an_independent_computation_agrees_with() {
    // The trajectory table holds, per step, what the agent was given before its action.
    // Recomputed here from the row's pose and the episode alone: the goal vector (3-D
    // distance; horizontal unit direction in the agent frame, right = (cos yaw, −sin yaw),
    // forward = (−sin yaw, −cos yaw) in world x, z), whether a point goal is within its
    // radius, the goal class, the steps left, the previous row's action and collision; and
    // for every task the geodesic is never below the straight line to the same target.
    use minos::episode::Goal;
    let dir = tempfile::tempdir().unwrap();
    let mut episodes = first_episodes(|t| t == Task::PointGoal, 4);
    episodes.extend(first_episodes(|t| t == Task::ObjectGoal, 3));
    episodes.extend(first_episodes(|t| t == Task::RoomGoal, 3));
    let out = dir.path().join("oracle");
    let report = rollout(
        &config(&out, AgentKind::Oracle, blind()),
        &episodes,
        &NoProgress,
    )
    .unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let by_id: std::collections::HashMap<&str, &Episode> = episodes
        .iter()
        .map(|e| (e.episode_id.as_str(), e))
        .collect();
    let mut checked = [0usize; 3];
    for b in all_batches(&out.join("trajectories.parquet")) {
        let ids = column::<StringArray>(&b, "episode_id");
        let f = |name: &str| column::<Float32Array>(&b, name).clone();
        let (x, y, z, yaw) = (f("x"), f("y"), f("z"), f("yaw"));
        let (d, right, forward, geo) = (
            f("euclidean_distance"),
            f("goal_right"),
            f("goal_forward"),
            f("geodesic_distance"),
        );
        let flag = |name: &str| column::<arrow::array::BooleanArray>(&b, name).clone();
        let (at_goal, prev_collision, collision) = (
            flag("at_goal"),
            flag("previous_collision"),
            flag("collision"),
        );
        let text = |name: &str| column::<StringArray>(&b, name).clone();
        let (room, object, previous, action) = (
            text("goal_room"),
            text("goal_object"),
            text("previous_action"),
            text("action"),
        );
        let steps = column::<UInt32Array>(&b, "step");
        let left = column::<UInt32Array>(&b, "steps_left");
        for r in 0..b.num_rows() {
            let ep = by_id[ids.value(r)];
            let t = steps.value(r);
            assert_eq!(left.value(r), ep.max_steps - t, "steps left at step {t}");
            if t == 0 {
                assert!(previous.is_null(r) && !prev_collision.value(r));
            } else {
                assert_eq!(previous.value(r), action.value(r - 1), "previous action");
                assert_eq!(prev_collision.value(r), collision.value(r - 1));
            }
            assert!(!d.is_null(r) && !right.is_null(r) && !forward.is_null(r));
            let dir_len = right.value(r).hypot(forward.value(r));
            // A unit vector, or zero on the target itself.
            assert!(
                (dir_len - 1.0).abs() < 1e-4 || (dir_len == 0.0 && d.value(r) < 1e-3),
                "direction of length {dir_len} at distance {}",
                d.value(r)
            );
            if !geo.is_null(r) {
                assert!(
                    geo.value(r) >= d.value(r) - 1e-4,
                    "{} step {t}: geodesic {} below the straight line {}",
                    ep.episode_id,
                    geo.value(r),
                    d.value(r)
                );
            }
            match &ep.goal {
                Goal::Point { position } => {
                    let (dx, dy, dz) = (
                        position[0] - x.value(r),
                        position[1] - y.value(r),
                        position[2] - z.value(r),
                    );
                    let dist = (dx * dx + dy * dy + dz * dz).sqrt();
                    assert!((d.value(r) - dist).abs() < 1e-4, "{} vs {dist}", d.value(r));
                    let (s, c) = yaw.value(r).sin_cos();
                    let h = dx.hypot(dz);
                    let (rx, fx) = ((dx * c - dz * s) / h, (-dx * s - dz * c) / h);
                    assert!((right.value(r) - rx).abs() < 1e-4, "right {rx}");
                    assert!((forward.value(r) - fx).abs() < 1e-4, "forward {fx}");
                    assert_eq!(at_goal.value(r), dist <= ep.success_radius, "at goal");
                    assert!(room.is_null(r) && object.is_null(r));
                    checked[0] += 1;
                }
                Goal::Object { category, .. } => {
                    assert_eq!(object.value(r), category);
                    assert!(room.is_null(r));
                    checked[1] += 1;
                }
                Goal::Room { class, .. } => {
                    let want = minos::scene::RoomClass::from_label(class).unwrap();
                    assert_eq!(room.value(r), want.name());
                    assert!(object.is_null(r));
                    checked[2] += 1;
                }
            }
            if action.value(r) == "stop" {
                assert!(at_goal.value(r), "the oracle stops at the goal");
            }
        }
    }
    assert!(checked.iter().all(|&n| n > 0), "rows per task: {checked:?}");
}

#[test]
fn runs_stepped_in_lockstep_batches_write_the_per_thread_bytes() {
    // `minos run --batch N` steps N environments per scene together (one render call per
    // step); every episode is still seeded from its own id, so the run folder is the same
    // bytes as one simulator per thread — for the oracle (stops, every task) and a random
    // agent (arrivals, the step limit), with a recording, on the CPU and, where an adapter
    // exists (lavapipe in CI), on wgpu.
    let dir = tempfile::tempdir().unwrap();
    let mut episodes = first_episodes(|t| t == Task::PointGoal, 5);
    episodes.extend(first_episodes(|t| t != Task::PointGoal, 4));
    let gpu = minos::render::gpu::GpuRenderer::new()
        .map_err(|e| common::skip(format!("the wgpu part: {e}")))
        .is_ok();
    let mut renderers = vec![RendererChoice::Cpu];
    if gpu {
        renderers.push(RendererChoice::Wgpu);
    }
    for renderer in renderers {
        for (agent, max_steps) in [(AgentKind::Oracle, None), (AgentKind::Random, Some(30))] {
            let mut folders = Vec::new();
            for batch in [1, 4, 64] {
                let out = dir.path().join(format!("{renderer:?}-{agent:?}-{batch}"));
                let mut cfg = config(&out, agent.clone(), SensorSuite::minos(16));
                cfg.renderer = renderer;
                cfg.max_steps = max_steps;
                cfg.batch = Some(batch);
                cfg.rerun = Some(minos::pipeline::rollout::RerunOutput {
                    // One path for all (the manifest names it).
                    path: dir.path().join("recording.rrd"),
                    episodes: 2,
                });
                let report = rollout(&cfg, &episodes, &NoProgress).unwrap();
                assert!(report.failures.is_empty(), "{:?}", report.failures);
                assert_eq!(report.episodes.len(), episodes.len());
                folders.push(common::tree_bytes(&out));
            }
            let bytes = |k: usize| &folders[k];
            assert!(!bytes(0).is_empty());
            for k in 1..folders.len() {
                let (a, b) = (bytes(0), bytes(k));
                assert_eq!(a.len(), b.len(), "{renderer:?} {agent:?}: the same files");
                for ((pa, ba), (pb, bb)) in a.iter().zip(b) {
                    assert_eq!(pa, pb);
                    assert!(ba == bb, "{renderer:?} {agent:?}: {} differs", pa.display());
                }
            }
        }
    }
}
