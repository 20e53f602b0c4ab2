//! `minos run`: flags → [`RunConfig`] ([`config`]: agent, body, sensors, episodes), then
//! [`minos::pipeline::rollout::rollout`], which writes the tables and the manifest; prints the
//! metrics table.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use minos::body::AgentPreset;
use minos::episode::Episode;
use minos::io::image_codec::ImageEncoding;
use minos::pipeline::rollout::{
    rollout_with as run_episodes, run_episodes_of, AgentKind, Provenance, RerunOutput,
    RolloutError, RunConfig, RunEpisodesError, RunFormat,
};
use minos::render::RendererChoice;
use minos::run::metrics::render_table;
use minos::run::metrics::Reward;
use minos::shard::ShardSpec;
use minos::sim::{AgentConfig, SensorSuite};
use minos::store::DataDir;

use super::common::{sensor_suite, sensors_help, vocab, VideoQp};
use super::Context;

/// Roll out episodes with an agent, writing Parquet datasets (trajectories, observations,
/// episodes with metrics) and metrics.json into DIR.
///
/// Agents: random (uniform over the action set), forward (forward, turning on collision),
/// oracle (plans over the agent's reachable states with the goal's geodesic field; reaches
/// and stops on every reachable episode), replay:FILE (the actions of a trajectories.parquet),
/// external:CMD (your policy in any language, one JSON line per step; docs/EXTERNAL_AGENT.md).
/// Episodes end on success (and, for oracle and replay, a stop), at --max-steps, or on an
/// agent error. Interrupted runs continue with --resume and end with the same bytes.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos run --data DATA --episodes eps/point.parquet --agent oracle --out runs/oracle\n  \
    minos run --data DATA --episodes eps/point.parquet --agent oracle --out runs/oracle --rerun runs/oracle.rrd --rerun-episodes 3\n  \
    minos run --data DATA --episodes eps/point.parquet --agent random --preset habitat --out runs/random\n  \
    minos run --data DATA --episodes eps/point.parquet --agent replay:runs/oracle/trajectories.parquet --out runs/replay\n  \
    minos run --data DATA --episodes eps/point.parquet --agent 'external:python3 my_policy.py' --out runs/mine\n\n\
    Python:\n  import pyarrow.parquet as pq, numpy as np, json\n  t = pq.read_table(\"runs/oracle/observations.parquet\")\n  \
    f = t.schema.field(\"color\"); shape = json.loads(f.metadata[b\"shape\"]); dtype = f.metadata[b\"dtype\"].decode()\n  \
    img = np.frombuffer(t.column(\"color\")[0].as_py(), dtype=dtype).reshape(shape)"
)]
pub struct Args {
    /// DATA folder (ingested and baked).
    #[arg(long)]
    data: PathBuf,
    /// Episode file from `minos episodes`.
    #[arg(long)]
    episodes: PathBuf,
    /// Run every episode on this variant of its scene (scene and episode ids in the outputs
    /// read `<scene>@NAME`); a variant that changes geometry needs `minos bake --variant NAME`.
    #[arg(long, value_name = "NAME")]
    variant: Option<String>,
    /// Agent: random (uniform over the moves), minos-random (MINOS's random baseline: each
    /// move pressed with probability ½ per step, so forward and a turn can combine), forward,
    /// oracle, replay:FILE or external:CMD (a process speaking JSON lines on stdin/stdout, see
    /// docs/EXTERNAL_AGENT.md).
    #[arg(long)]
    agent: String,
    /// Agent preset (body and motion); the grids must be baked for its body.
    #[arg(long, value_parser = vocab::<AgentPreset>(), default_value = "habitat")]
    preset: AgentPreset,
    /// Run on grids baked for another body than --preset's (recorded in manifest.json).
    #[arg(long)]
    allow_body_mismatch: bool,
    #[arg(long, help = sensors_help("MINOS's RGB, depth, semantic at --size and 4 contacts (grey, depth and semantic at 90° for --preset minos-paper)."))]
    sensors: Option<PathBuf>,
    /// Image size of the default sensors.
    #[arg(long, default_value_t = 84)]
    size: u32,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
    /// Step limit (default: each episode's own, 500).
    #[arg(long)]
    max_steps: Option<u32>,
    /// Seed of random agents and sensor noise.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Every n-th episode: i/n, or `auto` from the scheduler (Slurm array, Kubernetes Indexed
    /// Job with MINOS_SHARD_COUNT, or MINOS_SHARD=i/n).
    #[arg(long, value_parser = ShardSpec::parse, default_value = "0/1")]
    shard: ShardSpec,
    /// Keep the finished episodes of an interrupted run even when its parts have no record of
    /// what it was (older minos). Running an interrupted run again as it was continues it
    /// without this flag; another configuration over it is refused, not discarded.
    #[arg(long)]
    resume: bool,
    /// Reward: dist_time (MINOS), path_delta (MINOS) or geodesic (Habitat).
    #[arg(long, value_parser = vocab::<Reward>(), default_value = "dist_time")]
    reward: Reward,
    /// Image storage in observations.parquet: raw little-endian pixels, or png (lossless but
    /// for float depth, 1 mm steps, and normals; the column metadata says which).
    #[arg(long, value_parser = vocab::<ImageEncoding>(), default_value = "raw")]
    image_encoding: ImageEncoding,
    /// `lerobot`: also write a LeRobot v3.0 dataset into DIR/lerobot, loadable with
    /// `LeRobotDataset(repo_id, root="DIR/lerobot")` (see also `minos export-dataset`).
    #[arg(long, value_parser = vocab::<RunFormat>(), default_value = "parquet")]
    format: RunFormat,
    /// With `--format lerobot`: colour cameras as H.264 video features in MP4 files
    /// (`videos/<key>/chunk-000/file-000.mp4`, LeRobot's layout; lossy, many times smaller)
    /// rather than lossless image files in the data files (the default, which every LeRobot
    /// install reads without a video decoder). Depth and labels stay lossless either way.
    #[arg(long)]
    video: bool,
    #[command(flatten)]
    video_qp: VideoQp,
    /// Renderer.
    #[arg(long, value_parser = vocab::<RendererChoice>(), default_value = "cpu")]
    renderer: RendererChoice,
    /// Environments per scene stepped in lockstep, each step's observations rendered in one
    /// call (one GPU submission); 1 = one simulator per thread, each stepping alone. Default:
    /// 256 on a GPU renderer, 1 on the CPU. The outputs are the same bytes either way.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=65536))]
    batch: Option<u32>,
    /// Also record episodes for the rerun viewer into this .rrd file (open with
    /// `rerun FILE.rrd`): scene, navigation grid, shortest path, and per step the agent's
    /// pose, camera images and measurements.
    #[arg(long, value_name = "FILE.rrd")]
    rerun: Option<PathBuf>,
    /// How many episodes --rerun records: the first of this shard in episode-id order (each
    /// is a recording of its own in the file; ~10 kB per 84² RGB-D-semantic step plus
    /// ~0.5 MB per episode for its scene and grid).
    #[arg(long, default_value_t = 1, value_name = "N")]
    rerun_episodes: usize,
}

/// Flags → the run's configuration and its episodes (reads the episode, sensor and replay
/// files and checks the variant).
pub fn config(args: &Args) -> anyhow::Result<(RunConfig, Vec<Episode>)> {
    let data = DataDir::new(&args.data);
    let agent = AgentKind::from_name(&args.agent).context("--agent")?;
    let preset = args.preset;
    let sensors = sensor_suite(args.sensors.as_deref(), args.size, || {
        SensorSuite::for_preset(preset, args.size)
    })?;
    let shard = args
        .shard
        .resolve(|k| std::env::var(k).ok())
        .map_err(anyhow::Error::msg)?;
    let variant = args.variant.as_deref();
    let episodes = run_episodes_of(&data, &args.episodes, variant, &agent, &args.agent, shard)
        .map_err(|e| match e {
            RunEpisodesError::Variant(_) => {
                anyhow::Error::new(e).context(format!("--variant {}", variant.unwrap_or_default()))
            }
            RunEpisodesError::Agent(_) => anyhow::Error::new(e).context("--agent"),
            e => e.into(),
        })?;
    let cfg = RunConfig {
        batch: args.batch.map(|b| b as usize),
        data,
        out: args.out.clone(),
        agent,
        agent_config: AgentConfig::preset(preset),
        sensors,
        renderer: args.renderer,
        max_steps: args.max_steps,
        seed: args.seed,
        shard,
        resume: args.resume,
        reward: args.reward,
        encoding: args.image_encoding,
        lerobot: args.format.writes_lerobot(),
        lerobot_video: args.video_qp.settings(args.video),
        rerun: args.rerun.as_ref().map(|path| RerunOutput {
            path: path.clone(),
            episodes: args.rerun_episodes,
        }),
        allow_body_mismatch: args.allow_body_mismatch,
        provenance: Provenance {
            command: std::env::args().collect(),
            episodes_file: Some(args.episodes.clone()),
            variant: args.variant.clone(),
            agent: args.agent.clone(),
            preset: Some(preset),
        },
    };
    Ok((cfg, episodes))
}

/// Runs `minos run`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let (cfg, episodes) = config(&args)?;
    let start = std::time::Instant::now();
    let report = {
        let bar = ctx.progress(episodes.len() as u64, "run");
        run_episodes(&cfg, &episodes, ctx.lock_mode, &bar).map_err(|e| match e {
            RolloutError::Interrupted { .. } => {
                anyhow::anyhow!("{} (--resume keeps them)", minos::escape::error_line(&e))
            }
            e => e.into(),
        })?
    };
    for (id, e) in &report.failures {
        // Agents' errors name their episode already ("episode X: no plan found").
        let line = minos::escape::error_line(e);
        let named = line
            .strip_prefix(&format!("episode {id}"))
            .is_some_and(|rest| rest.starts_with([':', ' ']));
        if named {
            eprintln!("error: {line}");
        } else {
            eprintln!("error: episode {id}: {line}");
        }
    }
    let steps: u32 = report.episodes.iter().map(|(_, m)| m.steps).sum();
    ctx.say(render_table(&report.groups));
    // Failed episodes are in every count and rate above (as failures), and named here.
    ctx.say(format!(
        "{} episodes ({} failed with an error, counted as failures; {} resumed), {steps} steps \
         in {:.1} s ({:.0} steps/s) -> {}",
        report.episodes.len() + report.failures.len(),
        report.failures.len(),
        report.resumed,
        start.elapsed().as_secs_f64(),
        f64::from(steps) / start.elapsed().as_secs_f64(),
        cfg.out.display()
    ));
    if let Some(rerun) = &cfg.rerun {
        ctx.say(format!(
            "{} episode(s) recorded -> {} (open with `rerun {}`)",
            report.recorded,
            rerun.path.display(),
            rerun.path.display()
        ));
    }
    Ok(if report.failures.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::common::parse_flags;
    use minos::body::AgentBody;

    fn args(line: &str) -> Args {
        parse_flags::<Args>(line).expect("flags parse")
    }

    #[test]
    fn typed_flags_refuse_unknown_values() {
        for bad in [
            "--reward distance",
            "--image-encoding jpeg",
            "--format hdf5",
            "--renderer vulkan",
            "--preset default",
        ] {
            let line = format!("--data D --episodes E --agent oracle --out O {bad}");
            assert!(parse_flags::<Args>(&line).is_err(), "{bad}");
        }
        let a = args("--data D --episodes E --agent oracle --out O --preset minos-gridworld");
        assert_eq!(a.preset, AgentPreset::MinosGridworld);
        assert_eq!(AgentConfig::preset(a.preset).body, AgentBody::MINOS);
        assert_eq!(
            args("--data D --episodes E --agent oracle --out O").reward,
            Reward::DistTime
        );
    }
}
