//! End-to-end rollout throughput: `cargo bench --bench rollout`.
//!
//! Generated furnished houses (default configuration) baked at 5 cm; PointGoal, ObjectGoal
//! and RoomGoal episodes; the oracle with the Habitat agent and MINOS's RGB-D-semantic
//! sensors at 84² on the CPU renderer, writing Parquet, on one thread. Prints steps per
//! second per task, then a breakdown of one pass (planning, simulation steps, writing).
//!
//! `MINOS_BENCH_HOUSES` (default 8) and `MINOS_BENCH_PER_SCENE` (default 4) size the run;
//! `MINOS_BENCH_THREADS` (default 1) sets the rollout threads (one scene per thread);
//! `MINOS_BENCH_ROOMS` (default: the generator's 3–8 rooms, 1–2 levels) one-level houses of
//! exactly that many rooms; `MINOS_BENCH_PRESET` (default `habitat`; `minos`, `minos-paper`, `minos-gridworld`) the
//! agent preset: the body the houses are baked for, the agent, its default sensors and its
//! PointGoal success radius. Episodes that fail with an error count as failures.

use std::sync::Arc;
use std::time::{Duration, Instant};

use minos::body::{AgentPreset, BodyRule};
use minos::episode::interchange::DEFAULT_MAX_STEPS;
use minos::episode::sample::SampleConfig;
use minos::episode::{Episode, Task};
use minos::io::image_codec::ImageEncoding;
use minos::io::tables::ObservationWriter;
use minos::navmesh::geodesic::Geodesic;
use minos::pipeline::episodes::sample_scenes;
use minos::pipeline::rollout::{rollout, AgentKind, RunConfig};
use minos::progress::NoProgress;
use minos::render::Renderer;
use minos::render::RendererChoice;
use minos::run::agents::{Agent, Decision};
use minos::run::metrics::Reward;
use minos::run::oracle::OracleAgent;
use minos::run::stepper::{EpisodeStepper, StepperConfig};
use minos::shard::Shard;
use minos::sim::{AgentConfig, SceneAssets, SensorSuite, Simulator};

/// CPU time (s) of the whole process (all threads), from `/proc/self/stat` (Linux; `None`
/// elsewhere). On a shared, busy box CPU time is steadier than wall time.
mod support;
fn process_cpu() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = stat.rsplit_once(')')?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// A clock of this thread's CPU time (`/proc/thread-self/schedstat`, ns), falling back to wall
/// time.
struct Clock(Instant);

impl Clock {
    fn now() -> Clock {
        Clock(Instant::now())
    }

    fn thread_cpu() -> Option<Duration> {
        let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
        Some(Duration::from_nanos(
            s.split_whitespace().next()?.parse().ok()?,
        ))
    }

    /// Measures `f` in thread CPU time (wall time where that is unavailable).
    fn time<R>(total: &mut Duration, f: impl FnOnce() -> R) -> R {
        let (c0, w0) = (Self::thread_cpu(), Self::now());
        let r = f();
        *total += match (c0, Self::thread_cpu()) {
            (Some(a), Some(b)) => b.saturating_sub(a),
            _ => w0.0.elapsed(),
        };
        r
    }
}

fn env(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn main() {
    let preset: AgentPreset = std::env::var("MINOS_BENCH_PRESET")
        .unwrap_or_else(|_| "habitat".into())
        .parse()
        .expect("MINOS_BENCH_PRESET");
    let body = AgentConfig::preset(preset);
    let sensors = SensorSuite::for_preset(preset, 84);
    println!("preset {preset}");
    let dir = tempfile::tempdir().expect("tempdir");
    let rooms = env("MINOS_BENCH_ROOMS", 0);
    let generator = minos::generate::GenerateConfig {
        houses: env("MINOS_BENCH_HOUSES", 8),
        seed: 5,
        ..Default::default()
    };
    let generator = match rooms {
        0 => generator,
        n => minos::generate::GenerateConfig {
            rooms: (n, n),
            levels: (1, 1),
            ..generator
        },
    };
    let (data, ids) = support::baked_houses_from(dir.path(), &generator, preset.body());
    let scenes: Vec<(String, String)> = ids
        .iter()
        .map(|id| (id.clone(), "val".to_string()))
        .collect();
    let threads = env("MINOS_BENCH_THREADS", 1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool");
    let per_scene = env("MINOS_BENCH_PER_SCENE", 4);
    let tasks: Vec<(Task, Vec<Episode>)> = [Task::PointGoal, Task::ObjectGoal, Task::RoomGoal]
        .into_iter()
        .map(|task| {
            let cfg = SampleConfig {
                task,
                per_scene,
                seed: 2,
                success_radius: match task {
                    Task::PointGoal => preset.point_goal_radius(),
                    _ => SampleConfig::default().success_radius,
                },
                ..SampleConfig::default()
            };
            let batch = sample_scenes(
                &minos::store::DataDir::new(&data),
                &scenes,
                &cfg,
                BodyRule::strict(preset.body()),
                Shard::ALL,
                &NoProgress,
            );
            (task, batch.episodes)
        })
        .collect();
    println!(
        "| task | episodes | failed | success | SPL | steps | wall | steps/s (wall) | steps/s (CPU) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (task, episodes) in &tasks {
        let cfg = RunConfig {
            batch: None,
            data: minos::store::DataDir::new(&data),
            out: dir.path().join(format!("run-{}", task.name())),
            agent: AgentKind::Oracle,
            agent_config: body,
            sensors: sensors.clone(),
            renderer: RendererChoice::Cpu,
            max_steps: None,
            seed: 0,
            shard: Shard::ALL,
            resume: false,
            reward: Reward::Geodesic,
            encoding: ImageEncoding::Raw,
            lerobot: false,
            lerobot_video: None,
            rerun: None,
            allow_body_mismatch: false,
            provenance: Default::default(),
        };
        let (t, cpu0) = (Instant::now(), process_cpu());
        let report = pool
            .install(|| rollout(&cfg, episodes, &NoProgress))
            .expect("run");
        let s = t.elapsed().as_secs_f64();
        let cpu = process_cpu().zip(cpu0).map_or(s, |(b, a)| b - a);
        let steps: u64 = report.episodes.iter().map(|(_, m)| m.steps as u64).sum();
        // Over every episode: one that failed with an error is a failure.
        let all = &report.groups["all"];
        println!(
            "| {} | {} | {} | {:.0} % | {:.3} | {} | {:.2} s | {:.0} | {:.0} |",
            task.name(),
            all.episodes,
            all.failed,
            100.0 * all.success,
            all.spl,
            steps,
            s,
            steps as f64 / s,
            steps as f64 / cpu
        );
    }
    breakdown(&data, &tasks, dir.path(), body, &sensors);
}

/// Times the parts of a rollout on the same episodes, stepped by the episode stepper: scene
/// setup, reset (goal field and first frame), oracle planning, simulation steps (motion, rendering, sensors, measurements) and
/// observation writing.
fn breakdown(
    data: &std::path::Path,
    tasks: &[(Task, Vec<Episode>)],
    dir: &std::path::Path,
    body: AgentConfig,
    sensors: &SensorSuite,
) {
    let (mut setup, mut reset, mut plan, mut decide, mut step, mut write) = (
        Duration::ZERO,
        Duration::ZERO,
        Duration::ZERO,
        Duration::ZERO,
        Duration::ZERO,
        Duration::ZERO,
    );
    let mut steps = 0u64;
    let all: Vec<&Episode> = tasks.iter().flat_map(|(_, e)| e).collect();
    let mut scene_ids: Vec<&str> = all.iter().map(|e| e.scene_id.as_str()).collect();
    scene_ids.sort();
    scene_ids.dedup();
    for id in scene_ids {
        let (sim, assets) = Clock::time(&mut setup, || {
            let (_, scene) = minos::store::DataDir::new(data)
                .read_scene(id)
                .expect("scene");
            let grid = minos::store::DataDir::new(data)
                .read_grid(&minos::scene::SceneRef::parse(id))
                .expect("nav");
            let assets = Arc::new(SceneAssets::new(&scene, grid, &body).expect("assets"));
            let renderer =
                Arc::new(Renderer::new(RendererChoice::Cpu, &assets.render).expect("renderer"));
            let sim = Simulator::new(
                assets.clone(),
                renderer,
                body,
                sensors.clone(),
                DEFAULT_MAX_STEPS,
                0,
            );
            (sim, assets)
        });
        // The oracle's rules, as `minos run` steps it: success needs its stop.
        let mut stepper = EpisodeStepper::new(
            sim,
            StepperConfig {
                require_stop: true,
                ..StepperConfig::default()
            },
        );
        let geo = Clock::time(&mut setup, || Geodesic::new(&assets.grid));
        for ep in all.iter().filter(|e| e.scene_id == id) {
            Clock::time(&mut reset, || {
                stepper.reset_in(ep, Some(&geo)).expect("reset");
            });
            let mut agent = OracleAgent::new();
            // An episode without a plan is left out of the breakdown (the table counts it).
            if Clock::time(&mut plan, || agent.reset(ep, stepper.sim())).is_err() {
                continue;
            }
            let path = dir.join("breakdown.obs.parquet");
            let mut writer = ObservationWriter::create(
                &path,
                &ep.episode_id,
                &sensors.cameras,
                ImageEncoding::Raw,
            )
            .expect("writer");
            while !stepper.ended() {
                let (k, obs) = (stepper.decisions(), stepper.observation());
                Clock::time(&mut write, || writer.push(k, &obs.images).expect("push"));
                let d = Clock::time(&mut decide, || {
                    agent.decide(obs, stepper.sim()).expect("decide")
                });
                if d == Decision::Stop {
                    stepper.step(d).expect("stop");
                    break;
                }
                Clock::time(&mut step, || {
                    stepper.step(d).expect("step");
                });
                steps += 1;
            }
            Clock::time(&mut write, || writer.finish().expect("finish"));
        }
    }
    let total = setup + reset + plan + decide + step + write;
    println!(
        "\nbreakdown over {steps} steps ({:.2} s of thread CPU time):",
        total.as_secs_f64()
    );
    for (name, d) in [
        ("scene setup", setup),
        ("reset (goal field, first frame)", reset),
        ("oracle plan", plan),
        ("oracle decide", decide),
        ("sim step (motion, render, sensors, measurements)", step),
        ("observation writing", write),
    ] {
        println!(
            "  {name:<50} {:>8.1} ms  {:>5.1} %  {:>7.1} µs/step",
            d.as_secs_f64() * 1e3,
            100.0 * d.as_secs_f64() / total.as_secs_f64(),
            d.as_secs_f64() * 1e6 / steps.max(1) as f64
        );
    }
}
