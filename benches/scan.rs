//! Scan-sized scenes: `cargo bench --bench scan`.
//!
//! One scan-like house (`generate --scan`: 3 levels, `MINOS_BENCH_SCAN_TRIANGLES` triangles,
//! default 3,000,000) is generated, ingested and baked; then `minos bench`'s library code
//! ([`minos::pipeline::bench`]) measures baking, PointGoal sampling, rendering (RGB-D-semantic
//! 84², CPU) and the oracle's rollout loop on it, on one thread. Prints the generation and
//! ingest times, the compiled scene's size and the four tables.

use std::time::Instant;

use minos::body::AgentBody;
use minos::generate::{generate, house_id_for, GenerateConfig, OutputFormat, ScanOptions};
use minos::navmesh::NavParams;
use minos::pipeline::bake::{bake_scenes, BakeConfig};
use minos::pipeline::bench::{bench, BenchConfig, BenchKind};
use minos::pipeline::ingest::{ingest, DatasetFormat, IngestConfig};
use minos::progress::NoProgress;
use minos::render::RendererChoice;
use minos::sim::{AgentConfig, SensorSuite};
use minos::store::DataDir;

fn env(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn main() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (root, data) = (dir.path().join("scans"), dir.path().join("DATA"));
    let triangles = env("MINOS_BENCH_SCAN_TRIANGLES", 3_000_000);
    let cfg = GenerateConfig {
        houses: 1,
        seed: 1,
        rooms: (9, 12),
        levels: (3, 3),
        closed_door_prob: 0.0,
        ..Default::default()
    };
    let format = OutputFormat::Mp3dScan(ScanOptions {
        triangles,
        ..ScanOptions::default()
    });
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let t = Instant::now();
    one.install(|| generate(&cfg, format, &root, false, &NoProgress))
        .expect("generate");
    let generated = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let ingest_cfg = IngestConfig {
        format: DatasetFormat::Mp3d,
        root: root.clone(),
        data: DataDir::new(&data),
        ids: None,
        force: false,
        categories: None,
        models: None,
    };
    one.install(|| ingest(&ingest_cfg, &NoProgress))
        .expect("ingest");
    let ingested = t.elapsed().as_secs_f64();
    let id = house_id_for(&cfg, format, 0);
    let data = DataDir::new(&data);
    let mscene = std::fs::metadata(data.scene_path(&id)).map_or(0, |m| m.len());
    println!(
        "scan house {id}: generated in {generated:.2} s, ingested in {ingested:.2} s (1 thread); \
         .mscene {:.1} MB\n",
        mscene as f64 / 1e6
    );
    bake_scenes(
        &BakeConfig {
            data: data.clone(),
            scenes: vec![id.parse().expect("id")],
            params: NavParams::for_body(AgentBody::HABITAT),
            force: false,
            previews: false,
        },
        &NoProgress,
    );
    for (kind, episodes) in [
        (BenchKind::Bake, 1),
        (BenchKind::Episodes, 2000),
        (BenchKind::Render, 1),
        (BenchKind::Run, 20),
    ] {
        let cfg = BenchConfig {
            data: data.clone(),
            scene: Some(id.parse().expect("id")),
            kind,
            agent: AgentConfig::habitat(),
            sensors: SensorSuite::minos(84),
            renderer: RendererChoice::Cpu,
            frames: 200,
            episodes,
            seed: 0,
            allow_body_mismatch: false,
            threads: 1,
            batch: 0,
            envs: 0,
            per_core: true,
        };
        let report = one.install(|| bench(&cfg)).expect("bench");
        println!("{}", report.table());
    }
}
