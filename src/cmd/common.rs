//! What every subcommand shares: verbosity, logging set-up, progress bars, and the typed
//! flags several commands take (agent presets, renderers, sensor files, scene selections).

use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};
use minos::io::lerobot::video::{VideoSettings, DEFAULT_QP, MAX_QP};
use minos::lock::LockMode;
use minos::pipeline::split::{scenes_of, ScenesError};
use minos::sim::{SensorSuite, SuiteName};
use minos::store::DataDir;
use minos::vocab::Vocabulary;
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
        let lock_mode = LockMode::waiting_if(wait);
        Context { quiet, lock_mode }
    }

    /// Progress over `total` items: an indicatif bar on a terminal; when stderr is not a
    /// terminal (a Slurm or nohup log), a plain line every [`log_interval`] seconds and, after such lines, one
    /// when the work ends; nothing with -q.
    pub fn progress(&self, total: u64, what: &str) -> Bar {
        if self.quiet {
            return Bar(Shown::Hidden);
        }
        if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            return Bar(Shown::Log(LogLines::new(what, total, log_interval())));
        }
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template(
                "{prefix:>10} [{bar:30}] {pos}/{len} {per_sec} eta {eta} {msg}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        bar.set_prefix(what.to_string());
        Bar(Shown::Bar(bar))
    }

    /// Prints a line to stdout unless -q.
    pub fn say(&self, line: impl AsRef<str>) {
        if !self.quiet {
            println!("{}", line.as_ref());
        }
    }
}

/// Progress the library reports to through [`minos::progress::Progress`], shown as the
/// terminal allows.
pub struct Bar(Shown);

/// How a [`Bar`] shows progress.
enum Shown {
    /// -q: not at all.
    Hidden,
    /// On a terminal: an indicatif bar.
    Bar(ProgressBar),
    /// In a log: plain lines.
    Log(LogLines),
}

impl minos::progress::Progress for Bar {
    fn set_total(&self, total: u64) {
        match &self.0 {
            Shown::Hidden => {}
            Shown::Bar(bar) => bar.set_length(total),
            Shown::Log(lines) => lines.total.store(total, Ordering::Relaxed),
        }
    }
    fn advance(&self, n: u64) {
        match &self.0 {
            Shown::Hidden => {}
            Shown::Bar(bar) => bar.inc(n),
            Shown::Log(lines) => lines.advance(n),
        }
    }
}

impl Drop for Bar {
    fn drop(&mut self) {
        match &self.0 {
            Shown::Hidden => {}
            Shown::Bar(bar) => bar.finish_and_clear(),
            Shown::Log(lines) => lines.finish(),
        }
    }
}

/// Seconds between progress lines in a log: `MINOS_PROGRESS_SECONDS`, else 10.
fn log_interval() -> Duration {
    let seconds = std::env::var("MINOS_PROGRESS_SECONDS")
        .ok()
        .and_then(|s| s.trim().parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s >= 0.0)
        .unwrap_or(10.0);
    Duration::from_secs_f64(seconds)
}

/// Progress written as plain lines to stderr, for logs that cannot show a bar:
/// `run: 120/400 (30%), 12.5/s, 22 s left` at most once per interval, and, when there was
/// such a line, a last one with the total and the time taken.
struct LogLines {
    /// What is counted (`run`, `bake`, …).
    what: String,
    total: AtomicU64,
    done: AtomicU64,
    start: Instant,
    interval: Duration,
    /// When the last line was written and the count it showed (None: not yet).
    last: Mutex<Option<(Instant, u64)>>,
}

impl LogLines {
    fn new(what: &str, total: u64, interval: Duration) -> Self {
        LogLines {
            what: what.to_string(),
            total: AtomicU64::new(total),
            done: AtomicU64::new(0),
            start: Instant::now(),
            interval,
            last: Mutex::new(None),
        }
    }

    fn advance(&self, n: u64) {
        self.done.fetch_add(n, Ordering::Relaxed);
        let Ok(mut last) = self.last.lock() else {
            return;
        };
        // Read under the lock, so that lines from several threads count up.
        let done = self.done.load(Ordering::Relaxed);
        let now = Instant::now();
        let due = match *last {
            None => now.duration_since(self.start) >= self.interval,
            Some((at, shown)) => done > shown && now.duration_since(at) >= self.interval,
        };
        if due {
            *last = Some((now, done));
            eprintln!("{}", self.line(done, now));
        }
    }

    /// `what: done/total (p%), r/s, s left`.
    fn line(&self, done: u64, now: Instant) -> String {
        let total = self.total.load(Ordering::Relaxed);
        let seconds = now.duration_since(self.start).as_secs_f64();
        let rate = if seconds > 0.0 {
            done as f64 / seconds
        } else {
            0.0
        };
        let mut line = format!("{}: {done}", self.what);
        if total > 0 {
            line.push_str(&format!(
                "/{total} ({:.0}%)",
                100.0 * done as f64 / total as f64
            ));
        }
        line.push_str(&format!(", {rate:.1}/s"));
        if total > done && rate > 0.0 {
            line.push_str(&format!(", {:.0} s left", (total - done) as f64 / rate));
        }
        line
    }

    /// The last line, after work long enough to have shown a line (short work, and a
    /// command that fails early, write nothing but their own lines).
    fn finish(&self) {
        let shown = self.last.lock().map(|l| l.is_some()).unwrap_or(false);
        if !shown {
            return;
        }
        let done = self.done.load(Ordering::Relaxed);
        let seconds = self.start.elapsed().as_secs_f64();
        eprintln!("{}: {done} done in {seconds:.1} s", self.what);
    }
}

/// The value parser of a flag whose values are the library vocabulary `T`'s names (and
/// aliases), each with its help line: the one place the command line learns them.
pub fn vocab<T>() -> impl clap::builder::TypedValueParser<Value = T>
where
    T: Vocabulary + Clone + Send + Sync,
{
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser as _};
    let values = T::TERMS.iter().map(|t| {
        PossibleValue::new(t.name)
            .help(t.help)
            .aliases(t.aliases.iter().copied())
    });
    PossibleValuesParser::new(values).try_map(|name: String| T::parse_name(&name))
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

/// The help of `--sensors`: a sensor file or one of the library's suites (named from its
/// vocabulary, so a new suite shows up here), then what the command renders without it.
pub fn sensors_help(default: &str) -> String {
    format!(
        "Sensor file (TOML or JSON) or suite ({}); default: {default}",
        SuiteName::names().join(", ")
    )
}

/// `--sensors NAME|FILE` ([`SensorSuite::from_spec`] at `size`²), or `default` when not given.
pub fn sensor_suite(
    spec: Option<&Path>,
    size: u32,
    default: impl FnOnce() -> SensorSuite,
) -> anyhow::Result<SensorSuite> {
    match spec {
        Some(p) => Ok(SensorSuite::from_spec(p, size)?),
        None => Ok(default()),
    }
}

/// The scenes of split `name` (all subsets, sorted, distinct), or every ingested scene; a
/// split that cannot be read is blamed on `--split`.
pub fn split_or_all(data: &DataDir, split: Option<&str>) -> anyhow::Result<Vec<String>> {
    scenes_of(data, split).map_err(|e| match e {
        // The flag (or keyword) in place of the library's "split `NAME`".
        ScenesError::Split { name, source } => {
            anyhow::Error::new(source).context(format!("--split {name}"))
        }
        other => other.into(),
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

/// `--video-qp`, beside a command's `--video` flag (`minos run`, `minos export-dataset`).
#[derive(Debug, Clone, clap::Args)]
pub struct VideoQp {
    /// With --video: H.264's quantiser, the same for every frame, 0–51 (lower: larger files,
    /// closer to the raw frames). On 84² rendered rooms 26 decodes at ≈ 38.5 dB mean PSNR and
    /// 38 at ≈ 31.7 dB in 42 % of the video bytes (docs/PERFORMANCE.md).
    #[arg(long, value_name = "QP", requires = "video", default_value_t = DEFAULT_QP,
          value_parser = clap::value_parser!(u8).range(0..=i64::from(MAX_QP)))]
    video_qp: u8,
}

impl VideoQp {
    /// The video settings when `video` (the command's `--video`) asks for video.
    pub fn settings(&self, video: bool) -> Option<VideoSettings> {
        video.then_some(VideoSettings { qp: self.video_qp })
    }
}
