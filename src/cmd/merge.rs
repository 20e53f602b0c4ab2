//! `minos merge`: flags → what to merge ([`config`]: run folders or episode files) →
//! [`minos::pipeline::merge`]; prints what was written.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::bail;
use minos::pipeline::merge::episodes::merge_episodes;
use minos::pipeline::merge::run::{merge_runs, RunMerge};
use minos::pipeline::merge::MergeError;

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

/// What `minos merge` does.
#[derive(Debug, Clone)]
pub enum MergeJob {
    /// Join run folders.
    Runs {
        /// The shards' folders.
        shards: Vec<PathBuf>,
        /// Output and options.
        merge: RunMerge,
    },
    /// Join episode files.
    Episodes {
        /// The shards' episode files.
        shards: Vec<PathBuf>,
        /// The merged episode file.
        out: PathBuf,
    },
}

/// Flags → the merge: run folders when every shard is a folder, episode files when every
/// shard is a file; anything else is refused.
pub fn config(args: &Args, ctx: &Context) -> anyhow::Result<MergeJob> {
    let folders = args.shards.iter().filter(|p| p.is_dir()).count();
    let files = args.shards.iter().filter(|p| p.is_file()).count();
    if let Some(missing) = args.shards.iter().find(|p| !p.exists()) {
        bail!("{}: no such shard", missing.display());
    }
    if folders == args.shards.len() {
        Ok(MergeJob::Runs {
            shards: args.shards.clone(),
            merge: RunMerge {
                out: args.out.clone(),
                rerun: args.rerun.clone(),
                command: std::env::args().collect(),
                lock: ctx.lock_mode,
            },
        })
    } else if files == args.shards.len() {
        if let Some(r) = &args.rerun {
            bail!(
                "--rerun {}: episode files have no recordings (it is for run folders)",
                r.display()
            );
        }
        Ok(MergeJob::Episodes {
            shards: args.shards.clone(),
            out: args.out.clone(),
        })
    } else {
        bail!("shards must all be run folders or all episode files, not a mix")
    }
}

/// Runs `minos merge`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let report = match config(&args, ctx)? {
        MergeJob::Runs { shards, merge } => {
            let bar = ctx.progress(6, "merge");
            // The library names no flag; the command line adds its own.
            let report = merge_runs(&shards, &merge, &bar).map_err(|e| match e {
                MergeError::RecordingUnnamed { .. } => {
                    anyhow::anyhow!("{} (--rerun FILE.rrd)", minos::escape::error_line(&e))
                }
                MergeError::NothingRecorded { .. } => {
                    anyhow::anyhow!("--rerun {}", minos::escape::error_line(&e))
                }
                MergeError::Unfinished { .. } => anyhow::Error::new(e)
                    .context("finish the shard first (run it again with --resume)"),
                other => other.into(),
            })?;
            drop(bar);
            ctx.say(format!(
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
            ));
            report
        }
        MergeJob::Episodes { shards, out } => {
            let report = merge_episodes(&shards, &out)?;
            ctx.say(format!(
                "merged {} shards: {} episodes -> {}",
                report.shards,
                report.episodes,
                out.display()
            ));
            report
        }
    };
    Ok(if report.failures == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
