//! `minos diff A B`: two outputs of the same kind (run folders, LeRobot datasets, episode
//! files, DATA folders, or any two files or folders) compared file by file, each difference
//! said in terms a user reads — the episode and step (or LeRobot episode and frame), the
//! column or feature, and both values — instead of "the bytes differ".
//!
//! Files with the same bytes are identical. Otherwise Parquet tables are compared row by row
//! (`table.rs`), JSON documents value by value (`json.rs`), other text line by line and
//! anything else byte by byte; the first difference of each file is reported.

mod json;
mod table;

use crate::file_error::FileError;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The first difference of one file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Difference {
    /// The file: its path relative to the compared folders, or as given for two files.
    pub file: String,
    /// What differs (`episode \`h1:pointgoal:3\` step 4: column \`x\`: 1.25 vs 1.5`).
    pub what: String,
}

impl std::fmt::Display for Difference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let line = format!("{}: {}", self.file, self.what);
        f.write_str(&crate::escape::escape_controls(&line))
    }
}

/// The comparison of two outputs.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct DiffReport {
    /// Files compared.
    pub files: usize,
    /// One entry per file that differs, in path order.
    pub differences: Vec<Difference>,
}

impl DiffReport {
    /// True when every file is byte-identical.
    pub fn identical(&self) -> bool {
        self.differences.is_empty()
    }

    /// `identical (N files)` or `K of N files differ`.
    pub fn summary(&self) -> String {
        if self.identical() {
            format!("identical ({} files)", self.files)
        } else {
            format!("{} of {} files differ", self.differences.len(), self.files)
        }
    }
}

/// Why two paths could not be compared.
#[derive(Debug, thiserror::Error)]
pub enum DiffError {
    /// A path that cannot be read.
    #[error(transparent)]
    Io(#[from] FileError),
    /// A file and a folder.
    #[error("{} is a folder and {} is not: compare two outputs of the same kind", .0.display(), .1.display())]
    Kinds(PathBuf, PathBuf),
}

/// Sidecars compared with an episode file: `FILE.stats.json`, `FILE.provenance.json`.
const SIDECARS: [&str; 2] = [".stats.json", ".provenance.json"];

/// Compares `a` with `b`: two folders file by file (hidden names skipped), or two files
/// (with their sidecars, for episode files).
pub fn diff(a: &Path, b: &Path) -> Result<DiffReport, DiffError> {
    let meta =
        |p: &Path| std::fs::metadata(p).map_err(|source| DiffError::Io(FileError::new(p, source)));
    let (ma, mb) = (meta(a)?, meta(b)?);
    let mut report = DiffReport::default();
    match (ma.is_dir(), mb.is_dir()) {
        (true, true) => {
            let (fa, fb) = (files_under(a), files_under(b));
            let all: BTreeSet<&String> = fa.iter().chain(fb.iter()).collect();
            for rel in all {
                report.files += 1;
                let what = match (fa.contains(rel), fb.contains(rel)) {
                    (true, false) => Some(format!("only in {}", a.display())),
                    (false, true) => Some(format!("only in {}", b.display())),
                    _ => first_difference(&a.join(rel), &b.join(rel))?,
                };
                if let Some(what) = what {
                    report.differences.push(Difference {
                        file: rel.clone(),
                        what,
                    });
                }
            }
        }
        (false, false) => {
            report.files += 1;
            if let Some(what) = first_difference(a, b)? {
                report.differences.push(Difference {
                    file: a.display().to_string(),
                    what,
                });
            }
            for suffix in SIDECARS {
                let sa = PathBuf::from(format!("{}{suffix}", a.display()));
                let sb = PathBuf::from(format!("{}{suffix}", b.display()));
                let what = match (sa.is_file(), sb.is_file()) {
                    (false, false) => continue,
                    (true, false) => Some(format!("only beside {}", a.display())),
                    (false, true) => Some(format!("only beside {}", b.display())),
                    (true, true) => first_difference(&sa, &sb)?,
                };
                report.files += 1;
                if let Some(what) = what {
                    report.differences.push(Difference {
                        file: sa.display().to_string(),
                        what,
                    });
                }
            }
        }
        _ => return Err(DiffError::Kinds(a.to_path_buf(), b.to_path_buf())),
    }
    Ok(report)
}

/// The first difference of two files, `None` when their bytes are equal.
pub fn first_difference(a: &Path, b: &Path) -> Result<Option<String>, DiffError> {
    let read =
        |p: &Path| std::fs::read(p).map_err(|source| DiffError::Io(FileError::new(p, source)));
    let (ba, bb) = (read(a)?, read(b)?);
    if ba == bb {
        return Ok(None);
    }
    let ext = a.extension().and_then(|e| e.to_str()).unwrap_or("");
    let what = match ext {
        "parquet" => table::first_difference(a, b),
        "json" => json::first_difference(&ba, &bb),
        _ => None,
    };
    Ok(Some(what.unwrap_or_else(|| bytes_difference(&ba, &bb))))
}

/// The first differing line of two texts, or byte of two binary files.
fn bytes_difference(a: &[u8], b: &[u8]) -> String {
    if let (Ok(ta), Ok(tb)) = (std::str::from_utf8(a), std::str::from_utf8(b)) {
        let (mut la, mut lb) = (ta.lines(), tb.lines());
        let mut n = 1;
        loop {
            match (la.next(), lb.next()) {
                (Some(x), Some(y)) if x == y => n += 1,
                (x, y) => {
                    let show = |l: Option<&str>| {
                        l.map_or("(end of file)".into(), |l| format!("`{}`", quote(l)))
                    };
                    return format!("line {n}: {} vs {}", show(x), show(y));
                }
            }
        }
    }
    let at = a
        .iter()
        .zip(b)
        .position(|(x, y)| x != y)
        .unwrap_or(a.len().min(b.len()));
    format!(
        "{} vs {} bytes, first difference at byte {at}",
        a.len(),
        b.len()
    )
}

/// A value quoted in a difference: at most 80 characters.
fn quote(s: &str) -> String {
    if s.chars().count() > 80 {
        let cut: String = s.chars().take(77).collect();
        format!("{cut}…")
    } else {
        s.to_string()
    }
}

/// Every visible file under `dir`, `/`-separated and relative to it.
fn files_under(dir: &Path) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut pending = vec![(dir.to_path_buf(), String::new())];
    while let Some((d, prefix)) = pending.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') {
                continue;
            }
            let rel = format!("{prefix}{name}");
            if e.file_type().is_ok_and(|t| t.is_dir()) {
                pending.push((e.path(), format!("{rel}/")));
            } else {
                out.insert(rel);
            }
        }
    }
    out
}
