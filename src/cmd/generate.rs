//! `minos generate`: flags → [`minos::generate::GenerateConfig`], then report.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context as _;
use minos::generate::{
    generate, Furnishing, GenerateConfig, HouseFormat, OutputFormat, ScanOptions,
};

use super::common::vocab;
use super::range::parse_range;
use super::Context;

/// Dataset layouts `generate` can write.
/// Generate procedural houses in a real dataset's on-disk format.
///
/// Houses have 1–2 levels (stairs between them), rooms of varied types connected by doors
/// (some closed) and arches, windows, and furniture placed without interpenetration that
/// leaves every doorway reachable. Same flags ⇒ byte-identical files; existing houses are
/// kept, so an interrupted run resumes.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos generate --houses 100 --seed 1 --out gen/suncg\n  \
    minos generate --houses 20 --rooms 2..2 --levels 1 --out gen/two-rooms\n  \
    minos generate --houses 20 --rooms 2..2 --furnishing dense --out gen/cluttered\n  \
    minos generate --scan --houses 2 --scan-triangles 3000000 --out gen/scans"
)]
pub struct Args {
    /// Output format [default: suncg; with --scan mp3d-scan].
    #[arg(long, value_parser = vocab::<HouseFormat>())]
    format: Option<HouseFormat>,
    /// Number of houses.
    #[arg(long, default_value_t = 10)]
    houses: usize,
    /// Seed; house ids and contents derive from it.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Output root (the dataset folder), e.g. gen/suncg.
    #[arg(long)]
    out: PathBuf,
    /// Rooms per house as MIN..MAX (stair halls count), e.g. 1..12 [default: 3..8; with
    /// --scan 9..12].
    #[arg(long, value_parser = parse_range)]
    rooms: Option<(usize, usize)>,
    /// Levels per house as MIN..MAX (1 or 2; up to 3 with --scan), e.g. 1..2 or 1 [default:
    /// 1..2; with --scan 3].
    #[arg(long, value_parser = parse_range)]
    levels: Option<(usize, usize)>,
    /// Probability that the only door of a dead-end room is closed.
    #[arg(long, default_value_t = 0.25)]
    closed_doors: f64,
    /// How much furniture each room gets: standard (each room's recipe) or dense (extra
    /// pieces until about half the floor is taken, as measured in real SUNCG and 3D-FRONT
    /// rooms).
    #[arg(long, default_value = "standard", value_parser = vocab::<Furnishing>())]
    furnishing: Furnishing,
    /// Rewrite houses that already exist.
    #[arg(long)]
    force: bool,
    /// Write scan-like Matterport3D houses (= --format mp3d-scan): every surface a dense
    /// grid of small triangles with vertex noise, small holes and clutter, faces split into
    /// ~1 m segments; up to three levels joined by stairs.
    #[arg(long)]
    scan: bool,
    /// Triangles per scan house to aim for (each house gets at most this many, within a few
    /// per cent); 2,000,000 makes cells of about 2 cm [default: 2000000].
    #[arg(long)]
    scan_triangles: Option<u64>,
    /// Standard deviation of a scan's vertex noise along surface normals, in metres
    /// [default: 0.003].
    #[arg(long)]
    scan_noise: Option<f64>,
}

/// Flags → what to generate and in which format (`--scan` with `--format suncg` is an
/// error; ranges are checked by the library).
pub fn config(args: &Args) -> anyhow::Result<(GenerateConfig, OutputFormat)> {
    let chosen = match (args.format, args.scan) {
        (None | Some(HouseFormat::Mp3d | HouseFormat::Mp3dScan), true) => HouseFormat::Mp3dScan,
        (Some(HouseFormat::Suncg), true) => {
            anyhow::bail!("--scan writes Matterport3D houses: use it with --format mp3d")
        }
        (format, false) => format.unwrap_or(HouseFormat::Suncg),
    };
    let scan = chosen == HouseFormat::Mp3dScan;
    if !scan && (args.scan_triangles.is_some() || args.scan_noise.is_some()) {
        anyhow::bail!("--scan-triangles and --scan-noise need --scan (or --format mp3d-scan)");
    }
    let defaults = ScanOptions::default();
    let format = chosen.output(ScanOptions {
        triangles: args.scan_triangles.unwrap_or(defaults.triangles),
        noise: args.scan_noise.unwrap_or(defaults.noise),
    });
    let (rooms, levels) = if scan {
        ((9, 12), (3, 3))
    } else {
        ((3, 8), (1, 2))
    };
    let cfg = GenerateConfig {
        houses: args.houses,
        seed: args.seed,
        rooms: args.rooms.unwrap_or(rooms),
        levels: args.levels.unwrap_or(levels),
        closed_door_prob: args.closed_doors,
        furnishing: args.furnishing,
    };
    cfg.validate_for(format)?;
    Ok((cfg, format))
}

/// Runs `minos generate`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let (cfg, format) = config(&args)?;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::common::parse_flags;

    fn parse(line: &str) -> anyhow::Result<(GenerateConfig, OutputFormat)> {
        config(&parse_flags::<Args>(line)?)
    }

    #[test]
    fn scan_implies_mp3d_and_its_own_defaults() {
        let (cfg, format) = parse("--out o --scan --scan-triangles 50000").unwrap();
        assert_eq!(
            format,
            OutputFormat::Mp3dScan(ScanOptions {
                triangles: 50_000,
                noise: minos::generate::scan::DEFAULT_NOISE
            })
        );
        assert_eq!((cfg.rooms, cfg.levels), ((9, 12), (3, 3)));
        let (cfg, format) = parse("--out o").unwrap();
        assert_eq!(format, OutputFormat::Suncg);
        assert_eq!((cfg.rooms, cfg.levels), ((3, 8), (1, 2)));
    }

    #[test]
    fn bad_scan_options_are_one_line_errors() {
        for (line, needle) in [
            ("--out o --format suncg --scan", "--format mp3d"),
            ("--out o --scan --scan-triangles 10", "scan triangles 10"),
            ("--out o --scan --scan-noise 0.5", "scan noise"),
            ("--out o --scan --levels 4", "levels 4..4"),
            ("--out o --levels 3", "levels 3..3"),
        ] {
            let e = parse(line).unwrap_err().to_string();
            assert!(e.contains(needle) && !e.contains('\n'), "{line}: {e}");
        }
        assert!(
            parse("--out o --scan-triangles 5000").is_err(),
            "requires --scan"
        );
        // --format mp3d-scan is --scan.
        assert_eq!(
            parse("--out o --format mp3d-scan --scan-triangles 50000").unwrap(),
            parse("--out o --scan --scan-triangles 50000").unwrap()
        );
    }
}
