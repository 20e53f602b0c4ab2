//! `minos view`: flags → [`ViewConfig`] ([`config`]) → [`minos::pipeline::view::write_view`]; prints what was recorded.

use std::path::PathBuf;
use std::process::ExitCode;

use minos::episode::format::read_episodes;
use minos::pipeline::view::{write_view, ViewConfig};
use minos::scene::SceneRef;
use minos::store::DataDir;

use super::Context;

const AFTER_HELP: &str = "\
The recording holds the scene mesh in material colours (world/scene/mesh, ceilings left out)
and by NYU-40 class (semantic/mesh, a 3D view of its own), the walkable spans of the
navigation grid coloured by room class (world/nav/walkable), each level's grid preview
(nav/L<level>), and for each episode of the scene in --episodes its start (green), goals (red)
and shortest path (yellow) under world/episodes/<episode id>. Open it with the rerun viewer
(`pip install rerun-sdk==0.36.*`, then `rerun FILE.rrd`).

Examples:
  minos view --data minos-demo/data --scene gen_000 --out gen_000.rrd
  minos view --data DATA --scene gen_000 --episodes eps/pointgoal.parquet --out gen_000.rrd";

/// Flags of `minos view`.
#[derive(Debug, clap::Args)]
#[command(after_help = AFTER_HELP)]
pub struct Args {
    /// DATA folder (ingested and baked).
    #[arg(long, value_name = "DATA")]
    data: PathBuf,
    /// Id of the scene to record (`<scene>@<variant>` for a variant).
    #[arg(long, value_name = "ID")]
    scene: SceneRef,
    /// Episode file from `minos episodes`: draws the scene's episodes with their shortest
    /// paths.
    #[arg(long, value_name = "FILE")]
    episodes: Option<PathBuf>,
    /// The .rrd file to write (replaced atomically).
    #[arg(long, value_name = "FILE.rrd")]
    out: PathBuf,
}

/// Flags → what to record.
pub fn config(args: &Args) -> ViewConfig {
    ViewConfig {
        data: DataDir::new(&args.data),
        scene: args.scene.clone(),
        out: args.out.clone(),
    }
}

/// Runs `minos view`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let episodes = match &args.episodes {
        Some(p) => read_episodes(p)?,
        None => Vec::new(),
    };
    let cfg = config(&args);
    let report = write_view(&cfg, &episodes)?;
    if args.episodes.is_some() && report.episodes == 0 {
        tracing::warn!("no episode of scene {} in the episode file", args.scene);
    }
    ctx.say(format!(
        "{} triangles, {} walkable spans, {} episodes ({} unreachable) -> {} (open with `rerun {}`)",
        report.triangles,
        report.walkable,
        report.episodes,
        report.unreachable,
        args.out.display(),
        args.out.display()
    ));
    Ok(ExitCode::SUCCESS)
}
