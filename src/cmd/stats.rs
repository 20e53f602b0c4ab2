//! `minos stats`: reads the manifest (and a split), calls [`minos::stats`] and prints the table
//! or JSON.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use minos::split;
use minos::stats::{self, StatsColumn};
use minos::store::DataDir;

use super::Context;

const AFTER_HELP: &str = "\
The table has one column for all scenes in DATA, or with --split one per subset (train, val,
test) plus their total. Rows: houses loaded and failed, levels, rooms per house, floor area per
house (m²), objects and triangles per house; then how many houses contain each of the nine
MINOS room classes, and the 20 object categories found in the most houses. Per-house numbers
cover the houses that loaded.

Examples:
  # Statistics of everything ingested into data/suncg
  minos stats --data data/suncg

  # Per subset of the split written by `minos split --name multiroom`
  minos stats --data data/suncg --split multiroom

  # The same numbers as JSON, for scripts
  minos stats --data data/suncg --split multiroom --json > multiroom-stats.json
";

/// Flags of `minos stats`.
#[derive(Debug, clap::Args)]
#[command(after_help = AFTER_HELP)]
pub struct Args {
    /// DATA folder made by `minos ingest`; reads DATA/houses.parquet.
    #[arg(long, value_name = "DATA")]
    data: PathBuf,
    /// Describe the subsets of DATA/splits/NAME/ (made by `minos split`), e.g. --split mp3d.
    #[arg(long, value_name = "NAME")]
    split: Option<String>,
    /// Print the statistics as JSON (every category, not only the top 20) instead of a table.
    #[arg(long)]
    json: bool,
}

/// Flags → the DATA folder to describe (which split, and how, the flags say directly).
pub fn config(args: &Args) -> DataDir {
    DataDir::new(&args.data)
}

/// Runs the subcommand.
pub fn run(args: Args, _ctx: &Context) -> anyhow::Result<ExitCode> {
    let data = config(&args);
    let rows = data
        .read_manifest()
        .context("cannot read the manifest (run `minos ingest` first)")?;
    let columns = match &args.split {
        None => vec![StatsColumn {
            name: "all".into(),
            stats: stats::compute(&rows),
        }],
        Some(name) => {
            let lists =
                split::read_split(&data, name).with_context(|| format!("--split {name}"))?;
            let what = format!("ids of split {name} are not in the manifest (not counted)");
            super::split::warn_missing(&lists.missing_from(&rows), &what);
            stats::compute_split(&rows, &lists)
        }
    };
    // The statistics are this command's output, so -q does not hide them.
    if args.json {
        println!("{}", serde_json::to_string_pretty(&columns)?);
    } else {
        print!("{}", stats::render_table(&columns));
    }
    Ok(ExitCode::SUCCESS)
}
