//! `minos verify PATH`: checks an output minos wrote — a run folder, a LeRobot export, an
//! episode file with its provenance sidecar, or a DATA folder — and reports every problem as
//! one line naming the file, the record and what is wrong.
//!
//! What is checked, by kind (one file per kind):
//!
//! - every kind: the sha256 and size of each file its provenance record lists, files missing
//!   and files the record does not list (`checksums.rs`);
//! - run folders (`run.rs`): episode and step continuity of the trajectory table, the
//!   observation table's rows against it and every image cell decoding with its column's
//!   declared shape, the episode table's steps and success against the trajectories,
//!   `metrics.json`'s episodes, and the LeRobot copy in `lerobot/` when there is one;
//! - LeRobot exports (`lerobot.rs`): the data files' schema against `info.json`'s features,
//!   `index`, `episode_index`, `frame_index` and `timestamp` continuity, episode boundaries
//!   against `meta/episodes`, the totals, every image decoding with its declared shape, and
//!   the statistics recomputed from the frames (per episode exactly, and `stats.json` as
//!   LeRobot aggregates them); video features (`video.rs`): every MP4 file decoded frame by
//!   frame at the declared size, frame times, episode places and key frames, and each
//!   episode's mean colour against its decoded frames;
//! - episode files (`episodes.rs`): the file decodes, and with a DATA folder every start and
//!   goal lies on its scene's baked grid and the stored geodesic distance re-computes within
//!   [`GEODESIC_TOLERANCE`];
//! - DATA folders (`data.rs`): the manifest, compiled scene headers and navigation grids read.

mod checksums;
mod data;
mod episodes;
mod lerobot;
mod run;
mod tables;
mod video;

use crate::file_error::FileError;
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use crate::progress::Progress;

pub use episodes::GEODESIC_TOLERANCE;

/// At most this many problems are listed per file; the rest are counted in one more line.
pub const MAX_PROBLEMS_PER_FILE: usize = 20;

/// One problem: the file, the record in it (`row 12 (episode `h1:pointgoal:3` step 4)`,
/// `checksum`, `column \`step\``) and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Problem {
    /// The file (under the checked path).
    pub file: PathBuf,
    /// The record.
    pub record: String,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let line = format!("{}: {}: {}", self.file.display(), self.record, self.message);
        f.write_str(&crate::escape::escape_controls(&line))
    }
}

/// The kinds of output `verify` knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    /// A `minos run --out DIR` folder (`manifest.json`, the run tables).
    Run,
    /// A LeRobot v3.0 dataset (`meta/info.json`).
    Lerobot,
    /// An episode file (`FILE.parquet`, with `FILE.parquet.provenance.json`).
    Episodes,
    /// A DATA folder (`houses.parquet`).
    Data,
}

impl OutputKind {
    /// How the report names it.
    pub fn name(self) -> &'static str {
        match self {
            OutputKind::Run => "run folder",
            OutputKind::Lerobot => "LeRobot dataset",
            OutputKind::Episodes => "episode file",
            OutputKind::Data => "DATA folder",
        }
    }
}

/// What to check beyond the output itself.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct VerifyOptions {
    /// The DATA folder an episode file's scenes were baked in: starts, goals and geodesic
    /// distances are checked against its grids.
    pub data: Option<PathBuf>,
}

/// What `verify` found.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// The output's kind.
    pub kind: OutputKind,
    /// Every problem, grouped by file in the order checked.
    pub problems: Vec<Problem>,
    /// Files whose checksum was compared.
    pub files: usize,
    /// Their bytes.
    pub bytes: u64,
    /// What else was checked, in words (`12 episodes, 340 frames`).
    pub checked: Vec<String>,
}

impl Report {
    /// True when nothing is wrong.
    pub fn is_clean(&self) -> bool {
        self.problems.is_empty()
    }

    /// The one-line summary of a clean (or not) output.
    pub fn summary(&self) -> String {
        let mut parts = vec![format!(
            "{} files ({}) match their checksums",
            self.files,
            human_bytes(self.bytes)
        )];
        parts.extend(self.checked.iter().cloned());
        if self.is_clean() {
            format!("ok: {}: {}", self.kind.name(), parts.join("; "))
        } else {
            format!(
                "{} problem{} in this {}",
                self.problems.len(),
                if self.problems.len() == 1 { "" } else { "s" },
                self.kind.name()
            )
        }
    }
}

fn human_bytes(n: u64) -> String {
    match n {
        n if n >= 1 << 30 => format!("{:.1} GiB", n as f64 / (1u64 << 30) as f64),
        n if n >= 1 << 20 => format!("{:.1} MiB", n as f64 / (1u64 << 20) as f64),
        n if n >= 1 << 10 => format!("{:.1} KiB", n as f64 / 1024.0),
        n => format!("{n} bytes"),
    }
}

/// Why nothing could be checked.
#[derive(Debug, thiserror::Error)]
pub enum VerifyError {
    /// The path is none of the outputs `verify` knows.
    #[error(
        "{}: not a minos output (no manifest.json with trajectories.parquet, meta/info.json, \
         houses.parquet, or .parquet episode file)",
        .0.display()
    )]
    Unknown(PathBuf),
    /// The path cannot be read.
    #[error(transparent)]
    Io(#[from] FileError),
}

/// The kind of output at `path`.
pub fn detect(path: &Path) -> Result<OutputKind, VerifyError> {
    let meta =
        std::fs::metadata(path).map_err(|source| VerifyError::Io(FileError::new(path, source)))?;
    if meta.is_file() {
        return if path.extension().is_some_and(|e| e == "parquet") {
            Ok(OutputKind::Episodes)
        } else {
            Err(VerifyError::Unknown(path.to_path_buf()))
        };
    }
    if path.join(crate::io::lerobot::layout::INFO).is_file() {
        Ok(OutputKind::Lerobot)
    } else if crate::io::run_dir::RunDir::new(path).is_run() {
        Ok(OutputKind::Run)
    } else if path.join("houses.parquet").exists() {
        Ok(OutputKind::Data)
    } else {
        Err(VerifyError::Unknown(path.to_path_buf()))
    }
}

/// Checks the output at `path` (its kind detected); problems are in the report, errors only
/// when nothing could be checked. `progress` counts the files hashed.
pub fn verify(
    path: &Path,
    options: &VerifyOptions,
    progress: &dyn Progress,
) -> Result<Report, VerifyError> {
    let kind = detect(path)?;
    let mut found = Found::default();
    match kind {
        OutputKind::Run => run::check(path, &mut found, progress),
        OutputKind::Lerobot => lerobot::check(path, &mut found, progress),
        OutputKind::Episodes => episodes::check(path, options, &mut found, progress),
        OutputKind::Data => data::check(path, &mut found, progress),
    }
    Ok(found.into_report(kind))
}

/// Problems and counts gathered while checking.
#[derive(Debug, Default)]
struct Found {
    problems: Vec<Problem>,
    /// Problems per file (beyond [`MAX_PROBLEMS_PER_FILE`] only counted).
    per_file: BTreeMap<PathBuf, usize>,
    files: usize,
    bytes: u64,
    checked: Vec<String>,
}

impl Found {
    /// Records a problem of `file`.
    fn problem(&mut self, file: &Path, record: impl Into<String>, message: impl Into<String>) {
        let n = self.per_file.entry(file.to_path_buf()).or_insert(0);
        *n += 1;
        if *n <= MAX_PROBLEMS_PER_FILE {
            self.problems.push(Problem {
                file: file.to_path_buf(),
                record: record.into(),
                message: message.into(),
            });
        }
    }

    fn into_report(mut self, kind: OutputKind) -> Report {
        for (file, n) in &self.per_file {
            if *n > MAX_PROBLEMS_PER_FILE {
                self.problems.push(Problem {
                    file: file.clone(),
                    record: "file".into(),
                    message: format!("{} more problems not listed", n - MAX_PROBLEMS_PER_FILE),
                });
            }
        }
        Report {
            kind,
            problems: self.problems,
            files: self.files,
            bytes: self.bytes,
            checked: self.checked,
        }
    }
}

/// Reads and parses a JSON file, or records why not and gives `None`.
fn read_json(path: &Path, found: &mut Found) -> Option<serde_json::Value> {
    match std::fs::read(path) {
        Err(e) => {
            found.problem(path, "file", e.to_string());
            None
        }
        Ok(bytes) => match serde_json::from_slice(&bytes) {
            Ok(v) => Some(v),
            Err(e) => {
                found.problem(path, "file", format!("not JSON: {e}"));
                None
            }
        },
    }
}

/// A value quoted in a problem: at most 80 characters.
fn quote(v: impl fmt::Display) -> String {
    let s = v.to_string();
    if s.chars().count() > 80 {
        let cut: String = s.chars().take(77).collect();
        format!("{cut}…")
    } else {
        s
    }
}
