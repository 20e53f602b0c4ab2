//! Episode sampling throughput: `cargo bench --bench episodes`.
//!
//! Generated furnished houses (default configuration), baked at 5 cm; episodes per second on
//! one core for each task (ObjectGoal also with `--categories all`; VLN with three
//! instructions per route). Every task runs in each of `MINOS_BENCH_ROUNDS` rounds (5), and its
//! best time is kept, so that the rows compare with each other on a box whose load moves.
//! Prints Markdown rows for `docs/PERFORMANCE.md`.

use std::time::Instant;

use minos::body::{AgentBody, BodyRule};
use minos::episode::sample::{sample_scene, SampleConfig};
use minos::episode::Task;
use minos::navmesh::file::write_nav;
use minos::navmesh::geodesic::Geodesic;
use minos::navmesh::path::shortest_path_in;
use minos::pipeline::episodes::sample_scenes;
use minos::progress::NoProgress;
use minos::shard::Shard;

mod support;
fn main() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (data, ids) = support::baked_houses(dir.path(), 20, 4, AgentBody::MINOS);
    let scenes: Vec<(String, String)> = ids
        .iter()
        .map(|id| (id.clone(), "train".to_string()))
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    println!(
        "| task | episodes | time (1 core, best of rounds) | episodes/s/core | time / PointGoal's |\n|---|---|---|---|---|"
    );
    let mut rejected = Vec::new();
    // The tasks, ObjectGoal over every category of the scenes (open vocabulary), and VLN
    // with three instructions per route and its CLI defaults (4 m, two rooms).
    let runs = [
        (Task::PointGoal, false),
        (Task::ObjectGoal, false),
        (Task::ObjectGoal, true),
        (Task::RoomGoal, false),
        (Task::Vln, false),
    ];
    // Rounds over every task, the best time of each kept: the rows compare with each other
    // although the box's load moves between runs.
    let rounds: usize = std::env::var("MINOS_BENCH_ROUNDS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(5);
    let mut best = vec![f64::INFINITY; runs.len()];
    let mut totals = vec![0; runs.len()];
    for _ in 0..rounds.max(1) {
        for (k, &(task, all_categories)) in runs.iter().enumerate() {
            let vln = task == Task::Vln;
            let cfg = SampleConfig {
                task,
                per_scene: 100,
                seed: 1,
                all_categories,
                min_geodesic: if vln { 4.0 } else { 1.0 },
                min_rooms: if vln { 2 } else { 0 },
                success_radius: if vln { 3.0 } else { 0.2 },
                ..SampleConfig::default()
            };
            let t = Instant::now();
            let batch = pool.install(|| {
                sample_scenes(
                    &minos::store::DataDir::new(&data),
                    &scenes,
                    &cfg,
                    BodyRule::strict(AgentBody::MINOS),
                    Shard::ALL,
                    &NoProgress,
                )
            });
            best[k] = best[k].min(t.elapsed().as_secs_f64());
            if totals[k] == 0 {
                totals[k] = batch.total;
                rejected.push((task, batch.rejected.values().sum::<u64>()));
            }
        }
    }
    for (k, &(task, all_categories)) in runs.iter().enumerate() {
        println!(
            "| {}{} | {} | {:.3} s | {:.0} | {:.2}× |",
            task.name(),
            if all_categories {
                " (all categories)"
            } else {
                ""
            },
            totals[k],
            best[k],
            totals[k] as f64 / best[k],
            best[k] / best[0],
        );
    }
    for (task, n) in rejected {
        println!("{}: {n} draws rejected", task.name());
    }
    breakdown(&data, &ids);
}

/// Where PointGoal sampling spends its time, scene by scene: reading the grid (with the
/// line-of-sight squares and sparse graph edges stored in the file), building the geodesic
/// data (line-of-sight index from the stored squares, search records), the first path query on
/// the largest island (which builds the sparse graph, from the stored edges), the same two
/// without the stored parts for comparison, and sampling 100 episodes with all of that
/// reused.
fn breakdown(data: &std::path::Path, ids: &[String]) {
    let (mut read, mut geo_new, mut first, mut sample) = (0.0, 0.0, 0.0, 0.0);
    let (mut geo_unstored, mut first_unstored, mut first_unlabelled) = (0.0, 0.0, 0.0);
    let mut spans = 0usize;
    // Bytes of the files, of their stored sections (line-of-sight squares, sparse graph), and
    // the time to write them (building the stored parts included).
    let (mut file_bytes, mut squares_bytes, mut graph_bytes, mut write) = (0, 0, 0, 0.0);
    let mut labels_bytes = 0;
    let out = tempfile::tempdir().expect("tempdir");
    for id in ids {
        let t = Instant::now();
        let grid = minos::store::DataDir::new(data)
            .read_grid(&minos::scene::SceneRef::parse(id))
            .expect("nav");
        read += t.elapsed().as_secs_f64();
        spans += grid.spans.len();
        let bytes = std::fs::read(minos::store::DataDir::new(data).nav_path(&id.parse().unwrap()))
            .expect("nav");
        let header = u32::from_le_bytes(bytes[12..16].try_into().expect("header")) as usize;
        let arrays = 16
            + header
            + 4 * grid.column_start.len()
            + 56 * grid.spans.len()
            + 8 * grid.span_objects.len();
        file_bytes += bytes.len();
        squares_bytes += 16 + 4 * grid.spans.len();
        graph_bytes += bytes.len() - arrays - 16 - 4 * grid.spans.len();
        labels_bytes += grid.baked.sparse_labels.as_ref().map_or(0, |l| {
            40 + 4 * (l.area.len() + l.verts.len()) + 8 * (l.portals.len() + l.portal_gates.len())
        });
        let t = Instant::now();
        write_nav(&out.path().join("g.nav"), &grid).expect("write");
        write += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let geo = Geodesic::new(&grid);
        geo_new += t.elapsed().as_secs_f64();
        assert_eq!(grid.baked.sight_squares.len(), grid.spans.len());
        let mut bare = grid.clone();
        bare.baked = Default::default();
        let t = Instant::now();
        let bare_geo = Geodesic::new(&bare);
        geo_unstored += t.elapsed().as_secs_f64();
        // Two spans of the largest island, so that the query builds the sparse graph (a
        // pair on different islands is answered before that).
        let island = (0..grid.islands.len() as u32)
            .max_by_key(|&i| grid.islands[i as usize].spans)
            .expect("an island");
        let walkable = grid.walkable_spans(Some(island));
        let t = Instant::now();
        let _ = shortest_path_in(&geo, walkable[0], walkable[walkable.len() / 2]);
        first += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let _ = shortest_path_in(&bare_geo, walkable[0], walkable[walkable.len() / 2]);
        first_unstored += t.elapsed().as_secs_f64();
        let mut unlabelled = grid.clone();
        unlabelled.baked.sparse_labels = None;
        let unlabelled_geo = Geodesic::new(&unlabelled);
        let t = Instant::now();
        let _ = shortest_path_in(&unlabelled_geo, walkable[0], walkable[walkable.len() / 2]);
        first_unlabelled += t.elapsed().as_secs_f64();
        let cfg = SampleConfig {
            task: Task::PointGoal,
            per_scene: 100,
            seed: 1,
            ..SampleConfig::default()
        };
        let t = Instant::now();
        let _ = sample_scene(&grid, id, "train", &cfg);
        sample += t.elapsed().as_secs_f64();
    }
    let n = ids.len().max(1) as f64;
    println!(
        "\npointgoal per scene ({} scenes, {:.0} spans on average): read grid {:.2} ms, \
         Geodesic::new {:.2} ms, first path query {:.2} ms (without the stored labels: {:.2} ms; \
         without any stored parts: {:.2} and {:.2} ms); sample_scene (100 episodes, including its own setup) {:.2} ms; write_nav \
         {:.2} ms; file {:.0} kB, of which stored squares {:.0} kB and sparse graph {:.0} kB (labels {:.0} kB)",
        ids.len(),
        spans as f64 / n,
        1e3 * read / n,
        1e3 * geo_new / n,
        1e3 * first / n,
        1e3 * first_unlabelled / n,
        1e3 * geo_unstored / n,
        1e3 * first_unstored / n,
        1e3 * sample / n,
        1e3 * write / n,
        file_bytes as f64 / n / 1e3,
        squares_bytes as f64 / n / 1e3,
        graph_bytes as f64 / n / 1e3,
        labels_bytes as f64 / n / 1e3,
    );
}
