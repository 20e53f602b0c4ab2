//! `minos bench` as a script meets it: the JSON's structure, and counts that agree with each
//! other and with the flags (never timings).

use crate::common;

use common::{baked_houses, minos, RunOk};
use minos::generate::GenerateConfig;
use serde_json::Value;

fn bench_json(data: &std::path::Path, args: &[&str]) -> Value {
    let out = minos()
        .arg("bench")
        .args(args)
        .arg("--data")
        .arg(data)
        .arg("--json")
        .ok_output();
    serde_json::from_slice(&out.stdout).expect("bench --json prints JSON")
}

fn stages(v: &Value) -> Vec<(String, u64, String, f64, f64)> {
    v["stages"]
        .as_array()
        .expect("stages")
        .iter()
        .map(|s| {
            (
                s["stage"].as_str().unwrap().to_string(),
                s["count"].as_u64().unwrap(),
                s["unit"].as_str().unwrap().to_string(),
                s["seconds"].as_f64().unwrap(),
                s["per_second"].as_f64().unwrap(),
            )
        })
        .collect()
}

fn count(v: &Value, name: &str) -> u64 {
    stages(v)
        .into_iter()
        .find(|s| s.0 == name)
        .unwrap_or_else(|| panic!("no stage {name} in {v}"))
        .1
}

#[test]
fn bench_json_has_consistent_counts_for_every_benchmark() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = GenerateConfig {
        houses: 2,
        seed: 12,
        rooms: (3, 4),
        levels: (1, 1),
        closed_door_prob: 0.0,
        ..Default::default()
    };
    let (data, ids) = baked_houses(dir.path(), &cfg);
    let root = data.root().to_path_buf();
    let rows = data.read_manifest().unwrap();
    // The default scene is the manifest's first; --scene picks another.
    let bake = bench_json(&root, &["bake"]);
    assert_eq!(bake["bench"], "bake");
    assert_eq!(bake["scene"], ids[0].as_str());
    assert_eq!(bake["triangles"].as_u64().unwrap(), rows[0].ntriangles);
    assert!(bake["walkable_spans"].as_u64().unwrap() > 0);
    assert!(bake["rss_after_load_bytes"].as_u64().unwrap() > 0);
    assert!(bake["rss_peak_bytes"].as_u64() >= bake["rss_after_load_bytes"].as_u64());
    let names: Vec<String> = stages(&bake).into_iter().map(|s| s.0).collect();
    assert_eq!(names, ["load scene", "bake"]);
    for (name, n, _, secs, rate) in stages(&bake) {
        assert_eq!(n, 1, "{name}");
        assert!(secs >= 0.0 && (secs == 0.0 || (rate - 1.0 / secs).abs() < 1e-6 * rate));
    }
    // The bake of the bench finds the grid `minos bake` wrote.
    let grid = data.read_grid(&ids[0].parse().unwrap()).unwrap();
    let walkable = grid.spans.iter().filter(|s| s.walkable).count() as u64;
    assert_eq!(bake["walkable_spans"].as_u64().unwrap(), walkable);

    let eps = bench_json(&root, &["episodes", "--scene", &ids[1], "--episodes", "30"]);
    assert_eq!(eps["scene"], ids[1].as_str());
    assert_eq!(count(&eps, "sample"), 30);
    assert_eq!(eps["triangles"], 0, "episodes never load the scene");

    let render = bench_json(&root, &["render", "--frames", "12", "--size", "32"]);
    assert_eq!(count(&render, "render"), 12, "a frame is one observation");
    assert_eq!(count(&render, "prepare"), 1);
    assert_eq!(render["triangles"], bake["triangles"]);

    let run = bench_json(&root, &["run", "--episodes", "3", "--size", "32"]);
    let (sampled, steps) = (count(&run, "sample"), count(&run, "sim step"));
    assert_eq!(sampled, 3);
    assert_eq!(count(&run, "reset (goal field, first frame)"), sampled);
    assert_eq!(count(&run, "oracle plan"), sampled);
    assert!(steps > 0);
    // Each episode ends with a stop decision or at its step limit: one decision per step,
    // plus at most one per episode.
    let decisions = count(&run, "oracle decide");
    assert!(decisions >= steps && decisions <= steps + sampled, "{run}");
    assert_eq!(count(&run, "rollout loop"), steps);
    // Same seed, same counts.
    let again = bench_json(
        &root,
        &["run", "--episodes", "3", "--size", "32", "--threads", "1"],
    );
    assert_eq!(count(&again, "sim step"), steps);
    // One thread: no all-threads row. Two: the same episodes once more on both threads at
    // once, each run once (every episode is seeded from its id, so the steps agree).
    assert_eq!(again["threads"], 1);
    assert!(stages(&again)
        .iter()
        .all(|s| s.0 != "rollout loop, all threads"));
    let both = bench_json(
        &root,
        &["run", "--episodes", "3", "--size", "32", "--threads", "2"],
    );
    assert_eq!(both["threads"], 2);
    assert_eq!(count(&both, "rollout loop, all threads"), steps);
    // Environments stepped together take the same steps; by the wall clock.
    let batched = bench_json(
        &root,
        &[
            "run",
            "--episodes",
            "3",
            "--size",
            "32",
            "--envs",
            "2",
            "--throughput-only",
        ],
    );
    assert_eq!(batched["envs"], 2);
    assert_eq!(count(&batched, "rollout loop, batched"), steps);
    assert_eq!(clock(&batched, "rollout loop, batched"), "wall");
    assert!(
        stages(&batched).iter().all(|s| s.0 != "rollout loop"),
        "--throughput-only has no per-core loop"
    );
    // Where the lockstep's time went: every phase, counted in lockstep steps (two
    // environments: at least half a step each), by the wall clock, within the whole loop.
    // A lockstep may take no step: an episode's first observation, or an oracle's stop,
    // while the other environment is still starting its episode (how often depends on the
    // starts' timing), so at most one of each per episode comes on top of the steps.
    let lockstep = count(&batched, minos::pipeline::bench::PHASES[0]);
    assert!(
        lockstep >= steps.div_ceil(2) && lockstep <= steps + 2 * sampled,
        "{batched}"
    );
    let mut phases = 0.0;
    for name in minos::pipeline::bench::PHASES {
        assert_eq!(count(&batched, name), lockstep, "{name}");
        assert_eq!(clock(&batched, name), "wall", "{name}");
        if !name.contains("(all calls") {
            phases += seconds(&batched, name);
        }
    }
    assert!(
        seconds(&batched, minos::pipeline::bench::PHASES[7]) > 0.0,
        "the CPU renders while observing"
    );
    let whole = seconds(&batched, "rollout loop, batched");
    assert!(
        phases > 0.0 && phases <= whole,
        "{phases} s of phases in {whole} s"
    );
    // The GPU's own clocks (its work, unpacking) are zero on the CPU renderer; they overlap
    // the render calls and are not added again.
    let part = |k: usize| seconds(&batched, minos::pipeline::bench::PHASES[k]);
    assert_eq!((part(5), part(6)), (0.0, 0.0));
    assert_eq!(clock(&run, "rollout loop"), clock(&run, "sample"));
    assert_eq!(
        render["adapter"],
        Value::Null,
        "the CPU renderer names no adapter"
    );
}

/// A field of the stage named `name`.
fn stage_field<'v>(v: &'v Value, name: &str, field: &str) -> &'v Value {
    v["stages"]
        .as_array()
        .expect("stages")
        .iter()
        .find(|s| s["stage"] == name)
        .map(|s| &s[field])
        .unwrap_or_else(|| panic!("no stage {name} in {v}"))
}

/// The seconds of a stage.
fn seconds(v: &Value, name: &str) -> f64 {
    stage_field(v, name, "seconds")
        .as_f64()
        .unwrap_or_else(|| panic!("no seconds for {name} in {v}"))
}

/// The clock a stage was timed by (`wall` or `thread-cpu`).
fn clock(v: &Value, name: &str) -> String {
    stage_field(v, name, "clock")
        .as_str()
        .unwrap_or_else(|| panic!("no clock for {name} in {v}"))
        .to_string()
}

/// With a GPU renderer (lavapipe in CI), `bench render` adds the batched stages, by the
/// wall clock, with whole batches of views and the adapter named.
#[test]
fn bench_render_on_wgpu_times_batches_by_the_wall_clock() {
    if let Err(e) = minos::render::gpu::GpuRenderer::new() {
        common::skip(e);
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let cfg = GenerateConfig {
        houses: 1,
        seed: 5,
        rooms: (2, 3),
        levels: (1, 1),
        closed_door_prob: 0.0,
        ..Default::default()
    };
    let (data, _) = baked_houses(dir.path(), &cfg);
    let root = data.root().to_path_buf();
    let v = bench_json(
        &root,
        &[
            "render",
            "--renderer",
            "wgpu",
            "--frames",
            "3",
            "--size",
            "16",
            "--batch",
            "5",
        ],
    );
    assert_eq!(v["views_per_batch"], 5);
    assert!(v["adapter"].as_str().is_some_and(|a| !a.is_empty()), "{v}");
    for name in [
        "render",
        "gpu batch: ids + depth",
        "gpu batch + colour, depth, semantic (all threads)",
        "gpu batch + colour, depth, semantic derived on the GPU",
    ] {
        assert_eq!(clock(&v, name), "wall", "{name}");
    }
    assert_eq!(
        count(&v, "gpu batch + colour, depth, semantic derived on the GPU") % 5,
        0,
        "whole batches"
    );
    assert_eq!(count(&v, "render"), 3);
    let frames = count(&v, "gpu batch: ids + depth");
    assert!(
        frames >= 10 && frames.is_multiple_of(5),
        "whole batches, at least two: {frames}"
    );
    assert_eq!(clock(&v, "prepare"), "thread-cpu");
}

#[test]
fn bench_prints_a_table_and_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let data = common::cli_ingested(dir.path(), 1, 4);
    let out = minos()
        .args(["bench", "bake", "--data"])
        .arg(&data)
        .ok_output();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("| stage | count |") && text.contains("| bake | 1 |"),
        "{text}"
    );
    for (args, needle) in [
        (vec!["render"], "bake the scene first"),
        (vec!["bake", "--scene", "nope"], "nope"),
    ] {
        let out = minos()
            .arg("bench")
            .args(&args)
            .arg("--data")
            .arg(&data)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}
