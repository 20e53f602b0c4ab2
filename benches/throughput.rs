//! Throughput of the scene stages: `cargo bench --bench throughput`.
//!
//! Measures house generation (plan only, and plan + write), ingest from sources, and loading
//! compiled scenes, single-threaded and on all cores. Prints a Markdown table for
//! `docs/PERFORMANCE.md`. Set `MINOS_REAL_DATA` to include the real SUNCG sample.

use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

use minos::generate::{generate, plan_house, GenerateConfig, OutputFormat};
use minos::pipeline::ingest::{ingest, IngestConfig};
use minos::progress::NoProgress;
use minos::scene::formats::suncg::SuncgLoader;
use minos::scene::formats::{DatasetLoader, SceneEntry};

/// Runs `f` (which processes `n` items) `reps` times; returns the best items per second.
fn best_rate(n: usize, reps: usize, mut f: impl FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        f();
        best = best.min(t.elapsed().as_secs_f64());
    }
    n as f64 / best
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
}

fn row(what: &str, threads: usize, rate: f64, unit: &str) {
    println!("| {what} | {threads} | {rate:.0} {unit} |");
}

fn main() {
    let houses = 300;
    let cfg = GenerateConfig {
        houses,
        seed: 1,
        ..GenerateConfig::default()
    };
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let dir = tempfile::tempdir().expect("tempdir");
    let root = dir.path().join("suncg");
    let data = dir.path().join("DATA");
    println!("| stage | threads | throughput |\n|---|---|---|");
    let plan = best_rate(houses, 3, || {
        for i in 0..houses {
            black_box(plan_house(&cfg, i));
        }
    });
    row("plan houses (in memory)", 1, plan, "houses/s");
    for threads in [1, cores] {
        let rate = best_rate(houses, 3, || {
            pool(threads).install(|| {
                generate(&cfg, OutputFormat::Suncg, &root, true, &NoProgress).expect("generate");
            })
        });
        row(
            "generate (plan + write SUNCG files)",
            threads,
            rate,
            "houses/s",
        );
    }
    let loader = SuncgLoader::open(&root, None).expect("loader");
    let entries = loader.discover().expect("discover");
    let load = best_rate(entries.len(), 3, || {
        for e in &entries {
            black_box(loader.load(e).expect("load"));
        }
    });
    row("load house.json + OBJ meshes", 1, load, "houses/s");
    for threads in [1, cores] {
        let rate = best_rate(houses, 3, || {
            pool(threads).install(|| {
                ingest(
                    &IngestConfig {
                        force: true,
                        ..IngestConfig::suncg(&root, &data)
                    },
                    &NoProgress,
                )
                .expect("ingest");
            })
        });
        row(
            "ingest (load + compile + manifest)",
            threads,
            rate,
            "houses/s",
        );
    }
    let compiled = best_rate(entries.len(), 3, || {
        for e in &entries {
            black_box(
                minos::store::DataDir::new(&data)
                    .read_scene(&e.id)
                    .expect("compiled"),
            );
        }
    });
    row("load compiled scene", 1, compiled, "houses/s");
    println!(
        "\ncompiled scenes load {:.1}x faster than their sources (generated houses)",
        compiled / load
    );
    if let Some(real) = std::env::var_os("MINOS_REAL_DATA") {
        real_sample(Path::new(&real), dir.path());
    }
}

fn real_sample(real: &Path, tmp: &Path) {
    let root = real.join("suncg");
    let id = "00e2eed27fb6b5c911624902888039ee";
    let loader = SuncgLoader::open(&root, None).expect("loader");
    let entry = SceneEntry {
        id: id.into(),
        path: root.join(id).join("house.json"),
    };
    let source = best_rate(1, 10, || {
        black_box(loader.load(&entry).expect("real house"));
    });
    let loaded = loader.load(&entry).expect("real house");
    let path = tmp.join("real.mscene");
    let header = minos::store::scene_file::SceneHeader {
        id: id.into(),
        source: String::new(),
        sources: vec![],
    };
    minos::store::scene_file::write_scene(&path, &header, &loaded.scene).expect("write");
    let compiled = best_rate(1, 10, || {
        black_box(minos::store::scene_file::read_scene(&path).expect("read"));
    });
    println!(
        "real SUNCG sample (glTF meshes, {} triangles): source {:.1} ms, compiled {:.2} ms ({:.0}x)",
        loaded.scene.triangle_count(),
        1e3 / source,
        1e3 / compiled,
        compiled / source
    );
}
