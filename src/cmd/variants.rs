//! `minos variants`: define named scene variants (from a spec file or flags), compute the
//! material statistics retexturing needs, and report what each variant does to the scenes.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context as _};
use minos::atomic::sweep_stale;
use minos::pipeline::variants::{collect_stats, dry_run};
use minos::scene::variants::materials::DEFAULT_FRACTIONS;
use minos::scene::variants::{
    parse_spec_file, validate_name, KeepOnly, Retexture, TextureSet, VariantSpec,
};
use minos::store::DataDir;

use super::Context;

/// Define scene variants: clutter removal (remove, keep_only, empty, hide), open doors and
/// semantically consistent retexturing, stored as small descriptions in DATA/variants/ and
/// applied whenever a command loads `<scene>@<variant>` (bake, episodes, run, render and
/// export take --variant NAME).
///
/// Retexturing draws every material slot from the materials observed on its category across
/// the ingested scenes (DATA/stats/materials.json, computed on first use or with
/// --refresh-stats), restricted to one of three disjoint texture sets (train, val, test).
#[derive(Debug, clap::Args)]
#[command(after_help = "Spec files hold one table per variant:\n  \
    [empty]\n  empty = true\n\n  [tidy]\n  remove = [\"chair\", \"candle\"]\n  hide = [\"person\", \"plant\"]\n\n  \
    [open]\n  open_doors = true\n\n  [tex-train]\n  retexture = { seed = 7, texture_set = \"train\" }\n\n\
    Examples:\n  minos variants --data DATA --spec variants.toml\n  \
    minos variants --data DATA --name empty --empty\n  \
    minos variants --data DATA --name tex-val --retexture-seed 3 --texture-set val\n  \
    minos variants --data DATA --list\n  \
    minos bake --data DATA --variant empty")]
pub struct Args {
    /// DATA folder made by `minos ingest`.
    #[arg(long)]
    data: PathBuf,
    /// TOML file of named variants (one table per variant).
    #[arg(long, value_name = "FILE", conflicts_with = "name")]
    spec: Option<PathBuf>,
    /// Name of a variant defined by the flags below.
    #[arg(long)]
    name: Option<String>,
    /// Remove these categories (comma-separated; fine, coarse, NYU-40 or mpcat40 names).
    #[arg(long, value_delimiter = ',', requires = "name")]
    remove: Vec<String>,
    /// Keep only these categories besides architecture; `arch` keeps architecture alone.
    #[arg(long, value_delimiter = ',', requires = "name")]
    keep_only: Vec<String>,
    /// Keep only doors, arches and windows (MINOS emptyRoom).
    #[arg(long, requires = "name")]
    empty: bool,
    /// Hide these categories (MINOS's hide list; removed like --remove).
    #[arg(long, value_delimiter = ',', requires = "name")]
    hide: Vec<String>,
    /// Open every closed door.
    #[arg(long, requires = "name")]
    open_doors: bool,
    /// Retexture with this seed.
    #[arg(long, value_name = "SEED", requires = "name")]
    retexture_seed: Option<u64>,
    /// Texture set retexturing draws from.
    #[arg(long, value_enum, default_value = "train")]
    texture_set: SetArg,
    /// Recompute the material statistics even when they exist.
    #[arg(long)]
    refresh_stats: bool,
    /// Seed of the train/val/test partition of materials (with --refresh-stats or first use).
    #[arg(long, default_value_t = 0)]
    partition_seed: u64,
    /// List the variants defined in DATA and exit.
    #[arg(long)]
    list: bool,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum SetArg {
    Train,
    Val,
    Test,
}

fn from_flags(args: &Args, name: &str) -> anyhow::Result<VariantSpec> {
    validate_name(name).map_err(anyhow::Error::msg)?;
    let spec = VariantSpec {
        remove: args.remove.clone(),
        keep_only: match args.keep_only.len() {
            0 => None,
            1 => Some(KeepOnly::One(args.keep_only[0].clone())),
            _ => Some(KeepOnly::Many(args.keep_only.clone())),
        },
        empty: args.empty,
        hide: args.hide.clone(),
        open_doors: args.open_doors,
        doors: Default::default(),
        retexture: args.retexture_seed.map(|seed| Retexture {
            seed,
            texture_set: match args.texture_set {
                SetArg::Train => TextureSet::Train,
                SetArg::Val => TextureSet::Val,
                SetArg::Test => TextureSet::Test,
            },
        }),
    };
    spec.validate()
        .map_err(|e| anyhow::anyhow!("variant {name}: {e}"))?;
    if spec == VariantSpec::default() {
        bail!("variant {name}: no change given (use --remove, --keep-only, --empty, --hide, --open-doors or --retexture-seed)");
    }
    Ok(spec)
}

/// Flags → the variants to define: read from `--spec FILE`, or one built from the flags.
pub fn config(args: &Args) -> anyhow::Result<Vec<(String, VariantSpec)>> {
    Ok(match (&args.spec, &args.name) {
        (Some(path), _) => {
            let text = std::fs::read_to_string(path).with_context(|| path.display().to_string())?;
            parse_spec_file(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?
        }
        (None, Some(name)) => vec![(name.clone(), from_flags(args, name)?)],
        (None, None) => bail!("give --spec FILE or --name NAME with changes (see --help)"),
    })
}

/// Runs `minos variants`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let data = DataDir::new(&args.data);
    if args.list {
        for name in data.list_variants() {
            let spec = data.read_variant(&name)?;
            let line = spec.to_toml().lines().collect::<Vec<_>>().join("; ");
            println!("{name}: {line}");
        }
        return Ok(ExitCode::SUCCESS);
    }
    let variants = config(&args)?;
    let ids = data.ingested_ids()?;
    // Taken once DATA is known to hold a manifest, so a wrong --data creates nothing.
    let _lock = data.lock("variants", ctx.lock_mode)?;
    for dir in [data.variants_dir(), data.stats_dir()] {
        sweep_stale(&dir)
            .with_context(|| format!("{}: removing stale temporary files", dir.display()))?;
    }

    let needs_stats = variants.iter().any(|(_, s)| s.retexture.is_some());
    let stats = if needs_stats || args.refresh_stats {
        let existing = if args.refresh_stats {
            None
        } else {
            data.read_material_stats().ok()
        };
        Some(match existing {
            Some(s) => s,
            None => {
                let (stats, failures) = {
                    let bar = ctx.progress(ids.len() as u64, "material stats");
                    collect_stats(&data, &ids, args.partition_seed, DEFAULT_FRACTIONS, &bar)
                };
                for (id, e) in &failures {
                    eprintln!("warning: scene {id}: left out of the material statistics: {e}");
                }
                let path = data.write_material_stats(&stats)?;
                let per_set = |set| stats.materials.iter().filter(|m| m.set == set).count();
                ctx.say(format!(
                    "material statistics of {} scenes: {} materials in {} categories \
                     (train {}, val {}, test {}) -> {}",
                    stats.scenes.len(),
                    stats.materials.len(),
                    stats.categories.len(),
                    per_set(TextureSet::Train),
                    per_set(TextureSet::Val),
                    per_set(TextureSet::Test),
                    path.display()
                ));
                stats
            }
        })
    } else {
        None
    };
    if needs_stats && stats.is_none() {
        bail!("{}: missing", data.material_stats_path().display());
    }

    let mut failed = 0;
    for (name, spec) in &variants {
        let reports = {
            let bar = ctx.progress(ids.len() as u64, name);
            dry_run(&data, &ids, name, spec, stats.as_ref(), &bar)
        };
        let (mut removed, mut swapped, mut cleared, mut redrawn, mut kept) = (0, 0, 0, 0, 0);
        for (id, r) in &reports {
            match r {
                Ok(r) => {
                    removed += r.removed;
                    swapped += r.doors.swapped;
                    cleared += r.doors.cleared;
                    if let Some(t) = r.retexture {
                        redrawn += t.redrawn;
                        kept += t.kept;
                    }
                    for w in &r.doors.unmatched {
                        tracing::warn!("variant {name}, scene {id}: {w}");
                    }
                }
                Err(e) => {
                    eprintln!("error: variant {name}, scene {id}: {e}");
                    failed += 1;
                }
            }
        }
        let path = data.write_variant(name, spec)?;
        let mut what = format!("{removed} objects removed");
        if spec.open_doors || !spec.doors.is_empty() {
            what += &format!(", {swapped} doors swapped, {cleared} doors cleared");
        }
        if spec.retexture.is_some() {
            what += &format!(", {redrawn} material slots redrawn, {kept} kept (no material of their category in the set)");
        }
        let bake = if spec.changes_geometry() {
            format!(
                "; bake it with `minos bake --data {} --variant {name}`",
                data.root().display()
            )
        } else {
            "; it keeps the geometry and shares its scenes' grids".to_string()
        };
        ctx.say(format!(
            "variant {name} over {} scenes: {what} -> {}{bake}",
            reports.len(),
            path.display()
        ));
    }
    minos::store::provenance::write_data_record(&data)?;
    Ok(if failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
