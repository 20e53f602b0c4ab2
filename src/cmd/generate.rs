//! `minos generate` (not written yet).

use std::process::ExitCode;

use super::Context;

/// Flags of `minos generate`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args, _ctx: &Context) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`minos generate` is not implemented yet")
}
