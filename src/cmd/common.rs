//! What every subcommand shares: verbosity, logging set-up and progress bars.

use indicatif::{ProgressBar, ProgressStyle};
use tracing_subscriber::EnvFilter;

/// Global settings every subcommand receives.
#[derive(Debug, Clone)]
pub struct Context {
    /// `-q`: print only errors.
    pub quiet: bool,
}

impl Context {
    /// Initialises tracing (RUST_LOG wins over -v/-q) and returns the context.
    pub fn new(quiet: bool, verbose: u8) -> Self {
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
            .with_target(false)
            .try_init();
        Context { quiet }
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

/// Turns scene ids into references to `variant` (`<scene>@<variant>`), after checking that the
/// variant is defined in `data`; without a variant the ids are returned unchanged.
pub fn with_variant(
    data: &std::path::Path,
    ids: Vec<String>,
    variant: Option<&str>,
) -> anyhow::Result<Vec<String>> {
    let Some(name) = variant else {
        return Ok(ids);
    };
    minos::io::variant_store::read_variant(data, name)
        .map_err(|e| anyhow::anyhow!("--variant {name}: {e}"))?;
    Ok(ids
        .into_iter()
        .map(|id| {
            minos::scene::variants::join_ref(minos::scene::variants::split_ref(&id).0, Some(name))
        })
        .collect())
}
