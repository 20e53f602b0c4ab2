//! Episodes on generated houses: every episode is reachable and its stored geodesic equals a
//! fresh path query; filters act; output is identical across threads and shards; Habitat
//! export round-trips.

use crate::common;

use std::path::Path;

use common::{generate_into, ingest_into};
use minos::body::{AgentBody, BodyRule};
use minos::episode::format::write_episodes;
use minos::episode::habitat::{export_habitat, import_habitat};
use minos::episode::sample::{path_length_between, SampleConfig, Select};
use minos::episode::{Goal, Task};
use minos::generate::GenerateConfig;
use minos::navmesh::geodesic::{distance_field, Geodesic};
use minos::navmesh::path::{nearest_polyline_in, path_from_field, PathResult};
use minos::navmesh::route::route;
use minos::navmesh::{NavGrid, NavParams};
use minos::pipeline::bake::{bake_scenes, BakeConfig};
use minos::pipeline::episodes::{sample_scenes, EpisodeBatch};
use minos::progress::NoProgress;
use minos::shard::Shard;
use minos::store::manifest::read_manifest;

/// A baked DATA folder of generated houses, shared by the tests of this file.
fn data() -> &'static (tempfile::TempDir, Vec<(String, String)>) {
    static DATA: std::sync::OnceLock<(tempfile::TempDir, Vec<(String, String)>)> =
        std::sync::OnceLock::new();
    DATA.get_or_init(|| {
        let dir = common::shared_tempdir();
        let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
        let cfg = GenerateConfig {
            houses: 10,
            seed: 9,
            rooms: (3, 8),
            levels: (1, 2),
            closed_door_prob: 0.25,
            ..Default::default()
        };
        generate_into(&cfg, &root);
        ingest_into(&root, &data);
        let ids: Vec<String> = read_manifest(&minos::store::DataDir::new(&data).manifest_path())
            .unwrap()
            .into_iter()
            .map(|r| r.id)
            .collect();
        let bake = BakeConfig {
            data: minos::store::DataDir::new(&data),
            scenes: ids.iter().map(|id| id.parse().unwrap()).collect(),
            params: NavParams::default(),
            force: false,
            previews: false,
        };
        let report = bake_scenes(&bake, &NoProgress);
        assert_eq!(report.failures().count(), 0);
        let scenes = ids
            .into_iter()
            .enumerate()
            .map(|(i, id)| (id, ["train", "val", "test"][i % 3].to_string()))
            .collect();
        (dir, scenes)
    })
}

fn run(cfg: &SampleConfig, shard: Shard) -> EpisodeBatch {
    let (dir, scenes) = data();
    sample_scenes(
        &minos::store::DataDir::new(dir.path().join("DATA")),
        scenes,
        cfg,
        BodyRule::strict(AgentBody::HABITAT),
        shard,
        &NoProgress,
    )
}

fn grid(scene: &str) -> NavGrid {
    minos::store::DataDir::new(data().0.path().join("DATA"))
        .read_grid(&minos::scene::SceneRef::parse(scene))
        .unwrap()
}

/// The goal spans of an object or room goal, recomputed from the grid.
fn goal_spans(grid: &NavGrid, goal: &Goal, radius: f32) -> Vec<u32> {
    match goal {
        Goal::Point { .. } => unreachable!(),
        Goal::Object { targets, .. } => targets
            .iter()
            .flat_map(|t| {
                let i = grid.objects.iter().position(|o| o.id == t.id).unwrap() as u32;
                grid.object_spans(i, radius)
            })
            .collect(),
        Goal::Room { targets, .. } => targets
            .iter()
            .flat_map(|t| {
                let i = grid.rooms.iter().position(|r| r.id == t.id).unwrap() as u32;
                grid.room_spans(i)
            })
            .collect(),
    }
}

#[test]
fn every_episode_is_reachable_and_its_geodesic_matches_a_fresh_query() {
    for task in [Task::PointGoal, Task::ObjectGoal, Task::RoomGoal] {
        for select in [Select::Any, Select::Closest, Select::Random] {
            if task == Task::PointGoal && select != Select::Any {
                continue;
            }
            let cfg = SampleConfig {
                task,
                select,
                per_scene: 6,
                seed: 3,
                ..SampleConfig::default()
            };
            let batch = run(&cfg, Shard::ALL);
            assert!(
                batch.total >= 30,
                "{task:?} {select:?}: only {} episodes",
                batch.total
            );
            for e in &batch.episodes {
                let g = grid(&e.scene_id);
                let start = glam::Vec3::from_array(e.start_position);
                let fresh = match &e.goal {
                    Goal::Point { position } => {
                        let r = route(&g, start, glam::Vec3::from_array(*position)).unwrap();
                        // Rooms and doors are listed only for kept pairs: still those of
                        // the fresh path.
                        assert_eq!(
                            (e.path_num_doors, e.path_num_rooms),
                            (r.doors.len() as u32, r.rooms.len() as u32),
                            "{}",
                            e.episode_id
                        );
                        r.geodesic.expect("reachable")
                    }
                    goal => {
                        // The sampler's query to the nearest goal span, made afresh; and a
                        // distance field from the goal spans (an independent search, whose
                        // any-angle paths may be up to 1 % longer, a little more on ramps).
                        let spans = goal_spans(&g, goal, e.success_radius);
                        let from = g.snap(start).unwrap();
                        let island = g.spans[from as usize].island;
                        let on_island: Vec<u32> = spans
                            .iter()
                            .copied()
                            .filter(|&s| g.spans[s as usize].island == island)
                            .collect();
                        let geo = Geodesic::new(&g);
                        let regions = geo.goal_regions(&[&on_island]);
                        let field = distance_field(&g, &spans);
                        let PathResult::Found(f) = path_from_field(&g, &field, from) else {
                            panic!("{} unreachable", e.episode_id)
                        };
                        let by_field = path_length_between(&f, start, *f.points.last().unwrap());
                        let fresh = match nearest_polyline_in(&geo, from, &regions) {
                            Some(p) => path_length_between(&p, start, *p.points.last().unwrap()),
                            None => by_field,
                        };
                        assert!(
                            fresh <= by_field * 1.01 + 1e-3 && fresh >= by_field * 0.95,
                            "{}: {fresh} vs the field's {by_field}",
                            e.episode_id
                        );
                        fresh
                    }
                };
                assert!(
                    (fresh - e.geodesic_distance).abs() < 1e-3,
                    "{}: stored {} vs fresh {fresh}",
                    e.episode_id,
                    e.geodesic_distance
                );
                assert!(
                    e.geodesic_distance >= cfg.min_geodesic
                        && e.geodesic_distance <= cfg.max_geodesic
                );
                assert!(
                    e.geodesic_distance + 1e-3 >= e.euclidean_distance,
                    "{}",
                    e.episode_id
                );
            }
        }
    }
}

#[test]
fn the_ratio_door_and_room_filters_act() {
    let base = SampleConfig {
        per_scene: 20,
        seed: 5,
        ..SampleConfig::default()
    };
    let straight = |b: &EpisodeBatch| {
        b.episodes
            .iter()
            .filter(|e| e.geodesic_distance / e.euclidean_distance < 1.1)
            .count() as f64
            / b.total as f64
    };
    let without = run(
        &SampleConfig {
            ratio_rule: false,
            ..base.clone()
        },
        Shard::ALL,
    );
    let with = run(&base, Shard::ALL);
    assert!(
        straight(&with) < 0.5 * straight(&without),
        "ratio < 1.1: {} with the rule, {} without",
        straight(&with),
        straight(&without)
    );
    assert!(with.rejected.contains_key("geodesic/euclidean ratio rule"));
    assert!(without.episodes.iter().any(|e| e.path_num_doors == 0));
    let doors = run(
        &SampleConfig {
            min_doors: 1,
            ..base.clone()
        },
        Shard::ALL,
    );
    assert!(doors.total > 0 && doors.episodes.iter().all(|e| e.path_num_doors >= 1));
    let rooms = run(
        &SampleConfig {
            min_rooms: 3,
            ..base.clone()
        },
        Shard::ALL,
    );
    assert!(rooms.total > 0 && rooms.episodes.iter().all(|e| e.path_num_rooms >= 3));
    assert!(rooms.rejected["fewer rooms than min_rooms"] > 0);
}

#[test]
fn shards_union_to_the_unsharded_run_and_threads_do_not_matter() {
    let cfg = SampleConfig {
        task: Task::ObjectGoal,
        per_scene: 5,
        seed: 8,
        ..SampleConfig::default()
    };
    let all = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| run(&cfg, Shard::ALL));
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap()
        .install(|| run(&cfg, Shard::ALL));
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.parquet"), dir.path().join("b.parquet"));
    write_episodes(&a, &all.episodes).unwrap();
    write_episodes(&b, &two.episodes).unwrap();
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    let mut union: Vec<_> = (0..3)
        .flat_map(|i| run(&cfg, Shard { index: i, count: 3 }).episodes)
        .collect();
    union.sort_by(|x, y| x.episode_id.cmp(&y.episode_id));
    let mut expected = all.episodes.clone();
    expected.sort_by(|x, y| x.episode_id.cmp(&y.episode_id));
    assert_eq!(union, expected);
    // Another seed gives other episodes.
    let other = run(&SampleConfig { seed: 9, ..cfg }, Shard::ALL);
    assert_ne!(
        other.episodes[0].start_position,
        all.episodes[0].start_position
    );
}

#[test]
fn habitat_export_and_import_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    for task in [Task::PointGoal, Task::ObjectGoal] {
        let batch = run(
            &SampleConfig {
                task,
                per_scene: 4,
                seed: 1,
                ..SampleConfig::default()
            },
            Shard::ALL,
        );
        let val: Vec<_> = batch
            .episodes
            .iter()
            .filter(|e| e.split == "val")
            .cloned()
            .collect();
        let out = dir.path().join(task.name());
        export_habitat(&out, "val", &Default::default(), &val).unwrap();
        let mut back = Vec::new();
        for f in std::fs::read_dir(out.join("val/content"))
            .unwrap()
            .flatten()
        {
            back.extend(import_habitat(&f.path()).unwrap());
        }
        assert_eq!(back.len(), val.len());
        for e in &val {
            let b = back
                .iter()
                .find(|b| b.start_position == e.start_position)
                .unwrap_or_else(|| panic!("{} lost", e.episode_id));
            assert!((b.geodesic_distance - e.geodesic_distance).abs() < 1e-4);
            let dyaw = (b.start_yaw - e.start_yaw).rem_euclid(std::f32::consts::TAU);
            assert!(
                !(1e-4..=std::f32::consts::TAU - 1e-4).contains(&dyaw),
                "{} vs {}",
                b.start_yaw,
                e.start_yaw
            );
            match (&b.goal, &e.goal) {
                (Goal::Point { position: p }, Goal::Point { position: q }) => assert_eq!(p, q),
                (
                    Goal::Object {
                        category: c,
                        targets: t,
                    },
                    Goal::Object {
                        category: d,
                        targets: u,
                    },
                ) => {
                    assert_eq!(c, d);
                    let ids = |t: &[minos::episode::GoalTarget]| {
                        t.iter()
                            .map(|x| x.id.clone())
                            .collect::<std::collections::BTreeSet<_>>()
                    };
                    assert!(ids(u).is_subset(&ids(t)));
                }
                other => panic!("goal changed: {other:?}"),
            }
        }
    }
    assert!(Path::new(&dir.path().join("pointgoal/val/val.json.gz")).is_file());
}

#[test]
fn a_simulator_reset_to_an_episode_measures_its_stored_geodesic() {
    use std::sync::Arc;
    for task in [Task::PointGoal, Task::ObjectGoal, Task::RoomGoal] {
        let batch = run(
            &SampleConfig {
                task,
                per_scene: 2,
                seed: 12,
                ..SampleConfig::default()
            },
            Shard::ALL,
        );
        let e = &batch.episodes[0];
        let (dir, _) = data();
        let data = dir.path().join("DATA");
        let (_, scene) = minos::store::DataDir::new(&data)
            .read_scene(&e.scene_id)
            .unwrap();
        let agent = minos::sim::AgentConfig::habitat();
        let assets =
            Arc::new(minos::sim::SceneAssets::new(&scene, grid(&e.scene_id), &agent).unwrap());
        let renderer = Arc::new(minos::render::Renderer::Cpu);
        let sensors = minos::sim::SensorSuite {
            cameras: vec![],
            contact: None,
        };
        let mut sim = minos::sim::Simulator::new(assets, renderer, agent, sensors, e.max_steps, 0);
        sim.reset_episode(e);
        let m = sim.observe().unwrap().measurements;
        let got = m.goal_geodesic.expect("reachable");
        // The episode's distance comes from a point-to-point or nearest-goal search over the
        // sparse graph, the measurement from a field: equal within 1%.
        let tol = 0.01;
        assert!(
            (got - e.geodesic_distance).abs() < tol * e.geodesic_distance.max(1.0),
            "{task:?}: {got} vs {}",
            e.geodesic_distance
        );
        assert_eq!(m.position, e.start_position);
    }
}

/// The Python the ecosystem tests run (`MINOS_PYTHON`, else `python3`), or `None` (with the
/// reason printed) when it lacks pyarrow and pandas.
fn python_with_pandas() -> Option<String> {
    let python = std::env::var("MINOS_PYTHON").unwrap_or_else(|_| "python3".into());
    let probe = std::process::Command::new(&python)
        .args(["-c", "import pyarrow, pandas"])
        .output();
    match probe {
        Ok(o) if o.status.success() => Some(python),
        _ => {
            common::skip(format!(
                "`{python} -c 'import pyarrow, pandas'` fails (pip install pyarrow pandas \
                 polars duckdb, or set MINOS_PYTHON to a Python that has them)"
            ));
            None
        }
    }
}

#[test]
fn episode_files_rewritten_by_pandas_polars_duckdb_and_pyarrow_read_back_the_same() {
    let Some(python) = python_with_pandas() else {
        return;
    };
    // Every task in one file: list columns with and without values, null categories.
    let mut episodes = Vec::new();
    for task in [Task::PointGoal, Task::ObjectGoal, Task::RoomGoal] {
        let cfg = SampleConfig {
            task,
            per_scene: 2,
            seed: 5,
            ..SampleConfig::default()
        };
        episodes.extend(run(&cfg, Shard::ALL).episodes);
    }
    assert!(episodes.iter().any(|e| e.task == Task::ObjectGoal));
    let dir = tempfile::tempdir().unwrap();
    let original = dir.path().join("episodes.parquet");
    write_episodes(&original, &episodes).unwrap();
    let out = dir.path().join("rewritten");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/rewrite_parquet.py");
    let rewrite = std::process::Command::new(&python)
        .arg(&script)
        .arg(&original)
        .arg(&out)
        .output()
        .expect("python runs");
    let said = String::from_utf8_lossy(&rewrite.stdout).to_string();
    assert!(
        rewrite.status.success(),
        "{said}\n{}",
        String::from_utf8_lossy(&rewrite.stderr)
    );
    for line in said.lines().filter_map(|l| l.strip_prefix("skipped: ")) {
        common::skip(line);
    }
    let files: Vec<&str> = said.lines().filter(|l| l.ends_with(".parquet")).collect();
    // pyarrow and pandas at least, each with every compression.
    for c in ["snappy", "gzip", "brotli", "lz4", "zstd", "none"] {
        for lib in ["pyarrow-plain", "pandas-numpy"] {
            let name = format!("{lib}-{c}.parquet");
            assert!(files.iter().any(|f| f.ends_with(&name)), "{name}: {said}");
        }
    }
    // What minos reads back, written again by minos: the same bytes as the original file.
    let again = dir.path().join("again.parquet");
    let objectgoal: Vec<_> = episodes
        .iter()
        .filter(|e| e.task == Task::ObjectGoal)
        .cloned()
        .collect();
    for file in &files {
        let back = minos::episode::format::read_episodes(Path::new(file))
            .unwrap_or_else(|e| panic!("{file}: {e}"));
        let expected = if file.contains("-filtered-") {
            &objectgoal
        } else {
            &episodes
        };
        write_episodes(&again, &back).unwrap();
        let reference = dir.path().join("reference.parquet");
        write_episodes(&reference, expected).unwrap();
        assert_eq!(
            std::fs::read(&again).unwrap(),
            std::fs::read(&reference).unwrap(),
            "{file}: other episodes than written"
        );
    }
    eprintln!("{} rewritten episode files read back", files.len());
}

/// MINOS's episode states: PointGoal episodes with a doorway on the path give their starts to
/// ObjectGoal episodes, which keep each start's position and yaw, in order, and draw their
/// own goal; the starts file round-trips through Parquet; a scene without starts, or a start
/// off the floor, yields no episode and says why.
#[test]
fn given_starts_get_the_tasks_goals_in_order() {
    use minos::episode::sample::Start;
    use minos::pipeline::episodes::{read_starts, sample_scenes_from, StartsByScene};

    let (dir, scenes) = data();
    let states = run(
        &SampleConfig {
            task: Task::PointGoal,
            per_scene: 6,
            seed: 3,
            min_doors: 1,
            ratio_rule: false,
            ..SampleConfig::default()
        },
        Shard::ALL,
    );
    assert!(states.total >= 20, "{} states", states.total);
    let file = dir.path().join("states.parquet");
    write_episodes(&file, &states.episodes).unwrap();
    let mut starts = read_starts(&file).unwrap();
    let mut expected = StartsByScene::new();
    for e in &states.episodes {
        expected.entry(e.scene_id.clone()).or_default().push(Start {
            position: e.start_position,
            yaw: e.start_yaw,
        });
    }
    assert_eq!(starts, expected);
    // One scene loses its starts; another gets one in mid-air first.
    let (without, _) = &scenes[0];
    starts.remove(without);
    let (lifted, _) = scenes
        .iter()
        .skip(1)
        .find(|(id, _)| starts.contains_key(id))
        .unwrap();
    let first = starts[lifted][0];
    starts.get_mut(lifted).unwrap().insert(
        0,
        Start {
            position: [
                first.position[0],
                first.position[1] + 50.0,
                first.position[2],
            ],
            ..first
        },
    );
    let cfg = SampleConfig {
        task: Task::ObjectGoal,
        select: Select::Random,
        per_scene: 6,
        seed: 3,
        ..SampleConfig::default()
    };
    let sample = |starts: &StartsByScene| {
        sample_scenes_from(
            &minos::store::DataDir::new(dir.path().join("DATA")),
            scenes,
            &cfg,
            BodyRule::strict(AgentBody::HABITAT),
            Shard::ALL,
            Some(starts),
            &NoProgress,
        )
    };
    let batch = sample(&starts);
    assert_eq!(
        batch.scenes[without].problem.as_deref(),
        Some("no starts given for this scene")
    );
    assert_eq!(
        batch.rejected.get("given start off the usable floor"),
        Some(&1)
    );
    assert!(
        batch.total * 2 >= states.total,
        "{} of {} starts got a goal",
        batch.total,
        states.total
    );
    for (id, given) in &starts {
        let eps: Vec<_> = batch
            .episodes
            .iter()
            .filter(|e| &e.scene_id == id)
            .collect();
        // The episodes' starts are the given ones, in order (those whose goal draw was
        // rejected left out), each with its yaw.
        let mut rest = given.iter();
        for e in &eps {
            assert!(
                rest.any(|s| s.position == e.start_position && s.yaw == e.start_yaw),
                "{}: start {:?} not among the given ones in order",
                e.episode_id,
                e.start_position
            );
            assert!(matches!(&e.goal, Goal::Object { targets, .. } if targets.len() == 1));
        }
    }
    // The same starts and seed give the same episodes.
    assert_eq!(sample(&starts).episodes, batch.episodes);
}
