//! `minos bake`: flags → [`minos::navmesh::bake::BakeConfig`], then a summary and one line
//! per failed scene.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context as _;
use minos::io::manifest::read_manifest;
use minos::navmesh::bake::{bake_scenes, params_from_toml, BakeConfig, BakeOutcome};
use minos::navmesh::NavParams;
use minos::split::read_split;

use super::common::with_variant;
use super::Context;

/// Bake navigation grids: walkable floor spans for a cylinder agent, islands, rooms and
/// objects per span, written to DATA/nav/<scene>.nav with a PNG preview per level.
///
/// Walkable space is a multi-layer 2.5D grid built by voxelising the scene's triangles: a span
/// is walkable where the floor is within the slope limit, the agent's cylinder fits above it
/// and stays `agent_radius` from obstacles; neighbouring spans connect when their heights
/// differ by at most `max_climb`, so stairs join levels. Grids newer than their scene and
/// baked with the same parameters are kept (use --force).
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Parameters (TOML keys of --config; defaults are minos's):\n  \
    cell_size 0.05, agent_radius 0.1, agent_height 1.19, max_climb 0.2, max_slope_deg 45,\n  \
    clearance_margin 0.2, clearance_weight 1 (MINOS used 10: paths keep off walls, geodesics\n  \
    are no longer exact). A config may start from a preset: preset = \"minos\".\n\n\
    Examples:\n  minos bake --data DATA\n  minos bake --data DATA --split multiroom --preset minos\n  \
    minos bake --data DATA --config nav.toml --force\n  minos bake --data DATA --variant empty"
)]
pub struct Args {
    /// DATA folder made by `minos ingest`.
    #[arg(long)]
    data: PathBuf,
    /// Bake only the scenes of this split (all subsets); default: every ingested scene.
    #[arg(long, value_name = "NAME")]
    split: Option<String>,
    /// Parameter preset: default (5 cm cells), minos (10 cm cells, MINOS parity), habitat
    /// (agent height 1.5 m).
    #[arg(long, default_value = "default", value_parser = ["default", "minos", "habitat"])]
    preset: String,
    /// TOML file of parameters (overrides the preset), e.g. `cell_size = 0.1`.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Bake this variant of every selected scene (defined with `minos variants`); grids go to
    /// DATA/nav/<scene>@<variant>.nav.
    #[arg(long, value_name = "NAME")]
    variant: Option<String>,
    /// Rebake every scene.
    #[arg(long)]
    force: bool,
    /// Skip the PNG previews.
    #[arg(long)]
    no_preview: bool,
}

/// Runs `minos bake`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let mut params = NavParams::preset(&args.preset).context("--preset")?;
    if let Some(path) = &args.config {
        let text = std::fs::read_to_string(path).with_context(|| format!("{}", path.display()))?;
        params = params_from_toml(&text, params)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    }
    let ids: Vec<String> = match &args.split {
        Some(name) => {
            let lists = read_split(&args.data, name).with_context(|| format!("--split {name}"))?;
            let mut ids: Vec<String> = lists
                .train
                .into_iter()
                .chain(lists.val)
                .chain(lists.test)
                .collect();
            ids.sort();
            ids.dedup();
            ids
        }
        None => read_manifest(&args.data.join("houses.parquet"))
            .context("cannot read the manifest (run `minos ingest` first)")?
            .into_iter()
            .filter(|r| r.error.is_none())
            .map(|r| r.id)
            .collect(),
    };
    let ids = with_variant(&args.data, ids, args.variant.as_deref())?;
    let start = Instant::now();
    let cfg = BakeConfig {
        data: args.data.clone(),
        ids,
        params,
        force: args.force,
        previews: !args.no_preview,
    };
    let report = {
        let bar = ctx.progress(cfg.ids.len() as u64, "bake");
        bake_scenes(&cfg, &bar)
    };
    let mut failed = 0;
    for (id, e) in report.failures() {
        eprintln!("error: scene {id}: {e}");
        failed += 1;
    }
    let baked = report
        .scenes
        .iter()
        .filter(|(_, o)| matches!(o, BakeOutcome::Baked { .. }))
        .count();
    ctx.say(format!(
        "baked {} scenes in {:.2} s: {baked} baked, {} up to date, {failed} failed -> {}",
        report.scenes.len(),
        start.elapsed().as_secs_f64(),
        report.scenes.len() - baked - failed,
        args.data.join("nav").display()
    ));
    Ok(if failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
