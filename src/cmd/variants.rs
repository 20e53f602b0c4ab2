//! `minos variants`: define named scene variants (from a spec file or flags), compute the
//! material statistics retexturing needs, and report what each variant does to the scenes.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context as _};
use minos::pipeline::variants::{define_variants, read_spec_file, VariantsError, VariantsJob};
use minos::scene::variants::{KeepOnly, Retexture, TextureSet, VariantSpec};
use minos::store::DataDir;

use super::common::vocab;
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
    #[arg(long, value_parser = vocab::<TextureSet>(), default_value = "train")]
    texture_set: TextureSet,
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

/// The variant the flags describe (its name and rules are checked by the driver).
fn from_flags(args: &Args) -> VariantSpec {
    VariantSpec {
        remove: args.remove.clone(),
        keep_only: KeepOnly::from_names(args.keep_only.clone()),
        empty: args.empty,
        hide: args.hide.clone(),
        open_doors: args.open_doors,
        doors: Default::default(),
        retexture: args.retexture_seed.map(|seed| Retexture {
            seed,
            texture_set: args.texture_set,
        }),
    }
}

/// Flags → the variants to define: read from `--spec FILE`, or one built from the flags.
pub fn config(args: &Args) -> anyhow::Result<Vec<(String, VariantSpec)>> {
    Ok(match (&args.spec, &args.name) {
        (Some(path), _) => read_spec_file(path).context("--spec")?,
        (None, Some(name)) => vec![(name.clone(), from_flags(args))],
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
    let job = VariantsJob {
        data,
        variants: config(&args)?,
        refresh_stats: args.refresh_stats,
        partition_seed: args.partition_seed,
    };
    let report = {
        let bar = ctx.progress(0, "variants");
        define_variants(&job, ctx.lock_mode, &bar).map_err(|e| match e {
            VariantsError::NoChange { .. } if args.spec.is_none() => anyhow::anyhow!(
                "{} (use --remove, --keep-only, --empty, --hide, --open-doors or --retexture-seed)",
                minos::escape::error_line(&e)
            ),
            e => e.into(),
        })?
    };
    if let Some(stats) = &report.stats {
        for (id, e) in &stats.left_out {
            eprintln!("warning: scene {id}: left out of the material statistics: {e}");
        }
        let [train, val, test] = stats.per_set;
        ctx.say(format!(
            "material statistics of {} scenes: {} materials in {} categories \
             (train {train}, val {val}, test {test}) -> {}",
            stats.scenes,
            stats.materials,
            stats.categories,
            stats.path.display()
        ));
    }
    for v in &report.variants {
        let name = &v.name;
        for (id, w) in &v.unmatched {
            tracing::warn!("variant {name}, scene {id}: {w}");
        }
        for (id, e) in &v.failures {
            eprintln!("error: variant {name}, scene {id}: {e}");
        }
        let mut what = format!("{} objects removed", v.removed);
        if v.changes_doors {
            what += &format!(", {} doors swapped, {} doors cleared", v.swapped, v.cleared);
        }
        if v.retextures {
            what += &format!(
                ", {} material slots redrawn, {} kept (no material of their category in the set)",
                v.redrawn, v.kept
            );
        }
        let bake = if v.changes_geometry {
            format!(
                "; bake it with `minos bake --data {} --variant {name}`",
                job.data.root().display()
            )
        } else {
            "; it keeps the geometry and shares its scenes' grids".to_string()
        };
        ctx.say(format!(
            "variant {name} over {} scenes: {what} -> {}{bake}",
            v.scenes,
            v.path.display()
        ));
    }
    Ok(if report.any_failed() {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}
