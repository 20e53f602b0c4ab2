//! What every subcommand shares: verbosity, logging set-up, progress bars, and the typed
//! flags several commands take (agent presets, renderers, sensor files, scene selections).

use std::path::Path;

use anyhow::Context as _;
use indicatif::{ProgressBar, ProgressStyle};
use minos::body::AgentPreset;
use minos::lock::LockMode;
use minos::render::RendererChoice;
use minos::sim::SensorSuite;
use minos::split::read_split;
use minos::store::DataDir;
use tracing_subscriber::EnvFilter;

/// Global settings every subcommand receives.
#[derive(Debug, Clone)]
pub struct Context {
    /// `-q`: print only errors.
    pub quiet: bool,
    /// `--wait`: wait for another writer of the same folder instead of failing.
    pub lock_mode: LockMode,
}

impl Context {
    /// Initialises tracing (RUST_LOG wins over -v/-q) and returns the context.
    pub fn new(quiet: bool, verbose: u8, wait: bool) -> Self {
        let default = match (quiet, verbose) {
            (true, _) => "error",
            (false, 0) => "warn",
            (false, 1) => "info",
            (false, 2) => "debug",
            _ => "trace",
        };
        let filter = EnvFilter::try_from_default_env()
            .unwrap_or_else(|_| EnvFilter::new(format!("minos={default},{}", "warn")));
        let _ = tracing_subscriber::fmt()
            .with_env_filter(filter)
            .with_writer(std::io::stderr)
            .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
            .with_target(false)
            .try_init();
        let lock_mode = if wait { LockMode::Wait } else { LockMode::Fail };
        Context { quiet, lock_mode }
    }

    /// A progress bar over `total` items (hidden with -q or when stderr is not a terminal).
    pub fn progress(&self, total: u64, what: &str) -> Bar {
        let bar = if self.quiet {
            ProgressBar::hidden()
        } else {
            ProgressBar::new(total)
        };
        bar.set_style(
            ProgressStyle::with_template(
                "{prefix:>10} [{bar:30}] {pos}/{len} {per_sec} eta {eta} {msg}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        bar.set_prefix(what.to_string());
        Bar(bar)
    }

    /// Prints a line to stdout unless -q.
    pub fn say(&self, line: impl AsRef<str>) {
        if !self.quiet {
            println!("{}", line.as_ref());
        }
    }
}

/// An indicatif bar that the library reports to through [`minos::progress::Progress`].
pub struct Bar(pub ProgressBar);

impl minos::progress::Progress for Bar {
    fn set_total(&self, total: u64) {
        self.0.set_length(total);
    }
    fn advance(&self, n: u64) {
        self.0.inc(n);
    }
}

impl Drop for Bar {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}

/// Agent presets of `--preset` (one vocabulary for every command; see
/// [`minos::body::AgentPreset`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum PresetArg {
    /// Habitat's agent: 1.5 m body, 0.25 m steps, 10° turns.
    #[default]
    Habitat,
    /// MINOS's continuous agent: 1.19 m body, forces and friction.
    #[value(alias = "minos-continuous")]
    Minos,
    /// MINOS's gridworld agent: 1.19 m body, 0.4 m steps, 90° turns.
    MinosGridworld,
    /// The MINOS paper's agent: MINOS's continuous agent with forward / turn left / turn
    /// right only, 0.4 m PointGoal radius, grey 90° camera (with depth and semantic).
    MinosPaper,
}

impl From<PresetArg> for AgentPreset {
    fn from(p: PresetArg) -> Self {
        match p {
            PresetArg::Habitat => AgentPreset::Habitat,
            PresetArg::Minos => AgentPreset::Minos,
            PresetArg::MinosGridworld => AgentPreset::MinosGridworld,
            PresetArg::MinosPaper => AgentPreset::MinosPaper,
        }
    }
}

/// Renderers of `--renderer`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RendererArg {
    /// wgpu when a hardware GPU adapter exists, else the CPU renderer (the log says why).
    Auto,
    /// The built-in CPU rasteriser.
    Cpu,
    /// wgpu (fails without an adapter).
    Wgpu,
}

impl From<RendererArg> for RendererChoice {
    fn from(r: RendererArg) -> Self {
        match r {
            RendererArg::Auto => RendererChoice::Auto,
            RendererArg::Cpu => RendererChoice::Cpu,
            RendererArg::Wgpu => RendererChoice::Wgpu,
        }
    }
}

/// The most worker threads `--threads` accepts: far above any machine's cores, low enough
/// that a typo (`--threads 80000`) is refused instead of exhausting the system.
pub const MAX_THREADS: usize = 1024;

/// Parses a thread count: `0` means all cores (rayon's default), more than [`MAX_THREADS`]
/// is refused.
pub fn parse_threads(s: &str) -> Result<usize, String> {
    let n: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a thread count (0 = all cores)"))?;
    if n > MAX_THREADS {
        return Err(format!(
            "{n} threads is more than the {MAX_THREADS} allowed (0 = all cores)"
        ));
    }
    Ok(n)
}

/// Reads a sensor file (TOML or JSON), or MINOS's default suite when none is named.
pub fn sensor_suite(
    file: Option<&Path>,
    default: impl FnOnce() -> SensorSuite,
) -> anyhow::Result<SensorSuite> {
    match file {
        Some(p) => {
            let text = std::fs::read_to_string(p).with_context(|| p.display().to_string())?;
            if text.trim().is_empty() {
                anyhow::bail!(
                    "{}: the sensor file is empty (it needs at least one [[cameras]] table)",
                    p.display()
                );
            }
            SensorSuite::parse(&text, &p.display().to_string()).map_err(anyhow::Error::msg)
        }
        None => Ok(default()),
    }
}

/// Writes `DATA/provenance.json`, the DATA folder's provenance record: the minos that last
/// wrote it and the sha256 of every file the folder holds (no command line, time or host: the
/// same DATA gives the same record). `ingest`, `bake`, `split` and `variants` rewrite it when
/// they finish.
pub fn write_data_provenance(data: &DataDir) -> anyhow::Result<()> {
    use minos::provenance;
    let files = provenance::checksums(data.root(), &["provenance.json"])?;
    let record = serde_json::json!({
        "format": provenance::FORMAT,
        "kind": "data",
        "minos": provenance::MINOS,
        "files": files,
    });
    provenance::write_record(&data.root().join("provenance.json"), &record)?;
    Ok(())
}

/// The scenes of split `name` (all subsets, sorted, distinct), or every ingested scene.
pub fn split_or_all(data: &DataDir, split: Option<&str>) -> anyhow::Result<Vec<String>> {
    Ok(match split {
        Some(name) => {
            let lists = read_split(data, name).with_context(|| format!("--split {name}"))?;
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
        None => data.ingested_ids()?,
    })
}

/// Parses `line` (white-space separated) as the flags of a subcommand whose arguments are `A`,
/// for the unit tests of each command's `config`.
#[cfg(test)]
pub fn parse_flags<A: clap::Args + clap::FromArgMatches>(line: &str) -> Result<A, clap::Error> {
    let command = A::augment_args(clap::Command::new("minos"));
    let matches =
        command.try_get_matches_from(std::iter::once("minos").chain(line.split_whitespace()))?;
    A::from_arg_matches(&matches)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thread_counts_zero_means_all_cores_and_absurd_counts_are_refused() {
        assert_eq!(parse_threads("0"), Ok(0));
        assert_eq!(parse_threads("8"), Ok(8));
        assert_eq!(parse_threads(&MAX_THREADS.to_string()), Ok(MAX_THREADS));
        let too_many = parse_threads("80000").unwrap_err();
        assert!(
            too_many.contains("80000") && too_many.contains("1024"),
            "{too_many}"
        );
        assert!(parse_threads("-1").unwrap_err().contains("`-1`"));
        assert!(parse_threads("many").is_err());
    }
}
