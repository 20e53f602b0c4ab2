//! `minos bench`: flags → [`minos::pipeline::bench::BenchConfig`], then the table or JSON.

use std::path::PathBuf;
use std::process::ExitCode;

use minos::body::AgentPreset;
use minos::pipeline::bench::{bench, BenchConfig, BenchKind};
use minos::render::RendererChoice;
use minos::scene::SceneRef;
use minos::sim::{AgentConfig, SensorSuite};
use minos::store::DataDir;

use super::common::{sensor_suite, sensors_help, vocab};
use super::Context;

/// Benchmarks `bench` can run.
/// Measure minos on one ingested scene (yours): a table of stages with items per second on
/// one core, or JSON for scripts.
///
/// Everything runs on one thread, so figures are per core; stage times are the thread's CPU
/// time where the system reports it. `run` adds one row of the machine's throughput: the
/// rollout loop on --threads threads at once, wall clock, and with --envs the loop with that
/// many environments stepped together (wall clock). With a GPU renderer, `render` adds
/// batched stages (--batch views per submission and read-back, then with the images derived on
/// all threads), wall clock, and names the adapter. `render` and `run` need the scene baked
/// (`minos bake`) for --preset's body.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos bench bake --data DATA --scene 17DRP5sb8fy\n  \
    minos bench render --data DATA --size 128 --frames 500\n  \
    minos bench render --data DATA --renderer wgpu --size 128 --batch 1024\n  \
    minos bench run --data DATA --episodes 20 --json\n  \
    minos bench run --data DATA --renderer wgpu --envs 1024 --episodes 400"
)]
pub struct Args {
    /// What to measure.
    #[arg(value_parser = vocab::<BenchKind>())]
    which: BenchKind,
    /// The DATA folder.
    #[arg(long)]
    data: PathBuf,
    /// Scene id (or `<scene>@<variant>`); default: the first ingested scene.
    #[arg(long)]
    scene: Option<SceneRef>,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Agent preset (the grid must be baked for its body).
    #[arg(long, value_parser = vocab::<AgentPreset>(), default_value = "habitat")]
    preset: AgentPreset,
    /// Use a grid baked for another body than --preset's.
    #[arg(long)]
    allow_body_mismatch: bool,
    /// Renderer of `render` and `run`.
    #[arg(long, value_parser = vocab::<RendererChoice>(), default_value = "cpu")]
    renderer: RendererChoice,
    #[arg(long, help = sensors_help("RGB, depth and semantic cameras at --size (grey, depth and semantic at 90° for --preset minos-paper)."))]
    sensors: Option<PathBuf>,
    /// Image size of the default sensors.
    #[arg(long, default_value_t = 84)]
    size: u32,
    /// Poses `render` renders.
    #[arg(long, default_value_t = 200)]
    frames: usize,
    /// Episodes `episodes` samples and `run` rolls out.
    #[arg(long, default_value_t = 100)]
    episodes: usize,
    /// Seed of poses and episodes.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Views per batch of `render`'s batched GPU stages (with a GPU renderer; 0: none).
    #[arg(long, default_value_t = 1024)]
    batch: usize,
    /// Environments of `run`'s batched rollout stage, stepped together (every camera of a
    /// step in one render call); default 256 with a GPU renderer, none with the CPU; 0: none.
    #[arg(long)]
    envs: Option<usize>,
    /// `run`: only the machine's throughput (all threads, and --envs), without the per-core
    /// loop.
    #[arg(long)]
    throughput_only: bool,
}

/// Flags → the benchmark (reads the sensor file, if any).
pub fn config(args: &Args) -> anyhow::Result<BenchConfig> {
    if args.frames == 0 || args.episodes == 0 {
        anyhow::bail!("--frames and --episodes must be at least 1");
    }
    if args.size == 0 || args.size > 4096 {
        anyhow::bail!("--size {}: need 1 <= SIZE <= 4096", args.size);
    }
    Ok(BenchConfig {
        data: DataDir::new(&args.data),
        scene: args.scene.clone(),
        kind: args.which,
        agent: AgentConfig::preset(args.preset),
        sensors: sensor_suite(args.sensors.as_deref(), args.size, || {
            SensorSuite::for_preset(args.preset, args.size)
        })?,
        renderer: args.renderer,
        frames: args.frames,
        episodes: args.episodes,
        seed: args.seed,
        allow_body_mismatch: args.allow_body_mismatch,
        threads: rayon::current_num_threads(),
        batch: args.batch,
        envs: args
            .envs
            .unwrap_or(if args.renderer == RendererChoice::Cpu {
                0
            } else {
                256
            }),
        per_core: !args.throughput_only,
    })
}

/// Runs `minos bench`.
pub fn run(args: Args, _ctx: &Context) -> anyhow::Result<ExitCode> {
    let cfg = config(&args)?;
    let report = bench(&cfg)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report.to_json())?);
    } else {
        print!("{}", report.table());
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::common::parse_flags;
    use minos::body::AgentBody;
    use minos::render::RendererChoice;

    #[test]
    fn flags_become_the_benchmark() {
        let c = config(&parse_flags::<Args>("render --data D").unwrap()).unwrap();
        assert_eq!(c.kind, BenchKind::Render);
        assert_eq!(c.scene, None);
        assert_eq!(c.renderer, RendererChoice::Cpu);
        assert_eq!(c.agent.body, AgentBody::HABITAT);
        assert_eq!(c.sensors, SensorSuite::minos(84));
        let c = config(
            &parse_flags::<Args>("run --data D --scene h@v --preset minos --episodes 7").unwrap(),
        )
        .unwrap();
        assert_eq!(c.kind, BenchKind::Run);
        assert_eq!(c.scene.unwrap().to_string(), "h@v");
        assert_eq!(c.agent.body, AgentBody::MINOS);
        assert_eq!(c.episodes, 7);
        for bad in ["render --data D --frames 0", "render --data D --size 0"] {
            let e = config(&parse_flags::<Args>(bad).unwrap()).unwrap_err();
            assert!(!e.to_string().contains('\n'), "{bad}: {e}");
        }
        assert!(parse_flags::<Args>("paint --data D").is_err());
    }
}
