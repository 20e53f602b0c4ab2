//! VLN episodes on generated furnished houses: instructions are grounded (checked by
//! rendering the instance camera along the reference path and by independent geometry),
//! byte-identical whatever the threads or shards, stored and read back exactly, and exported
//! as VLN-CE and R2R files.

use crate::common;

use std::collections::BTreeSet;

use glam::Vec3;
use minos::body::{AgentBody, BodyRule};
use minos::episode::format::{read_episodes, write_episodes};
use minos::episode::sample::{SampleConfig, Select};
use minos::episode::vln::grammar::{category_words, room_words, Mention};
use minos::episode::vln::landmarks::SceneIndex;
use minos::episode::vln::walk::LANDMARK_DISTANCE;
use minos::episode::vln::{describe_route, instruction_seed, Described, RouteEnds};
use minos::episode::{Episode, Goal, Task};
use minos::generate::GenerateConfig;
use minos::navmesh::path::shortest_path;
use minos::navmesh::{NavGrid, NONE};
use minos::pipeline::episodes::{sample_scenes, EpisodeBatch};
use minos::progress::NoProgress;
use minos::render::Camera;
use minos::render::RenderScene;
use minos::scene::{Scene, SceneRef};
use minos::shard::Shard;
use minos::store::DataDir;

/// The fixture: its folder, the DATA folder, and the scenes with their subsets.
type Fixture = (tempfile::TempDir, DataDir, Vec<(String, String)>);

/// Furnished generated houses (some with two levels), baked, shared by the tests.
fn data() -> &'static Fixture {
    static DATA: std::sync::OnceLock<Fixture> = std::sync::OnceLock::new();
    DATA.get_or_init(|| {
        // Kept in a static, never dropped: under the fixture root each run clears.
        let dir = common::shared_tempdir();
        let cfg = GenerateConfig {
            houses: 6,
            seed: 31,
            rooms: (4, 8),
            levels: (1, 2),
            closed_door_prob: 0.0,
            ..Default::default()
        };
        let (data, ids) = common::baked_houses(dir.path(), &cfg);
        let scenes = ids
            .into_iter()
            .enumerate()
            .map(|(i, id)| (id, ["train", "val", "test"][i % 3].to_string()))
            .collect();
        (dir, data, scenes)
    })
}

fn vln_config(seed: u64) -> SampleConfig {
    SampleConfig {
        task: Task::Vln,
        per_scene: 12,
        seed,
        min_geodesic: 4.0,
        min_rooms: 2,
        success_radius: 3.0,
        select: Select::Any,
        ..SampleConfig::default()
    }
}

fn run(cfg: &SampleConfig, shard: Shard) -> EpisodeBatch {
    let (_, data, scenes) = data();
    sample_scenes(
        data,
        scenes,
        cfg,
        BodyRule::strict(AgentBody::HABITAT),
        shard,
        &NoProgress,
    )
}

fn grid_and_scene(id: &str) -> (NavGrid, Scene) {
    let data = &data().1;
    let r = SceneRef::parse(id);
    let grid = data.read_grid(&r).unwrap();
    let (scene, _) = data.load_scene(&r).unwrap();
    (grid, scene)
}

/// The route of `e` described again from a fresh path query, as the sampler did.
fn redescribe(grid: &NavGrid, index: &SceneIndex, e: &Episode, k: usize) -> Described {
    let route = e.route.as_ref().expect("a VLN episode has a route");
    let Goal::Point { position } = e.goal else {
        panic!("VLN goals are points")
    };
    let (start, goal) = (
        Vec3::from_array(e.start_position),
        Vec3::from_array(position),
    );
    let (a, b) = (grid.span_at(start).unwrap(), grid.span_at(goal).unwrap());
    let path = shortest_path(grid, a, b).path().cloned().unwrap();
    let goal_object = route
        .goal_object
        .as_ref()
        .map(|id| grid.objects.iter().position(|o| &o.id == id).unwrap() as u32);
    describe_route(
        grid,
        index,
        &path,
        RouteEnds {
            start,
            goal,
            yaw: e.start_yaw,
            goal_object,
        },
        instruction_seed(e.seed, k),
        route.instructions.len(),
    )
}

/// The point of polyline `points` at distance `at` along it, and the direction there.
fn point_at(points: &[[f32; 3]], at: f32) -> (Vec3, Vec3) {
    let mut left = at;
    for w in points.windows(2) {
        let (a, b) = (Vec3::from_array(w[0]), Vec3::from_array(w[1]));
        let len = a.distance(b);
        if left <= len || std::ptr::eq(w, points.windows(2).last().unwrap()) {
            let t = if len > 0.0 {
                (left / len).clamp(0.0, 1.0)
            } else {
                0.0
            };
            return (a.lerp(b, t), (b - a).normalize_or_zero());
        }
        left -= len;
    }
    (Vec3::from_array(points[0]), Vec3::NEG_Z)
}

/// XZ distance from `p` to an object's box.
fn box_distance(p: Vec3, min: [f32; 3], max: [f32; 3]) -> f32 {
    let dx = (min[0] - p.x).max(0.0).max(p.x - max[0]);
    let dz = (min[2] - p.z).max(0.0).max(p.z - max[2]);
    (dx * dx + dz * dz).sqrt()
}

/// Rooms of the walkable spans under points every 5 cm along the reference path: the rooms
/// the path enters, computed without the walk that made the instructions.
fn rooms_along(grid: &NavGrid, points: &[[f32; 3]]) -> BTreeSet<u32> {
    let mut rooms = BTreeSet::new();
    for w in points.windows(2) {
        let (a, b) = (Vec3::from_array(w[0]), Vec3::from_array(w[1]));
        let n = (a.distance(b) / 0.05).ceil().max(1.0) as usize;
        for k in 0..=n {
            let p = a.lerp(b, k as f32 / n as f32);
            if let Some(s) = grid.span_at(p) {
                let r = grid.spans[s as usize].room;
                if r != NONE {
                    rooms.insert(r);
                }
            }
        }
    }
    rooms
}

#[test]
fn every_landmark_room_and_stop_named_is_grounded_in_the_scene() {
    let batch = run(&vln_config(5), Shard::ALL);
    assert!(batch.total >= 30, "{} episodes", batch.total);
    let mut by_scene: std::collections::BTreeMap<&str, Vec<(usize, &Episode)>> = Default::default();
    for e in &batch.episodes {
        let k: usize = e.episode_id.rsplit(':').next().unwrap().parse().unwrap();
        by_scene.entry(&e.scene_id).or_default().push((k, e));
    }
    let (mut landmarks, mut seen, mut rooms_named, mut stops) = (0, 0, 0, 0);
    for (scene_id, eps) in by_scene {
        let (grid, scene) = grid_and_scene(scene_id);
        // The instance camera numbers objects as the grid does.
        assert_eq!(scene.objects().count(), grid.objects.len());
        for (o, g) in scene.objects().zip(&grid.objects) {
            assert_eq!(o.id, g.id);
        }
        let render_scene = RenderScene::new(&scene);
        let index = SceneIndex::new(&grid);
        for (k, e) in eps {
            let route = e.route.as_ref().unwrap();
            let again = redescribe(&grid, &index, e, k);
            // The stored route is what describing the fresh path query gives.
            assert_eq!(&again.route, route.as_ref(), "{}", e.episode_id);
            let entered = rooms_along(&grid, &route.path);
            for r in &again.rendered {
                let text = r.text.to_lowercase();
                for m in &r.mentions {
                    match *m {
                        Mention::Room { room, .. } => {
                            rooms_named += 1;
                            assert!(
                                entered.contains(&room),
                                "{}: `{}` names room {} the path does not enter",
                                e.episode_id,
                                r.text,
                                grid.rooms[room as usize].id
                            );
                            let words = room_words(grid.rooms[room as usize].class);
                            assert!(
                                text.contains(words),
                                "{}: `{}` lacks `{words}`",
                                e.episode_id,
                                r.text
                            );
                        }
                        Mention::Landmark { object, at } => {
                            landmarks += 1;
                            let obj = &grid.objects[object as usize];
                            let name = category_words(&obj.category);
                            assert!(
                                text.contains(&name),
                                "{}: `{}` lacks `{name}`",
                                e.episode_id,
                                r.text
                            );
                            let (p, _) = point_at(&route.path, at);
                            let near = box_distance(p, obj.min, obj.max);
                            // Look at it from the path, eye height 1.25 m.
                            let centre = Vec3::new(
                                0.5 * (obj.min[0] + obj.max[0]),
                                0.5 * (obj.min[1] + obj.max[1]),
                                0.5 * (obj.min[2] + obj.max[2]),
                            );
                            let eye = p + Vec3::Y * 1.25;
                            let d = centre - eye;
                            let camera = Camera {
                                position: eye,
                                yaw: (-d.x).atan2(-d.z),
                                tilt: (d.y / d.x.hypot(d.z).max(1e-3)).atan(),
                                vfov_deg: 90.0,
                                width: 64,
                                height: 64,
                                near: 0.05,
                                far: 50.0,
                            };
                            let frame = minos::render::cpu::render(&render_scene, &camera);
                            let visible = frame.instance(&render_scene).contains(&(object + 1));
                            if visible {
                                seen += 1;
                            }
                            assert!(
                                visible || near <= LANDMARK_DISTANCE + 1e-3,
                                "{}: landmark {} ({name}) neither visible nor within {LANDMARK_DISTANCE} m ({near:.2} m) at {at:.2} m",
                                e.episode_id,
                                obj.id
                            );
                            // Only one of its category in its room.
                            let room = index.object_room[object as usize];
                            let same = grid
                                .objects
                                .iter()
                                .enumerate()
                                .filter(|(i, o)| {
                                    index.object_room[*i] == room
                                        && o.category.eq_ignore_ascii_case(&obj.category)
                                })
                                .count();
                            assert_eq!(same, 1, "{}: {} is not distinctive", e.episode_id, obj.id);
                        }
                        Mention::Goal { object, room } => {
                            stops += 1;
                            let Goal::Point { position } = e.goal else {
                                unreachable!()
                            };
                            let goal = Vec3::from_array(position);
                            let goal_room = grid.spans[grid.span_at(goal).unwrap() as usize].room;
                            if let Some(room) = room {
                                assert_eq!(
                                    room, goal_room,
                                    "{}: stop names another room",
                                    e.episode_id
                                );
                            }
                            let obj = &grid.objects[object as usize];
                            assert!(text.contains(&category_words(&obj.category)));
                            // The closest instance of its category to the goal among those
                            // beside the goal room's floor (within 0.3 m of it, at its height).
                            let room_floor = grid.room_spans(goal_room);
                            let beside_room = |o: &minos::navmesh::NavObject| {
                                room_floor.iter().any(|&s| {
                                    let p = grid.span_position(s as usize);
                                    box_distance(p, o.min, o.max) <= 0.3
                                        && o.min[1] < p.y + 2.0
                                        && o.max[1] > p.y - 0.2
                                })
                            };
                            let named = box_distance(goal, obj.min, obj.max);
                            assert!(
                                named <= 1.0 + 1e-3,
                                "{}: stop {named} m from the object",
                                e.episode_id
                            );
                            for (i, o) in grid.objects.iter().enumerate() {
                                if i as u32 != object
                                    && o.category.eq_ignore_ascii_case(&obj.category)
                                    && beside_room(o)
                                {
                                    assert!(
                                        box_distance(goal, o.min, o.max) > named,
                                        "{}: {} is as close to the goal as the named {}",
                                        e.episode_id,
                                        o.id,
                                        obj.id
                                    );
                                }
                            }
                        }
                    }
                }
            }
            // Multi-level routes name the stairs in every instruction.
            if route.levels.len() > 1 {
                assert!(e.levels_crossed > 0, "{}", e.episode_id);
                for t in &route.instructions {
                    assert!(
                        t.contains("stairs"),
                        "{}: `{t}` {:?} {} {:?}",
                        e.episode_id,
                        route.levels,
                        e.levels_crossed,
                        again.walk.events
                    );
                }
            }
        }
    }
    assert!(
        landmarks > 20 && rooms_named > 50 && stops > 20,
        "{landmarks} {rooms_named} {stops}"
    );
    // Most landmarks are in view from where they are mentioned, not only near.
    println!("landmarks in view where mentioned: {seen} of {landmarks}");
    assert!(
        seen * 100 >= landmarks * 85,
        "{seen} of {landmarks} landmarks in view"
    );
}

#[test]
fn vln_episodes_are_byte_identical_whatever_the_threads_or_shards_and_read_back_exactly() {
    let cfg = vln_config(7);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| run(&cfg, Shard::ALL));
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap()
        .install(|| run(&cfg, Shard::ALL));
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.parquet"), dir.path().join("b.parquet"));
    one.write(&a).unwrap();
    two.write(&b).unwrap();
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    let stats = |p: &std::path::Path| std::fs::read(format!("{}.stats.json", p.display())).unwrap();
    assert_eq!(stats(&a), stats(&b));
    let mut union: Vec<Episode> = (0..2)
        .flat_map(|i| run(&cfg, Shard { index: i, count: 2 }).episodes)
        .collect();
    union.sort_by(|x, y| x.episode_id.cmp(&y.episode_id));
    assert_eq!(union, one.episodes);
    // Read back exactly, routes and instructions included.
    let back = read_episodes(&a).unwrap();
    assert_eq!(back, one.episodes);
    assert!(back.iter().all(|e| e.task == Task::Vln
        && e.route.as_ref().is_some_and(
            |r| r.instructions.len() == 3 && r.instructions.iter().all(|t| t.ends_with('.'))
        )));
    // Three different instructions per route, most of the time.
    let varied = back
        .iter()
        .filter(|e| {
            let r = e.route.as_ref().unwrap();
            r.instructions.iter().collect::<BTreeSet<_>>().len() == 3
        })
        .count();
    assert!(varied * 10 >= back.len() * 9, "{varied} of {}", back.len());
    // Another seed, other routes.
    let other = run(&vln_config(8), Shard::ALL);
    assert_ne!(other.episodes[0].route, one.episodes[0].route);
    // Statistics: lengths and difficulty as computed here.
    let s: serde_json::Value = serde_json::from_slice(&stats(&a)).unwrap();
    let vln = &s["vln"];
    assert_eq!(vln["routes"], one.total);
    assert_eq!(vln["instructions"], one.total * 3);
    let words: Vec<usize> = one
        .episodes
        .iter()
        .flat_map(|e| e.route.as_ref().unwrap().instructions.clone())
        .map(|t| t.split_whitespace().count())
        .collect();
    let mean = words.iter().sum::<usize>() as f64 / words.len() as f64;
    assert!((vln["words"]["mean"].as_f64().unwrap() - mean).abs() < 1e-9);
    let hard = one
        .episodes
        .iter()
        .filter(|e| e.difficulty.name() == "hard")
        .count();
    assert_eq!(s["difficulty"]["hard"].as_u64().unwrap_or(0) as usize, hard);
    let multi = one.episodes.iter().filter(|e| e.levels_crossed > 0).count();
    assert!(multi > 0, "the two-level houses give routes across levels");
    let crossed: usize = s["levels_crossed"]
        .as_object()
        .unwrap()
        .iter()
        .filter(|(k, _)| k.as_str() != "0")
        .map(|(_, v)| v.as_u64().unwrap() as usize)
        .sum();
    assert_eq!(crossed, multi);
    // R2R: one entry per route; the heading faces where the start yaw faces, seen in
    // Matterport3D's z-up frame ((x, y, z) y-up is (x, −z, y) z-up; heading is clockwise
    // from +y, so the facing direction is (sin h, cos h)).
    let r2r = minos::episode::vln::export::export_r2r(dir.path(), "val", &one.episodes).unwrap();
    let entries: serde_json::Value = serde_json::from_slice(&std::fs::read(&r2r).unwrap()).unwrap();
    let entries = entries.as_array().unwrap();
    assert_eq!(entries.len(), one.total);
    for (i, (e, x)) in one.episodes.iter().zip(entries).enumerate() {
        let route = e.route.as_ref().unwrap();
        assert_eq!(x["path_id"].as_u64(), Some(i as u64 + 1));
        assert_eq!(x["scan"].as_str(), Some(e.scene_id.as_str()));
        assert_eq!(x["instructions"], serde_json::json!(route.instructions));
        assert_eq!(x["path"].as_array().unwrap().len(), route.path.len());
        // serde_json's default float parsing may differ in the last bit.
        let d = x["distance"].as_f64().unwrap();
        assert!((d - f64::from(e.geodesic_distance)).abs() < 1e-9, "{d}");
        let h = x["heading"].as_f64().unwrap();
        assert!((0.0..std::f64::consts::TAU).contains(&h));
        let (s, c) = (f64::from(e.start_yaw).sin(), f64::from(e.start_yaw).cos());
        let facing_zup = (-s, c);
        assert!((h.sin() - facing_zup.0).abs() < 1e-6 && (h.cos() - facing_zup.1).abs() < 1e-6);
    }
    // An episode file without the new columns (an older one) reads with no route.
    let mut plain = one.episodes[0].clone();
    plain.route = None;
    plain.task = Task::PointGoal;
    write_episodes(&b, &[plain.clone()]).unwrap();
    assert_eq!(read_episodes(&b).unwrap(), [plain]);
}

/// `minos run --agent oracle` on VLN episodes scores how closely the agent followed each
/// reference path (nDTW, recomputed here from the trajectory table): the oracle, walking
/// the shortest path the reference is, follows it closely; the table's other tasks have none.
#[test]
fn the_oracle_follows_the_reference_path_by_ndtw() {
    use arrow::array::{Array, Float32Array, StringArray};
    use common::RunOk;

    let (_, data, _) = data();
    let dir = tempfile::tempdir().unwrap();
    let eps = dir.path().join("vln.parquet");
    let mut batch = run(&vln_config(11), Shard::ALL);
    batch.episodes.truncate(8);
    write_episodes(&eps, &batch.episodes).unwrap();
    let out = dir.path().join("run");
    common::minos()
        .args(["-q", "run", "--agent", "oracle", "--size", "16", "--data"])
        .arg(data.root())
        .arg("--episodes")
        .arg(&eps)
        .arg("--out")
        .arg(&out)
        .ok_output();
    let table = |name: &str| {
        let f = std::fs::File::open(out.join(name)).unwrap();
        let builder =
            parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(f).unwrap();
        let schema = builder.schema().clone();
        let batches: Vec<_> = builder.build().unwrap().map(|b| b.unwrap()).collect();
        arrow::compute::concat_batches(&schema, &batches).unwrap()
    };
    let episodes = table("episodes.parquet");
    let trajectories = table("trajectories.parquet");
    let col = |b: &arrow::record_batch::RecordBatch, n: &str| b.column_by_name(n).unwrap().clone();
    let ids = col(&episodes, "episode_id");
    let ids = ids.as_any().downcast_ref::<StringArray>().unwrap();
    let ndtw = col(&episodes, "ndtw");
    let ndtw = ndtw.as_any().downcast_ref::<Float32Array>().unwrap();
    let t_ids = col(&trajectories, "episode_id");
    let t_ids = t_ids.as_any().downcast_ref::<StringArray>().unwrap();
    let xyz: Vec<std::sync::Arc<dyn Array>> = ["x", "y", "z"]
        .iter()
        .map(|n| col(&trajectories, n))
        .collect();
    let xyz: Vec<&Float32Array> = xyz
        .iter()
        .map(|a| a.as_any().downcast_ref::<Float32Array>().unwrap())
        .collect();
    assert_eq!(ids.len(), batch.episodes.len());
    let mut total = 0.0;
    for (r, e) in batch.episodes.iter().enumerate() {
        assert_eq!(ids.value(r), e.episode_id);
        let walked: Vec<[f32; 3]> = (0..t_ids.len())
            .filter(|&k| t_ids.value(k) == e.episode_id)
            .map(|k| [xyz[0].value(k), xyz[1].value(k), xyz[2].value(k)])
            .collect();
        let route = e.route.as_ref().unwrap();
        let want = minos::run::metrics::ndtw(&route.path, &walked);
        assert!(!ndtw.is_null(r), "{}", e.episode_id);
        assert!(
            (ndtw.value(r) - want).abs() < 1e-4,
            "{}: {} stored, {want} from the trajectory",
            e.episode_id,
            ndtw.value(r)
        );
        total += ndtw.value(r);
    }
    let mean = total / batch.episodes.len() as f32;
    assert!(
        mean > 0.8,
        "the oracle strays from the reference paths: nDTW {mean}"
    );
    let metrics: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("metrics.json")).unwrap()).unwrap();
    let reported = metrics["groups"]["all"]["ndtw"].as_f64().unwrap();
    assert!(
        (reported - f64::from(mean)).abs() < 1e-4,
        "{reported} against {mean}"
    );
}
