//! `minos generate`: flags → [`minos::generate::GenerateConfig`], then report.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context as _;
use minos::generate::{generate, GenerateConfig, OutputFormat};

use super::range::parse_range;
use super::Context;

/// Dataset layouts `generate` can write.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum Format {
    /// SUNCG: house/<id>/house.json, room/, object/, metadata/ModelCategoryMapping.csv.
    Suncg,
    /// Matterport3D: <id>/house_segmentations/<id>.house and <id>.ply (read with
    /// `ingest --dataset mp3d`).
    Mp3d,
}

/// Generate procedural houses in a real dataset's on-disk format.
///
/// Houses have 1–2 levels (stairs between them), rooms of varied types connected by doors
/// (some closed) and arches, windows, and furniture placed without interpenetration that
/// leaves every doorway reachable. Same flags ⇒ byte-identical files; existing houses are
/// kept, so an interrupted run resumes.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos generate --houses 100 --seed 1 --out gen/suncg\n  \
    minos generate --houses 20 --rooms 2..2 --levels 1 --out gen/two-rooms"
)]
pub struct Args {
    /// Output format.
    #[arg(long, value_enum, default_value = "suncg")]
    format: Format,
    /// Number of houses.
    #[arg(long, default_value_t = 10)]
    houses: usize,
    /// Seed; house ids and contents derive from it.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Output root (the dataset folder), e.g. gen/suncg.
    #[arg(long)]
    out: PathBuf,
    /// Rooms per house as MIN..MAX (stair halls count), e.g. 1..12.
    #[arg(long, default_value = "3..8", value_parser = parse_range)]
    rooms: (usize, usize),
    /// Levels per house as MIN..MAX (1 or 2), e.g. 1..2 or 1.
    #[arg(long, default_value = "1..2", value_parser = parse_range)]
    levels: (usize, usize),
    /// Probability that the only door of a dead-end room is closed.
    #[arg(long, default_value_t = 0.25)]
    closed_doors: f64,
    /// Rewrite houses that already exist.
    #[arg(long)]
    force: bool,
}

/// Flags → what to generate and in which format.
pub fn config(args: &Args) -> (GenerateConfig, OutputFormat) {
    let cfg = GenerateConfig {
        houses: args.houses,
        seed: args.seed,
        rooms: args.rooms,
        levels: args.levels,
        closed_door_prob: args.closed_doors,
    };
    let format = match args.format {
        Format::Suncg => OutputFormat::Suncg,
        Format::Mp3d => OutputFormat::Mp3d,
    };
    (cfg, format)
}

/// Runs `minos generate`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let (cfg, format) = config(&args);
    let start = Instant::now();
    let bar = ctx.progress(cfg.houses as u64, "generate");
    let report = generate(&cfg, format, &args.out, args.force, &bar)
        .with_context(|| format!("generating into {}", args.out.display()))?;
    drop(bar);
    let secs = start.elapsed().as_secs_f64();
    ctx.say(format!(
        "generated {} houses ({} kept from an earlier run) in {:.2} s ({:.0} houses/s) -> {}",
        report.written.len(),
        report.skipped.len(),
        secs,
        report.written.len() as f64 / secs.max(1e-9),
        args.out.display()
    ));
    Ok(ExitCode::SUCCESS)
}
