//! `minos diff A B`: one call to [`minos::diff::diff`] and its differences printed one per
//! line.

use std::path::PathBuf;
use std::process::ExitCode;

use super::Context;

const AFTER_HELP: &str = "\
Compares two outputs of the same kind — run folders, LeRobot datasets, episode files (with
their .stats.json and .provenance.json), DATA folders — or any two files or folders, file by
file. For each file that differs, one line gives its first difference in user terms:
Parquet tables by row (episode and step, or LeRobot episode and frame), column and both
values; JSON by the value's path; text by line. Prints `identical` and exits 0 when every
file has the same bytes; exits 1 when something differs.

Examples:
  minos diff runs/full runs/merged
  minos diff episodes/a.parquet episodes/b.parquet
  minos diff runs/a/lerobot runs/b/lerobot
";

/// Flags of `minos diff`.
#[derive(Debug, clap::Args)]
#[command(after_help = AFTER_HELP)]
pub struct Args {
    /// The first output.
    a: PathBuf,
    /// The second output.
    b: PathBuf,
}

/// Runs the subcommand.
pub fn run(args: Args, _ctx: &Context) -> anyhow::Result<ExitCode> {
    let report = minos::diff::diff(&args.a, &args.b)?;
    for d in &report.differences {
        println!("{d}");
    }
    // The verdict is this command's output, so -q does not hide it.
    println!("{}", report.summary());
    Ok(if report.identical() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
