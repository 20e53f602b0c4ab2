//! `minos campaign`: the tools around a `minos serve --campaign` study. `links` mints
//! participant links (tokens stored in the campaign's state folder, never on a command
//! line) and prints them.

use std::path::PathBuf;
use std::process::ExitCode;

use minos::serve::campaign::links::{mint, PARTICIPANTS};
use minos::serve::campaign::CampaignSpec;

use super::Context;

/// What `minos campaign` does.
#[derive(Debug, clap::Subcommand)]
pub enum Action {
    /// Mint participant links: N new participants with their own tokens, added to
    /// STATE/participants.json (owner-only) and printed as `<id>\t<link>`.
    Links(LinksArgs),
}

/// Flags of `minos campaign`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    action: Action,
}

/// Flags of `minos campaign links`.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Example:\n  minos campaign links --campaign study.toml --count 50 \
    --base-url https://lab.example.org:8080 > links.tsv"
)]
pub struct LinksArgs {
    /// The campaign file.
    #[arg(long, value_name = "FILE")]
    campaign: PathBuf,
    /// Participants to add.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=100_000))]
    count: u32,
    /// Where participants reach the server (the links are BASE/?participant=TOKEN).
    #[arg(long, value_name = "URL", default_value = "http://127.0.0.1:8080")]
    base_url: String,
}

/// A participant's link.
fn link(base: &str, token: &str) -> String {
    format!("{}/?participant={token}", base.trim_end_matches('/'))
}

/// Runs `minos campaign`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    match args.action {
        Action::Links(a) => {
            let spec = CampaignSpec::read(&a.campaign)?;
            let new = mint(&spec.state, a.count as usize)?;
            for p in &new {
                println!("{}\t{}", p.id, link(&a.base_url, &p.token));
            }
            // On stderr: stdout is the links alone (`> links.tsv`).
            if !ctx.quiet {
                eprintln!(
                    "{} participant link(s) added to {}",
                    new.len(),
                    spec.state.join(PARTICIPANTS).display()
                );
            }
            Ok(ExitCode::SUCCESS)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_join_the_base_and_the_token() {
        assert_eq!(link("http://h:1/", "ab"), "http://h:1/?participant=ab");
        assert_eq!(link("http://h:1", "ab"), "http://h:1/?participant=ab");
    }
}
