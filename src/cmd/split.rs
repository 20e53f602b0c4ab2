//! `minos split`: reads the manifest, parses `--where`, calls [`minos::split`] and writes
//! `DATA/splits/NAME/{train,val,test}.txt`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context as _;
use clap::ArgGroup;
use minos::pipeline::split::{make_split, Method, SplitJob, SplitJobError};
use minos::split::SYNTAX_HELP;
use minos::split::{Expr, Ratios, SplitResult};
use minos::store::DataDir;

use super::Context;

/// Ids of missing scenes a warning names before "…".
const SHOW_MISSING: usize = 5;

const AFTER_HELP: &str = "\
Scenes that failed to ingest are never put in a split. Ratio splits hash each id with the
seed on its own, so adding scenes to DATA later never moves the scenes already split.
--lists reads DIR/train.txt, DIR/val.txt and DIR/test.txt (one id per line; blank lines and
# comments ignored) and keeps the listed scenes that are in DATA; listed ids missing from DATA
are reported, not fatal. The official lists ship inside minos: `--lists mp3d` and
`--lists suncg-multiroom` (or `splits/NAME`, as the repository lays them out) work from any
folder; a folder of that name, when there is one, wins.

Examples:
  # The MINOS Matterport3D split (61/11/18 scenes), from the lists shipped with minos
  minos split --data data/mp3d --name mp3d --lists mp3d

  # MINOS's SUNCG multi-room split, keeping only houses with a kitchen and no people
  minos split --data data/suncg --name multiroom --lists suncg-multiroom \\
      --where 'has_room(\"kitchen\") && !has_category(\"person\")'

  # A seeded 60/20/20 split of houses with 3 to 5 rooms
  minos split --data data/suncg --name mid --ratios 0.6,0.2,0.2 --seed 1 \\
      --where 'nrooms > 2 && nrooms < 6'

  # Two-room houses only
  minos split --data data/suncg --name tworoom --ratios 0.8,0.1,0.1 --where 'nrooms == 2'
";

/// Flags of `minos split`.
#[derive(Debug, clap::Args)]
#[command(
    after_help = format!(
        "{}\n\n{AFTER_HELP}",
        SYNTAX_HELP.replacen("Filter expressions", "Filter expressions (--where)", 1)
    ),
    group(ArgGroup::new("source").required(true).args(["lists", "ratios"])),
)]
pub struct Args {
    /// DATA folder made by `minos ingest`; reads DATA/houses.parquet.
    #[arg(long, value_name = "DATA")]
    data: PathBuf,
    /// Split name: the lists go to DATA/splits/NAME/{train,val,test}.txt (replacing them).
    #[arg(long, value_name = "NAME")]
    name: String,
    /// Keep only scenes for which EXPR is true, e.g. 'nrooms > 2 && has_room("kitchen")'.
    /// The language is described below.
    #[arg(long = "where", value_name = "EXPR")]
    filter: Option<String>,
    /// Take the subsets from DIR/{train,val,test}.txt, or the built-in official lists
    /// `mp3d` or `suncg-multiroom`.
    #[arg(long, value_name = "DIR|NAME")]
    lists: Option<PathBuf>,
    /// Split by fractions TRAIN,VAL,TEST (non-negative, summing to 1), e.g. 0.6,0.2,0.2.
    #[arg(long, value_name = "TRAIN,VAL,TEST")]
    ratios: Option<Ratios>,
    /// Seed of a --ratios split: the same seed always gives the same split.
    #[arg(long, value_name = "S", default_value_t = 0, conflicts_with = "lists")]
    seed: u64,
}

/// Flags → the job (the `--where` expression checked before any work).
pub fn config(args: &Args) -> anyhow::Result<SplitJob> {
    let filter = args
        .filter
        .as_deref()
        .map(Expr::parse)
        .transpose()
        .context("--where")?;
    let method = match (&args.lists, args.ratios) {
        (Some(lists_dir), _) => Method::ListsFrom(lists_dir.clone()),
        (None, Some(ratios)) => Method::Ratios(ratios, args.seed),
        (None, None) => anyhow::bail!("one of --lists and --ratios is required"),
    };
    Ok(SplitJob {
        data: DataDir::new(&args.data),
        name: args.name.clone(),
        filter,
        method,
    })
}

/// Runs the subcommand.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let job = config(&args)?;
    let report = make_split(&job, ctx.lock_mode).map_err(|e| match e {
        SplitJobError::Name(_) => anyhow::Error::new(e).context("--name"),
        // The flag in place of the library's "lists DIR".
        SplitJobError::Lists { given, source } => {
            anyhow::Error::new(source).context(format!("--lists {}", given.display()))
        }
        other => other.into(),
    })?;
    warn_missing(&report.result.missing, "listed ids are not in DATA");
    if report.result.lists.total() == 0 {
        tracing::warn!("split {} is empty", args.name);
    }
    ctx.say(summary(&args, &report.result, &report.dir));
    Ok(ExitCode::SUCCESS)
}

/// Warns, when `missing` is not empty, with its count, `what`, and its first few ids.
pub(super) fn warn_missing(missing: &[String], what: &str) {
    if missing.is_empty() {
        return;
    }
    let shown = missing[..missing.len().min(SHOW_MISSING)].join(", ");
    let more = if missing.len() > SHOW_MISSING {
        ", …"
    } else {
        ""
    };
    tracing::warn!("{} {what}: {shown}{more}", missing.len());
}

/// `split NAME: 207 train, 76 val, 77 test (12 filtered out by --where, 1 failed to ingest) -> DIR/`
fn summary(args: &Args, r: &SplitResult, dir: &Path) -> String {
    let mut notes = Vec::new();
    if args.filter.is_some() {
        notes.push(format!("{} filtered out by --where", r.filtered_out));
    }
    notes.push(format!("{} failed to ingest", r.failed));
    if r.unlisted > 0 {
        notes.push(format!("{} in no list", r.unlisted));
    }
    if !r.missing.is_empty() {
        notes.push(format!("{} listed but not in DATA", r.missing.len()));
    }
    format!(
        "split {}: {} train, {} val, {} test ({}) -> {}/",
        args.name,
        r.lists.train.len(),
        r.lists.val.len(),
        r.lists.test.len(),
        notes.join(", "),
        dir.display()
    )
}
