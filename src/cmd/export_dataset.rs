//! `minos export-dataset`: flags → [`ExportConfig`] ([`config`]) →
//! [`minos::io::lerobot::write_dataset`]; prints what was written.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context as _;
use minos::io::lerobot::{
    fps_of_step, write_dataset_of, DatasetLayout, DatasetOptions, DemoSource, RunTables,
};
use minos::pipeline::rollout::LEROBOT_ROBOT_TYPE;
use minos::serve::campaign::record::{SessionQc, QC_FILE};

use super::common::vocab;
use super::Context;

const AFTER_HELP: &str = "\
The dataset is LeRobot's v3.0 layout (meta/info.json, meta/stats.json, meta/tasks.parquet,
meta/episodes/…, data/chunk-000/file-000.parquet), loadable offline with
`LeRobotDataset(\"minos/run\", root=OUT)`. Colour and grey cameras are lossless `image` features;
depth and label images lossless image files and normals arrays under `observation.<sensor>`; every
episode's task is its instruction (\"find a chair\", \"go to the kitchen\", \"go 4.2 m ahead
and 1.3 m left\"). The frame rate is the agent's steps per second from the run's
manifest.json unless --fps is given. With --video, colour cameras are H.264 `video` features
in videos/<key>/chunk-000/file-000.mp4 (lossy, many times smaller; LeRobot decodes them with
torchcodec, which needs the FFmpeg libraries, or PyAV).

Several --run folders (or every session of --campaign-state) are merged into one dataset,
in order; with --accepted only the demonstrations a campaign's quality checks accepted
(each session's qc.json) go in, never a tutorial.

Examples:
  minos export-dataset --run runs/oracle --out datasets/oracle-lerobot
  minos export-dataset --campaign-state study.state --accepted --out datasets/humans
  minos export-dataset --run minos-demo/run --out /tmp/demo-lerobot --fps 10
  minos export-dataset --run runs/oracle --out datasets/oracle-video --video";

/// Flags of `minos export-dataset`.
#[derive(Debug, clap::Args)]
#[command(after_help = AFTER_HELP)]
pub struct Args {
    /// A run folder written by `minos run` or a `minos serve` session (trajectories,
    /// observations and episodes tables); repeat to merge several.
    #[arg(long, value_name = "DIR", required_unless_present = "campaign_state")]
    run: Vec<PathBuf>,
    /// A campaign's state folder: every session in it (after the --run folders).
    #[arg(long, value_name = "DIR")]
    campaign_state: Option<PathBuf>,
    /// Only the demonstrations accepted by the campaign's quality checks (`qc.json`).
    #[arg(long)]
    accepted: bool,
    /// The dataset folder to write (replaced when the new one is complete).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// The dataset format.
    #[arg(long, value_parser = vocab::<DatasetLayout>(), default_value = "lerobot")]
    format: DatasetLayout,
    /// Frames per second (default: the agent's steps per second from DIR/manifest.json).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=10_000))]
    fps: Option<u32>,
    /// Colour cameras as H.264 video features in MP4 files (`videos/<key>/…`, LeRobot's
    /// layout; lossy, many times smaller) rather than lossless image files in the data files
    /// (the default). Depth and labels stay lossless either way.
    #[arg(long)]
    video: bool,
}

/// What to export.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportConfig {
    /// The run's tables (the first run's, when there are several).
    pub tables: RunTables,
    /// Every run, with the episodes kept of each.
    pub sources: Vec<DemoSource>,
    /// The dataset folder.
    pub out: PathBuf,
    /// Dataset options.
    pub options: DatasetOptions,
}

/// The agent's step (`body.dt`) recorded in a run's manifest.
fn manifest_step(run: &Path) -> anyhow::Result<f32> {
    let path = run.join("manifest.json");
    let text = std::fs::read_to_string(&path).with_context(|| {
        format!(
            "{}: cannot read the run's manifest (give --fps)",
            path.display()
        )
    })?;
    let manifest: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    let dt = manifest
        .pointer("/body/dt")
        .and_then(|v| v.as_f64())
        .filter(|dt| dt.is_finite() && *dt > 0.0)
        .with_context(|| format!("{}: body.dt: not a positive number", path.display()))?;
    Ok(dt as f32)
}

/// Flags → what to export (reads the run's manifest.json for the frame rate).
pub fn config(args: &Args) -> anyhow::Result<ExportConfig> {
    let DatasetLayout::Lerobot = args.format;
    let mut runs = args.run.clone();
    if let Some(state) = &args.campaign_state {
        // Sessions that finished no episode have no tables.
        runs.extend(
            minos::serve::campaign::session_folders(state)?
                .into_iter()
                .filter(|s| s.join("episodes.parquet").is_file()),
        );
    }
    let Some(first) = runs.first().cloned() else {
        anyhow::bail!("no run to export (the campaign has no session yet)");
    };
    let fps = match args.fps {
        Some(fps) => fps,
        None => fps_of_step(manifest_step(&first)?),
    };
    let mut sources = Vec::with_capacity(runs.len());
    for run in &runs {
        let keep = if args.accepted {
            if !run.join(QC_FILE).is_file() {
                anyhow::bail!(
                    "{}: no quality records (qc.json): --accepted needs a campaign session",
                    run.display()
                );
            }
            Some(SessionQc::load(run)?.accepted().into_iter().collect())
        } else {
            None
        };
        sources.push(DemoSource {
            tables: RunTables::in_dir(run),
            keep,
        });
    }
    let run_dir = &first;
    Ok(ExportConfig {
        sources,
        tables: RunTables::in_dir(run_dir),
        out: args.out.clone(),
        options: DatasetOptions {
            fps,
            robot_type: LEROBOT_ROBOT_TYPE.into(),
            // The run's configuration, when its manifest is there to read.
            run: std::fs::read(run_dir.join("manifest.json"))
                .ok()
                .and_then(|b| serde_json::from_slice(&b).ok())
                .map(|m| minos::io::lerobot::run_configuration(&m)),
            video: args.video,
        },
    })
}

/// Runs `minos export-dataset`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let cfg = config(&args)?;
    let bar = ctx.progress(0, "episodes");
    let summary = write_dataset_of(&cfg.sources, &cfg.out, &cfg.options, &bar)?;
    drop(bar);
    ctx.say(format!(
        "{}: LeRobot {} dataset, {} episodes, {} frames, {} tasks, {} data file(s), {} fps",
        cfg.out.display(),
        minos::io::lerobot::CODEBASE_VERSION,
        summary.episodes,
        summary.frames,
        summary.tasks,
        summary.data_files,
        cfg.options.fps
    ));
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::common::parse_flags;

    #[test]
    fn fps_comes_from_the_flag_or_the_runs_manifest() {
        let dir = tempfile::tempdir().expect("tempdir");
        let run = dir.path().display().to_string();
        let flags = |extra: &str| {
            parse_flags::<Args>(&format!("--run {run} --out {run}/lr {extra}")).expect("flags")
        };
        // No manifest and no --fps: one error naming the manifest.
        let e = config(&flags("")).expect_err("no manifest").to_string();
        assert!(e.contains("manifest.json"), "{e}");
        assert_eq!(config(&flags("--fps 30")).expect("given").options.fps, 30);
        std::fs::write(dir.path().join("manifest.json"), r#"{"body": {"dt": 0.1}}"#)
            .expect("write");
        let cfg = config(&flags("")).expect("from the manifest");
        assert_eq!(cfg.options.fps, 10);
        assert_eq!(cfg.tables.episodes, dir.path().join("episodes.parquet"));
        std::fs::write(dir.path().join("manifest.json"), r#"{"body": {"dt": -1}}"#).expect("write");
        let e = config(&flags("")).expect_err("bad dt").to_string();
        assert!(e.contains("body.dt"), "{e}");
        assert!(parse_flags::<Args>(&format!("--run {run} --out x --fps 0")).is_err());
    }
}
