//! Episode sampling throughput: `cargo bench --bench episodes`.
//!
//! Generated furnished houses (default configuration), baked at 5 cm; episodes per second on
//! one core for each task. Prints Markdown rows for `docs/PERFORMANCE.md`.

use std::time::Instant;

use minos::episode::batch::{sample_scenes, Shard};
use minos::episode::sample::SampleConfig;
use minos::episode::Task;
use minos::generate::{generate, GenerateConfig, OutputFormat};
use minos::ingest::{ingest, IngestConfig};
use minos::navmesh::bake::{bake_scenes, BakeConfig};
use minos::navmesh::NavParams;
use minos::progress::NoProgress;

fn main() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    let cfg = GenerateConfig {
        houses: 20,
        seed: 4,
        ..GenerateConfig::default()
    };
    generate(&cfg, OutputFormat::Suncg, &root, false, &NoProgress).expect("generate");
    let report = ingest(&IngestConfig::suncg(&root, &data), &NoProgress).expect("ingest");
    let ids: Vec<String> = report.scenes.iter().map(|(r, _)| r.id.clone()).collect();
    let bake = BakeConfig {
        data: data.clone(),
        ids: ids.clone(),
        params: NavParams::default(),
        force: false,
        previews: false,
    };
    bake_scenes(&bake, &NoProgress);
    let scenes: Vec<(String, String)> = ids
        .iter()
        .map(|id| (id.clone(), "train".to_string()))
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    println!("| task | episodes | time (1 core) | episodes/s/core |\n|---|---|---|---|");
    for task in [Task::PointGoal, Task::ObjectGoal, Task::RoomGoal] {
        let cfg = SampleConfig {
            task,
            per_scene: 100,
            seed: 1,
            ..SampleConfig::default()
        };
        let t = Instant::now();
        let batch = pool.install(|| sample_scenes(&data, &scenes, &cfg, Shard::ALL, &NoProgress));
        let s = t.elapsed().as_secs_f64();
        println!(
            "| {} | {} | {:.2} s | {:.0} |",
            task.name(),
            batch.total,
            s,
            batch.total as f64 / s
        );
    }
}
