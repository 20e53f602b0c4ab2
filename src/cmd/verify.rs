//! `minos verify PATH`: the flags → [`minos::verify::VerifyOptions`], one call to
//! [`minos::verify::verify`], and the problems printed one per line.

use std::path::PathBuf;
use std::process::ExitCode;

use minos::verify::{self, VerifyOptions};

use super::Context;

const AFTER_HELP: &str = "\
PATH is detected as a run folder (manifest.json + trajectories.parquet; its lerobot/ copy is
checked too), a LeRobot v3.0 dataset (meta/info.json), an episode file (FILE.parquet with
FILE.parquet.provenance.json) or a DATA folder (houses.parquet).

Checked: every file's sha256 and size against the output's provenance record (and files
missing or not listed); run tables against each other (episode and step continuity, rows,
steps, success, metrics.json) and every image cell decoding with its declared shape;
LeRobot data files against info.json's features, index / episode / frame continuity,
episode boundaries against meta/episodes, totals, images, and statistics recomputed from the
frames; episode files against the baked grids of --data (starts and goals navigable,
geodesic distances within 0.05 m); DATA folders' manifest, compiled scenes and grids.

Each problem is one line `FILE: RECORD: WHAT` on stdout (at most 20 per file, then a count),
and the exit status is 1. A clean output prints one summary line and exits 0.

Examples:
  minos verify runs/pointgoal
  minos verify runs/pointgoal/lerobot
  minos verify episodes/val.parquet --data data/suncg
  minos verify data/suncg
";

/// Flags of `minos verify`.
#[derive(Debug, clap::Args)]
#[command(after_help = AFTER_HELP)]
pub struct Args {
    /// The output to check: run folder, LeRobot dataset, episode file or DATA folder.
    path: PathBuf,
    /// For an episode file: the DATA folder its scenes were baked in, to check every start
    /// and goal on the grids and re-compute the geodesic distances.
    #[arg(long, value_name = "DATA")]
    data: Option<PathBuf>,
}

/// Flags → what to check.
pub fn config(args: &Args) -> VerifyOptions {
    VerifyOptions {
        data: args.data.clone(),
    }
}

/// Runs the subcommand.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let options = config(&args);
    let bar = ctx.progress(0, "checksums");
    let report = verify::verify(&args.path, &options, &bar)?;
    drop(bar);
    for p in &report.problems {
        println!("{p}");
    }
    if report.is_clean() {
        ctx.say(format!("{}: {}", args.path.display(), report.summary()));
        Ok(ExitCode::SUCCESS)
    } else {
        eprintln!("{}: {}", args.path.display(), report.summary());
        Ok(ExitCode::FAILURE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    #[test]
    fn data_is_passed_on() {
        let cli = Cli::parse_from(["x", "eps.parquet", "--data", "D"]);
        assert_eq!(config(&cli.args).data, Some(PathBuf::from("D")));
        let cli = Cli::parse_from(["x", "run"]);
        assert_eq!(config(&cli.args), VerifyOptions::default());
    }
}
