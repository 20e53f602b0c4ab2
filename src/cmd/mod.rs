//! Command-line front door: global flags, logging, the thread pool, and dispatch to one file
//! per subcommand. Commands parse and validate flags, call the library, and print results; they
//! hold no algorithms.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod bake;
mod bench;
mod campaign;
mod common;
mod demo;
mod diff;
mod episodes;
mod export;
mod export_dataset;
mod generate;
mod ingest;
mod merge;
mod nav;
mod range;
mod render;
mod run;
mod serve;
mod split;
mod stats;
mod variants;
mod verify;
mod view;

pub use common::Context;

/// minos turns indoor 3D scene datasets (SUNCG, Matterport3D, 3D-FRONT, glTF, or houses it
/// generates itself) into embodied-AI navigation data.
///
/// Start with `minos demo`, which generates houses, ingests, splits and summarises them into
/// ./minos-demo/. Every subcommand has its own --help with examples.
#[derive(Debug, Parser)]
#[command(name = "minos", version, about, long_about, propagate_version = true)]
struct Cli {
    /// Print only errors (no progress bars, no summaries).
    #[arg(short, long, global = true)]
    quiet: bool,
    /// More log output: -v info, -vv debug, -vvv trace (RUST_LOG overrides).
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,
    /// Worker threads for parallel work: 0 or unset means all cores (RAYON_NUM_THREADS
    /// overrides), at most 1024. Outputs never depend on it.
    #[arg(long, global = true, value_name = "N", value_parser = common::parse_threads)]
    threads: Option<usize>,
    /// When another minos process is writing the same DATA or output folder, wait for it to
    /// finish instead of failing at once with its pid.
    #[arg(long, global = true)]
    wait: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Generate procedural houses in a real dataset's on-disk format.
    Generate(generate::Args),
    /// Load scenes into compiled scenes and a Parquet manifest.
    Ingest(ingest::Args),
    /// Write train/val/test id lists, filtered by an expression.
    Split(split::Args),
    /// Print environment statistics of a DATA folder or one of its splits.
    Stats(stats::Args),
    /// Define scene variants: clutter removal, empty houses, open doors, retexturing.
    Variants(Box<variants::Args>),
    /// Bake navigation grids (walkable spans, islands, rooms) for ingested scenes.
    Bake(bake::Args),
    /// Navigation queries on baked grids (shortest paths, distances).
    Nav(nav::Args),
    /// Sample navigable PointGoal / ObjectGoal / RoomGoal episodes (or import episode files).
    Episodes(Box<episodes::Args>),
    /// Render what an agent's sensors see at a pose (one PNG per sensor).
    Render(render::Args),
    /// Roll out episodes with an agent into Parquet datasets and metrics (and rerun recordings).
    Run(run::Args),
    /// Export a compiled scene's world-space geometry as OBJ or GLB.
    Export(export::Args),
    /// Write a run as a dataset other tools load (LeRobot v3.0).
    ExportDataset(export_dataset::Args),
    /// Join the outputs of sharded `run` or `episodes` commands into one unsharded output.
    Merge(merge::Args),
    /// Record a scene, its navigation grid and episodes' shortest paths for the rerun viewer.
    View(view::Args),
    /// Serve a web page to explore scenes and record human demonstrations.
    Serve(serve::Args),
    /// Demonstration campaigns of `minos serve --campaign`: participant links.
    Campaign(campaign::Args),
    /// Run the whole pipeline on generated houses into ./minos-demo/.
    Demo(demo::Args),
    /// Measure bake, episode sampling, rendering or rollouts on one ingested scene.
    Bench(bench::Args),
    /// Check a run folder, LeRobot dataset, episode file or DATA folder: checksums, tables,
    /// indices, statistics, images, navigability.
    Verify(verify::Args),
    /// Compare two outputs and say where they first differ (episode, step, column, values).
    Diff(diff::Args),
}

/// Parses the command line, sets up logging and threads, and runs the subcommand.
pub fn main() -> ExitCode {
    // Before any thread starts (setting the environment later would race with readers):
    // keep the GPU adapter probe from printing libwayland's XDG_RUNTIME_DIR complaint.
    if let Some((name, value)) = minos::render::gpu::quiet_probe_env(std::env::var_os) {
        std::env::set_var(name, value);
    }
    let cli = Cli::parse();
    let ctx = Context::new(cli.quiet, cli.verbose, cli.wait);
    if let Some(n) = cli.threads {
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
        {
            eprintln!("error: --threads {n}: {e}");
            return ExitCode::FAILURE;
        }
    }
    let result = match cli.command {
        Command::Generate(a) => generate::run(a, &ctx),
        Command::Ingest(a) => ingest::run(a, &ctx),
        Command::Split(a) => split::run(a, &ctx),
        Command::Stats(a) => stats::run(a, &ctx),
        Command::Variants(a) => variants::run(*a, &ctx),
        Command::Bake(a) => bake::run(a, &ctx),
        Command::Nav(a) => nav::run(a, &ctx),
        Command::Episodes(a) => episodes::run(*a, &ctx),
        Command::Render(a) => render::run(a, &ctx),
        Command::Run(a) => run::run(a, &ctx),
        Command::Export(a) => export::run(a, &ctx),
        Command::ExportDataset(a) => export_dataset::run(a, &ctx),
        Command::Merge(a) => merge::run(a, &ctx),
        Command::View(a) => view::run(a, &ctx),
        Command::Serve(a) => serve::run(a, &ctx),
        Command::Campaign(a) => campaign::run(a, &ctx),
        Command::Demo(a) => demo::run(a, &ctx),
        Command::Bench(a) => bench::run(a, &ctx),
        Command::Verify(a) => verify::run(a, &ctx),
        Command::Diff(a) => diff::run(a, &ctx),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            let hint = minos::pipeline::rollout::body_mismatch_of(e.as_ref())
                .map(rebake_hint)
                .or_else(|| minos::store::remedy::remedy_of(e.as_ref()).map(remedy_hint))
                .unwrap_or_default();
            eprintln!("error: {}{hint}", one_line(&e));
            ExitCode::FAILURE
        }
    }
}

/// The step that fixes an error, as the command line spells it.
fn remedy_hint(r: minos::store::remedy::Remedy) -> String {
    use minos::store::remedy::Remedy;
    let what = match r {
        Remedy::Ingest => "run `minos ingest` first",
        Remedy::Reingest => "ingest it again: `minos ingest --force`",
        Remedy::Bake => "run `minos bake` first (`--variant NAME` for a variant's grids)",
        Remedy::Rebake => "rebake it: `minos bake --force` (`--variant NAME` for a variant's grid)",
        Remedy::DefineVariant => "define it with `minos variants --spec FILE`",
        Remedy::MaterialStats => "compute them with `minos variants --refresh-stats`",
        Remedy::Wait => "or pass --wait to wait for it",
    };
    format!(" ({what})")
}

/// How to rebake for the agent's body, as the command line spells it.
fn rebake_hint(b: minos::body::BodyMismatch) -> String {
    let agent = b.agent;
    let bake = match agent.preset() {
        Some(p) => format!("`minos bake --preset {} --force`", p.name()),
        None => format!(
            "`minos bake --config FILE --force` where FILE sets agent_radius = {}, \
             agent_height = {}, max_climb = {}",
            agent.radius, agent.height, agent.max_climb
        ),
    };
    format!(" (rebake with {bake}, or pass --allow-body-mismatch)")
}

/// The error and its causes on one line ([`minos::escape::error_line`]).
fn one_line(e: &anyhow::Error) -> String {
    minos::escape::error_line(e.as_ref())
}
