//! `minos merge`: flags → what to merge ([`config`]: run folders or episode files) →
//! [`minos::pipeline::merge`]; prints what was written.

use std::path::PathBuf;
use std::process::ExitCode;

use minos::pipeline::merge::run::RunMerge;
use minos::pipeline::merge::{MergeError, MergeJob};

use super::Context;

const AFTER_HELP: &str = "\
Shards are the outputs of one command run with --shard 0/n … n-1/n (or --shard auto under
Slurm, Kubernetes or MINOS_SHARD). The merged files are byte for byte those one unsharded run
writes, but for manifest.json's `command` (the merge's) and the rerun recording's footer
(rerun's index, whose bytes change between any two runs).

Run folders (`minos run --shard i/n --out DIR`): the three tables, metrics.json,
manifest.json, the LeRobot copy when the shards have one, and with --rerun the recording of
the run's first --rerun-episodes episodes. Episode files (`minos episodes --shard i/n --out
FILE`): the episodes and FILE.stats.json.

Examples:
  minos merge --out runs/oracle runs/oracle-0 runs/oracle-1 runs/oracle-2
  minos merge --out runs/oracle --rerun runs/oracle.rrd runs/oracle-*
  minos merge --out eps/points.parquet eps/part-*.parquet";

/// Flags of `minos merge`.
#[derive(Debug, clap::Args)]
#[command(after_help = AFTER_HELP)]
pub struct Args {
    /// The merged output: a run folder, or an episode file.
    #[arg(long, value_name = "PATH")]
    out: PathBuf,
    /// The merged rerun recording (when the shard runs recorded episodes with --rerun).
    #[arg(long, value_name = "FILE.rrd")]
    rerun: Option<PathBuf>,
    /// The shards: run folders, or episode files (all of one kind), in any order.
    #[arg(required = true, value_name = "SHARD")]
    shards: Vec<PathBuf>,
}

/// Flags → the merge (run folders or episode files: the library tells them apart).
pub fn config(args: &Args, ctx: &Context) -> anyhow::Result<MergeJob> {
    let merge = RunMerge {
        out: args.out.clone(),
        rerun: args.rerun.clone(),
        command: std::env::args().collect(),
        lock: ctx.lock_mode,
    };
    MergeJob::of_shards(args.shards.clone(), merge).map_err(|e| match e {
        MergeError::NoRecordingOfEpisodes { .. } => {
            anyhow::anyhow!("--rerun {}", minos::escape::error_line(&e))
        }
        other => other.into(),
    })
}

/// Runs `minos merge`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let job = config(&args, ctx)?;
    let bar = ctx.progress(6, "merge");
    // The library names no flag; the command line adds its own.
    let report = job.run(&bar).map_err(|e| match e {
        MergeError::RecordingUnnamed { .. } => {
            anyhow::anyhow!("{} (--rerun FILE.rrd)", minos::escape::error_line(&e))
        }
        MergeError::NothingRecorded { .. } => {
            anyhow::anyhow!("--rerun {}", minos::escape::error_line(&e))
        }
        MergeError::Unfinished { .. } => {
            anyhow::Error::new(e).context("finish the shard first (run it again with --resume)")
        }
        other => other.into(),
    })?;
    drop(bar);
    match &job {
        MergeJob::Runs { merge, .. } => ctx.say(format!(
            "merged {} shards: {} episodes ({} failed in their shard){} -> {}",
            report.shards,
            report.episodes,
            report.failures,
            merge
                .rerun
                .as_ref()
                .map(|p| format!(", {} recorded -> {}", report.recorded, p.display()))
                .unwrap_or_default(),
            merge.out.display()
        )),
        MergeJob::Episodes { out, .. } => ctx.say(format!(
            "merged {} shards: {} episodes -> {}",
            report.shards,
            report.episodes,
            out.display()
        )),
    }
    Ok(if report.failures == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
