//! `minos bake`: flags → [`BakeConfig`] ([`config`]), then [`minos::pipeline::bake`] and a
//! summary with one line per failed scene.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context as _;
use minos::body::AgentPreset;
use minos::navmesh::NavParams;
use minos::pipeline::bake::{bake, grid_params, BakeConfig, BakeOutcome, GridParamsError};
use minos::shard::ShardSpec;
use minos::store::DataDir;

use super::common::{split_or_all, vocab};
use super::Context;

/// Bake navigation grids: walkable floor spans for a cylinder agent, islands, rooms and
/// objects per span, written to DATA/nav/<scene>.nav with a PNG preview per level.
///
/// Walkable space is a multi-layer 2.5D grid built by voxelising the scene's triangles: a span
/// is walkable where the floor is within the slope limit, the agent's cylinder fits above it
/// and stays `agent_radius` from obstacles; neighbouring spans connect when their heights
/// differ by at most `max_climb`, so stairs join levels. Grids newer than their scene and
/// baked with the same parameters are kept (use --force). A grid serves one agent body:
/// `episodes`, `render` and `run` refuse a grid baked for another body than their --preset.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Parameters (TOML keys of --config; defaults are the habitat preset's):\n  \
    cell_size 0.05, agent_radius 0.1, agent_height 1.5, max_climb 0.2, max_slope_deg 45,\n  \
    clearance_margin 0.2, clearance_weight 1 (MINOS used 10: paths keep off walls, geodesics\n  \
    are no longer exact). A config may start from an agent preset: preset = \"minos\".\n\n\
    Examples:\n  minos bake --data DATA\n  minos bake --data DATA --split multiroom --preset minos --cell-size 0.1\n  \
    minos bake --data DATA --config nav.toml --force\n  minos bake --data DATA --variant empty"
)]
pub struct Args {
    /// DATA folder made by `minos ingest`.
    #[arg(long)]
    data: PathBuf,
    /// Bake only the scenes of this split (all subsets); default: every ingested scene.
    #[arg(long, value_name = "NAME")]
    split: Option<String>,
    /// Agent preset whose body the grids are for: habitat (1.5 m), minos, minos-gridworld or
    /// minos-paper (MINOS's 1.19 m body).
    #[arg(long, value_parser = vocab::<AgentPreset>(), default_value = "habitat")]
    preset: AgentPreset,
    /// Cell edge in metres (MINOS used 0.1).
    #[arg(long, value_name = "M")]
    cell_size: Option<f32>,
    /// TOML file of parameters (overrides --preset and --cell-size), e.g. `cell_size = 0.1`.
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
    /// Every n-th scene (sorted by name): i/n, or `auto` from the scheduler (Slurm array,
    /// Kubernetes Indexed Job with MINOS_SHARD_COUNT, or MINOS_SHARD=i/n). Shards may bake
    /// one DATA folder at once, from one machine or many sharing it.
    #[arg(long, value_parser = ShardSpec::parse, default_value = "0/1")]
    shard: ShardSpec,
}

/// The grid parameters the flags ask for (reads the `--config` file, if any).
fn params(args: &Args) -> anyhow::Result<NavParams> {
    grid_params(args.preset, args.cell_size, args.config.as_deref()).map_err(|e| match e {
        GridParamsError::CellSize(source) => anyhow::Error::new(source).context("--cell-size"),
        other => other.into(),
    })
}

/// Flags → the library's configuration: parameters, and the scenes of the split (or every
/// ingested scene) on the chosen variant.
pub fn config(args: &Args) -> anyhow::Result<BakeConfig> {
    let data = DataDir::new(&args.data);
    let ids = split_or_all(&data, args.split.as_deref())?;
    let scenes = data
        .refs(&ids, args.variant.as_deref())
        .with_context(|| format!("--variant {}", args.variant.as_deref().unwrap_or_default()))?;
    Ok(BakeConfig {
        params: params(args)?,
        scenes,
        data,
        force: args.force,
        previews: !args.no_preview,
    })
}

/// Runs `minos bake`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let cfg = config(&args)?;
    let shard = args
        .shard
        .resolve(|k| std::env::var(k).ok())
        .map_err(anyhow::Error::msg)?;
    let start = Instant::now();
    let report = {
        let bar = ctx.progress(cfg.scenes.len() as u64, "bake");
        bake(&cfg, shard, ctx.lock_mode, &bar)?
    };
    if let Some(e) = report.write_failure() {
        return Err(e.clone().into());
    }
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
        cfg.data.nav_dir().display()
    ));
    // Grids for another body were replaced: what was made on them was for that body.
    let mut replaced: std::collections::BTreeMap<String, Vec<&str>> = Default::default();
    for (id, body) in report.replaced_bodies() {
        replaced.entry(body.to_string()).or_default().push(id);
    }
    for (body, ids) in &replaced {
        eprintln!(
            "warning: replaced {} grids baked for another body ({body}) with grids for {}: {}; \
             episode files sampled on the old grids are for that body (resample them)",
            ids.len(),
            cfg.params.body,
            ids.join(", ")
        );
    }
    Ok(if failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::common::parse_flags;
    use minos::body::AgentBody;

    fn args(line: &str) -> Args {
        parse_flags::<Args>(line).expect("flags parse")
    }

    #[test]
    fn presets_choose_the_body_and_flags_the_cells() {
        let p = params(&args("--data D")).unwrap();
        assert_eq!(p.body, AgentBody::HABITAT);
        assert_eq!(p.cell_size, 0.05);
        let p = params(&args("--data D --preset minos --cell-size 0.1")).unwrap();
        assert_eq!(p.body, AgentBody::MINOS);
        assert_eq!(p.cell_size, 0.1);
        let p = params(&args("--data D --preset minos-continuous")).unwrap();
        assert_eq!(p.body, AgentBody::MINOS);
        assert!(params(&args("--data D --cell-size=-1")).is_err());
        assert!(parse_flags::<Args>("--data D --preset default").is_err());
    }

    #[test]
    fn a_config_file_overrides_the_flags() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("nav.toml");
        std::fs::write(&file, "preset = \"minos\"\ncell_size = 0.08\n").unwrap();
        let line = format!("--data D --cell-size 0.1 --config {}", file.display());
        let p = params(&args(&line)).unwrap();
        assert_eq!((p.body, p.cell_size), (AgentBody::MINOS, 0.08));
    }
}
