//! `minos ingest`: flags → [`IngestConfig`] ([`config`]), then a summary and one line per
//! failed scene.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context as _;
use minos::pipeline::ingest::{ingest_shard, read_id_list, DatasetFormat, IngestConfig, Outcome};
use minos::shard::ShardSpec;
use minos::store::DataDir;

use super::common::vocab;
use super::Context;

/// Load scenes into compiled scenes (DATA/scenes/) and a Parquet manifest (DATA/houses.parquet).
///
/// Scenes load in parallel. A scene that fails is reported on one line (file, node, what is
/// wrong), gets a row with its error in the manifest, and the others finish; the command then
/// exits with status 1. Scenes whose compiled file is newer than all their sources are not
/// reloaded (use --force).
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos generate --houses 50 --out gen/suncg\n  \
    minos ingest --dataset suncg --root gen/suncg --out DATA\n  \
    minos ingest --dataset suncg --root /data/suncg --ids splits/suncg-multiroom/train.txt --out DATA"
)]
pub struct Args {
    /// Dataset format.
    #[arg(long, value_parser = vocab::<DatasetFormat>(), default_value = "suncg")]
    dataset: DatasetFormat,
    /// Dataset root folder.
    #[arg(long)]
    root: PathBuf,
    /// DATA folder to write (created if missing).
    #[arg(long, visible_alias = "data")]
    out: PathBuf,
    /// Only the scene ids listed in FILE (one per line).
    #[arg(long, value_name = "FILE")]
    ids: Option<PathBuf>,
    /// Compile every n-th scene (sorted by id): i/n, or `auto` from the scheduler. Shards
    /// compile into one DATA folder at once and write no manifest: when all are done, run
    /// the same ingest without --shard (it reuses the compiled scenes) to write it.
    #[arg(long, value_parser = ShardSpec::parse, default_value = "0/1")]
    shard: ShardSpec,
    /// Parallel jobs (same as the global --threads: 0 means all cores, at most 1024).
    #[arg(long, value_name = "N", value_parser = super::common::parse_threads)]
    jobs: Option<usize>,
    /// Category table: SUNCG's if not <root>/metadata/ModelCategoryMapping.csv; Matterport3D's
    /// category_mapping.tsv if not in <root> or <root>/metadata.
    #[arg(long, value_name = "FILE")]
    categories: Option<PathBuf>,
    /// 3D-FRONT: 3D-FUTURE model folder (<jid>/raw_model.obj); furniture are boxes without it.
    #[arg(long, value_name = "DIR")]
    models: Option<PathBuf>,
    /// Rebuild every compiled scene.
    #[arg(long)]
    force: bool,
}

/// Flags → the library's configuration (reads the `--ids` list, if any).
pub fn config(args: &Args) -> anyhow::Result<IngestConfig> {
    let ids = match &args.ids {
        Some(f) => Some(read_id_list(f)?),
        None => None,
    };
    Ok(IngestConfig {
        format: args.dataset,
        root: args.root.clone(),
        data: DataDir::new(&args.out),
        ids,
        force: args.force,
        categories: args.categories.clone(),
        models: args.models.clone(),
    })
}

/// Runs `minos ingest`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let cfg = config(&args)?;
    let start = Instant::now();
    let report = {
        let bar = ctx.progress(0, "ingest");
        let shard = args
            .shard
            .resolve(|k| std::env::var(k).ok())
            .map_err(anyhow::Error::msg)?;
        let job = || ingest_shard(&cfg, shard, ctx.lock_mode, &bar);
        match args.jobs {
            Some(n) => rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .context("--jobs")?
                .install(job),
            None => job(),
        }
        .with_context(|| format!("ingesting {}", args.root.display()))?
    };
    for w in &report.warnings {
        tracing::warn!("{w}");
    }
    if !report.missing_ids.is_empty() {
        tracing::warn!(
            "{} requested ids are not under {} (first: {})",
            report.missing_ids.len(),
            args.root.display(),
            report
                .missing_ids
                .iter()
                .take(5)
                .cloned()
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let failed: Vec<_> = report
        .scenes
        .iter()
        .filter(|(_, o)| *o == Outcome::Failed)
        .collect();
    for (row, _) in &failed {
        eprintln!("error: {}", row.error.as_deref().unwrap_or("unknown error"));
    }
    ctx.say(format!(
        "ingested {} scenes in {:.2} s: {} compiled, {} up to date, {} failed -> {}",
        report.scenes.len(),
        start.elapsed().as_secs_f64(),
        report.count(Outcome::Compiled),
        report.count(Outcome::UpToDate),
        failed.len(),
        if report.manifest_written {
            report.manifest.display().to_string()
        } else {
            format!(
                "{} (a shard writes no manifest: when every shard is done, run this ingest \
                 without --shard to write it)",
                cfg.data.scenes_dir().display()
            )
        }
    ));
    Ok(if failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
