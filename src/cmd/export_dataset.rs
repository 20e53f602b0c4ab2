//! `minos export-dataset`: flags → [`ExportConfig`] ([`config`]) →
//! [`minos::io::lerobot::write_dataset`]; prints what was written.

use std::path::PathBuf;
use std::process::ExitCode;

use minos::io::lerobot::source::RunTables;
use minos::io::lerobot::{write_dataset_of, DatasetLayout, DatasetOptions, DemoSource};
use minos::io::run_dir::RunDir;
use minos::serve::campaign::record::SessionQc;

use super::common::{vocab, VideoQp};
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
    #[command(flatten)]
    video_qp: VideoQp,
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

/// Flags → what to export (reads the first run's manifest.json for the frame rate and the
/// configuration the dataset records).
pub fn config(args: &Args) -> anyhow::Result<ExportConfig> {
    let DatasetLayout::Lerobot = args.format;
    let mut runs: Vec<RunDir> = args.run.iter().map(RunDir::new).collect();
    if let Some(state) = &args.campaign_state {
        // Sessions that finished no episode have no tables.
        runs.extend(
            minos::serve::campaign::session_folders(state)?
                .into_iter()
                .map(RunDir::new)
                .filter(|s| s.episodes().is_file()),
        );
    }
    let Some(first) = runs.first() else {
        anyhow::bail!("no run to export (the campaign has no session yet)");
    };
    // Without --fps, the frame rate is the manifest's: its errors say how to do without.
    let options = DatasetOptions::of_run(first, args.fps, args.video_qp.settings(args.video))
        .map_err(|e| anyhow::anyhow!("{} (give --fps)", minos::escape::error_line(&e)))?;
    let mut sources = Vec::with_capacity(runs.len());
    for run in &runs {
        let keep = if args.accepted {
            if !run.qc().is_file() {
                anyhow::bail!(
                    "{}: no quality records (qc.json): --accepted needs a campaign session",
                    run.root().display()
                );
            }
            Some(
                SessionQc::load(run.root())?
                    .accepted()
                    .into_iter()
                    .collect(),
            )
        } else {
            None
        };
        sources.push(DemoSource {
            tables: RunTables::in_dir(run.root()),
            keep,
        });
    }
    Ok(ExportConfig {
        sources,
        tables: RunTables::in_dir(first.root()),
        out: args.out.clone(),
        options,
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
        assert!(e.ends_with("(give --fps)"), "{e}");
        assert_eq!(config(&flags("--fps 30")).expect("given").options.fps, 30);
        std::fs::write(dir.path().join("manifest.json"), r#"{"body": {"dt": 0.1}}"#)
            .expect("write");
        let cfg = config(&flags("")).expect("from the manifest");
        assert_eq!(cfg.options.fps, 10);
        assert_eq!(cfg.tables.episodes, dir.path().join("episodes.parquet"));
        std::fs::write(dir.path().join("manifest.json"), r#"{"body": {"dt": -1}}"#).expect("write");
        let e = config(&flags("")).expect_err("bad dt").to_string();
        assert!(e.contains("body.dt: not a positive number"), "{e}");
        // With --fps the manifest's step is not needed, its configuration still recorded.
        let cfg = config(&flags("--fps 5")).expect("given");
        assert_eq!(
            cfg.options.run,
            Some(serde_json::json!({"body": {"dt": -1}}))
        );
        assert!(parse_flags::<Args>(&format!("--run {run} --out x --fps 0")).is_err());
    }
}
