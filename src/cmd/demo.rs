//! `minos demo`: the README's main job. Runs every stage that exists on generated houses
//! (generate → ingest → split → stats) into one folder and says where everything is.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context as _;
use minos::generate::{generate, GenerateConfig, OutputFormat};
use minos::ingest::{ingest, IngestConfig, Outcome};
use minos::io::manifest::read_manifest;
use minos::split::{self, Expr, Ratios};
use minos::stats;

use super::Context;

/// Run the pipeline on procedural houses into ./minos-demo/.
///
/// Generates houses in SUNCG's layout, ingests them into a DATA folder (compiled scenes and
/// a Parquet manifest), writes a seeded 60/20/20 split and MINOS's multi-room split
/// (3 to 5 rooms), and prints environment statistics. Re-running resumes.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos demo\n  minos demo --houses 200 --seed 3 --out /tmp/demo"
)]
pub struct Args {
    /// Output folder.
    #[arg(long, default_value = "minos-demo")]
    out: PathBuf,
    /// Number of houses to generate.
    #[arg(long, default_value_t = 48)]
    houses: usize,
    /// Seed of the houses and splits.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

/// Runs `minos demo`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let start = Instant::now();
    let root = args.out.join("suncg");
    let data = args.out.join("data");
    let cfg = GenerateConfig {
        houses: args.houses,
        seed: args.seed,
        ..GenerateConfig::default()
    };
    {
        let bar = ctx.progress(cfg.houses as u64, "generate");
        generate(&cfg, OutputFormat::Suncg, &root, false, &bar).context("generate")?;
    }
    ctx.say(format!(
        "1/4 generated {} houses      -> {}",
        cfg.houses,
        root.display()
    ));
    let report = {
        let bar = ctx.progress(0, "ingest");
        ingest(&IngestConfig::suncg(&root, &data), &bar).context("ingest")?
    };
    let failed = report.count(Outcome::Failed);
    ctx.say(format!(
        "2/4 ingested {} scenes ({failed} failed) -> {}",
        report.scenes.len(),
        report.manifest.display()
    ));
    let rows = read_manifest(&report.manifest)?;
    let ratios = Ratios::new([0.6, 0.2, 0.2])?;
    let all = split::split_by_ratios(&rows, None, ratios, args.seed);
    let all_dir = split::write_split(&data, "all", &all.lists)?;
    let multiroom = Expr::parse("nrooms > 2 && nrooms < 6").context("demo filter")?;
    let mr = split::split_by_ratios(&rows, Some(&multiroom), ratios, args.seed);
    let mr_dir = split::write_split(&data, "multiroom", &mr.lists)?;
    ctx.say(format!(
        "3/4 splits: all {}/{}/{} -> {}, multiroom (3-5 rooms) {}/{}/{} -> {}",
        all.lists.train.len(),
        all.lists.val.len(),
        all.lists.test.len(),
        all_dir.display(),
        mr.lists.train.len(),
        mr.lists.val.len(),
        mr.lists.test.len(),
        mr_dir.display()
    ));
    ctx.say("4/4 statistics of split `all`:");
    ctx.say(stats::render_table(&stats::compute_split(
        &rows, &all.lists,
    )));
    ctx.say(format!(
        "done in {:.1} s. Next:\n  minos stats --data {d} --split multiroom\n  \
         minos export --data {d} --scene {id} --out house.glb   (open in Blender)\n  \
         python: pandas.read_parquet(\"{m}\")",
        start.elapsed().as_secs_f64(),
        d = data.display(),
        id = rows.first().map(|r| r.id.as_str()).unwrap_or("ID"),
        m = report.manifest.display(),
    ));
    Ok(if failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
