//! `minos run`: flags → [`minos::run::rollout::RunConfig`]; prints the metrics table.

use std::collections::HashMap;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context as _};
use minos::episode::batch::Shard;
use minos::episode::format::read_episodes;
use minos::io::atomic::write_bytes_atomic;
use minos::io::variant_store::read_variant;
use minos::run::agents::Decision;
use minos::run::metrics::{render_table, Reward};
use minos::run::rollout::{run as run_episodes, AgentKind, RerunOutput, RunConfig};
use minos::run::tables::ImageEncoding;
use minos::sim::{AgentConfig, RendererChoice, SensorSuite};

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
    /// Agent: random, forward, oracle, replay:FILE or external:CMD (a process speaking JSON
    /// lines on stdin/stdout, see docs/EXTERNAL_AGENT.md).
    #[arg(long)]
    agent: String,
    /// Agent preset: minos-continuous, minos-gridworld or habitat.
    #[arg(long, default_value = "habitat")]
    preset: String,
    /// Sensor file (TOML/JSON); default: MINOS's RGB, depth, semantic at --size and 4 contacts.
    #[arg(long)]
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
    /// Every n-th episode: i/n.
    #[arg(long, value_parser = Shard::parse, default_value = "0/1")]
    shard: Shard,
    /// Keep the finished episodes of an interrupted run.
    #[arg(long)]
    resume: bool,
    /// Reward: dist_time (MINOS), path_delta (MINOS) or geodesic (Habitat).
    #[arg(long, default_value = "dist_time", value_parser = ["dist_time", "path_delta", "geodesic"])]
    reward: String,
    /// Image storage: raw little-endian pixels (shape/dtype in the column metadata) or png.
    #[arg(long, default_value = "raw", value_parser = ["raw", "png"])]
    image_encoding: String,
    /// Also write a LeRobot-style layout into DIR/lerobot (`--format lerobot`).
    #[arg(long, value_parser = ["parquet", "lerobot"], default_value = "parquet")]
    format: String,
    /// Renderer: auto, cpu or wgpu.
    #[arg(long, default_value = "cpu", value_parser = ["auto", "cpu", "wgpu"])]
    renderer: String,
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

fn read_replay(path: &std::path::Path) -> anyhow::Result<HashMap<String, Vec<Decision>>> {
    use arrow::array::{Array, StringArray, UInt32Array};
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
    let file = std::fs::File::open(path).with_context(|| path.display().to_string())?;
    let reader = ParquetRecordBatchReaderBuilder::try_new(file)?.build()?;
    let mut rows: HashMap<String, Vec<(u32, Decision)>> = HashMap::new();
    for batch in reader {
        let batch = batch?;
        let col = |n: &str| {
            batch
                .column_by_name(n)
                .with_context(|| format!("{}: no column `{n}`", path.display()))
        };
        let ids = col("episode_id")?
            .as_any()
            .downcast_ref::<StringArray>()
            .context("episode_id: not text")?
            .clone();
        let steps = col("step")?
            .as_any()
            .downcast_ref::<UInt32Array>()
            .context("step: not uint32")?
            .clone();
        let actions = col("action")?
            .as_any()
            .downcast_ref::<StringArray>()
            .context("action: not text")?
            .clone();
        for i in 0..batch.num_rows() {
            let d = Decision::from_name(actions.value(i)).with_context(|| {
                format!(
                    "{}: row {i}: unknown action `{}`",
                    path.display(),
                    actions.value(i)
                )
            })?;
            rows.entry(ids.value(i).to_string())
                .or_default()
                .push((steps.value(i), d));
        }
    }
    Ok(rows
        .into_iter()
        .map(|(k, mut v)| {
            v.sort_by_key(|(s, _)| *s);
            (k, v.into_iter().map(|(_, d)| d).collect())
        })
        .collect())
}

/// Runs `minos run`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let agent = match args.agent.as_str() {
        "random" => AgentKind::Random,
        "forward" => AgentKind::Forward,
        "oracle" => AgentKind::Oracle,
        other => match (other.strip_prefix("replay:"), other.strip_prefix("external:")) {
            (Some(file), _) => AgentKind::Replay(read_replay(std::path::Path::new(file))?),
            (_, Some(cmd)) if !cmd.trim().is_empty() => AgentKind::External(cmd.to_string()),
            _ => bail!("--agent: unknown agent `{other}` (random, forward, oracle, replay:FILE, external:CMD)"),
        },
    };
    let body = AgentConfig::preset(&args.preset)
        .with_context(|| format!("--preset: unknown `{}`", args.preset))?;
    let sensors = match &args.sensors {
        Some(p) => SensorSuite::parse(
            &std::fs::read_to_string(p).with_context(|| p.display().to_string())?,
            &p.display().to_string(),
        )
        .map_err(anyhow::Error::msg)?,
        None => SensorSuite::minos(args.size),
    };
    let mut episodes = read_episodes(&args.episodes)?;
    if let Some(name) = &args.variant {
        read_variant(&args.data, name).map_err(|e| anyhow::anyhow!("--variant {name}: {e}"))?;
        episodes = episodes.into_iter().map(|e| e.on_variant(name)).collect();
    }
    let cfg = RunConfig {
        data: args.data.clone(),
        out: args.out.clone(),
        agent,
        body,
        sensors,
        renderer: match args.renderer.as_str() {
            "auto" => RendererChoice::Auto,
            "wgpu" => RendererChoice::Wgpu,
            _ => RendererChoice::Cpu,
        },
        max_steps: args.max_steps,
        seed: args.seed,
        shard: args.shard,
        resume: args.resume,
        reward: Reward::from_name(&args.reward).unwrap_or_default(),
        encoding: if args.image_encoding == "png" {
            ImageEncoding::Png
        } else {
            ImageEncoding::Raw
        },
        lerobot: args.format == "lerobot",
        rerun: args.rerun.as_ref().map(|path| RerunOutput {
            path: path.clone(),
            episodes: args.rerun_episodes,
        }),
    };
    let start = std::time::Instant::now();
    let report = {
        let bar = ctx.progress(episodes.len() as u64, "run");
        run_episodes(&cfg, &episodes, &bar).map_err(anyhow::Error::msg)?
    };
    let manifest = serde_json::json!({
        "command": std::env::args().collect::<Vec<_>>(),
        "minos_version": env!("CARGO_PKG_VERSION"),
        "episodes_file": args.episodes,
        "variant": args.variant,
        "agent": args.agent,
        "preset": args.preset,
        "body": body,
        "sensors": cfg.sensors,
        "seed": args.seed,
        "shard": format!("{}/{}", args.shard.index, args.shard.count),
        "reward": args.reward,
        "image_encoding": args.image_encoding,
        "rerun": args.rerun,
        "rerun_episodes": args.rerun.as_ref().map(|_| args.rerun_episodes),
    });
    write_bytes_atomic(
        &args.out.join("manifest.json"),
        &serde_json::to_vec_pretty(&manifest)?,
    )?;
    for (id, e) in &report.failures {
        eprintln!("error: episode {id}: {e}");
    }
    let steps: u32 = report.episodes.iter().map(|(_, m)| m.steps).sum();
    ctx.say(render_table(&report.groups));
    ctx.say(format!(
        "{} episodes ({} resumed, {} failed), {steps} steps in {:.1} s ({:.0} steps/s) -> {}",
        report.episodes.len(),
        report.resumed,
        report.failures.len(),
        start.elapsed().as_secs_f64(),
        f64::from(steps) / start.elapsed().as_secs_f64(),
        args.out.display()
    ));
    if let Some(path) = &args.rerun {
        ctx.say(format!(
            "{} episode(s) recorded -> {} (open with `rerun {}`)",
            report.recorded,
            path.display(),
            path.display()
        ));
    }
    Ok(if report.failures.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
