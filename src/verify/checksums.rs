//! The checksum pass: every file a provenance record lists is hashed (sha256, several files
//! at once) and compared with the record; files missing or not listed are problems.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde_json::Value;

use super::Found;
use crate::progress::Progress;
use crate::provenance::sha256_file;

/// Compares the `files` object of the record at `record` (`{"rel/path": {"sha256", "bytes"}}`,
/// relative to `root`) with the files on disk. With `complete`, files under `root` that the
/// record does not list are problems too (hidden names and `skip` excepted).
pub(super) fn check(
    root: &Path,
    record: &Path,
    files: Option<&Value>,
    complete: Option<&[&str]>,
    found: &mut Found,
    progress: &dyn Progress,
) {
    let record_name = record
        .strip_prefix(root)
        .unwrap_or(record)
        .display()
        .to_string();
    let Some(listed) = files.and_then(Value::as_object) else {
        found.problem(record, "files", "no `files` list of checksums");
        return;
    };
    let mut wanted: Vec<(&String, Option<&str>, Option<u64>)> = Vec::new();
    for (rel, sum) in listed {
        let sha = sum.get("sha256").and_then(Value::as_str);
        let bytes = sum.get("bytes").and_then(Value::as_u64);
        if sha.is_none() || bytes.is_none() || !safe_relative(rel) {
            found.problem(
                record,
                format!("files `{rel}`"),
                "not a relative path with `sha256` and `bytes`",
            );
            continue;
        }
        wanted.push((rel, sha, bytes));
    }
    progress.set_total(wanted.len() as u64);
    let sums: Vec<_> = wanted
        .par_iter()
        .map(|(rel, _, _)| {
            let sum = sha256_file(&root.join(rel));
            progress.advance(1);
            sum
        })
        .collect();
    for ((rel, sha, bytes), sum) in wanted.iter().zip(sums) {
        let path = root.join(rel);
        let (sha, bytes) = (sha.unwrap_or_default(), bytes.unwrap_or_default());
        match sum {
            Err(e) if e.source.kind() == std::io::ErrorKind::NotFound => {
                found.problem(&path, "file", format!("missing (listed in {record_name})"));
            }
            Err(e) => found.problem(&path, "file", e.source.to_string()),
            Ok(got) => {
                found.files += 1;
                found.bytes += got.bytes;
                if got.bytes != bytes {
                    found.problem(
                        &path,
                        "checksum",
                        format!("{} bytes where {record_name} records {bytes}", got.bytes),
                    );
                } else if got.sha256 != sha {
                    found.problem(
                        &path,
                        "checksum",
                        format!("sha256 {} where {record_name} records {sha}", got.sha256),
                    );
                }
            }
        }
    }
    if let Some(skip) = complete {
        let mut on_disk = BTreeMap::new();
        list(root, String::new(), &mut on_disk);
        for rel in on_disk.keys() {
            if !listed.contains_key(rel) && !skip.contains(&rel.as_str()) {
                found.problem(
                    &root.join(rel),
                    "file",
                    format!("not listed in {record_name}"),
                );
            }
        }
    }
}

/// A record's file name that stays inside its folder.
fn safe_relative(rel: &str) -> bool {
    let p = Path::new(rel);
    !rel.is_empty()
        && p.components()
            .all(|c| matches!(c, std::path::Component::Normal(_)))
}

/// Every visible file under `dir` by its `/`-separated path relative to the checked root.
fn list(dir: &Path, prefix: String, out: &mut BTreeMap<String, PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') {
            continue;
        }
        let rel = format!("{prefix}{name}");
        match entry.file_type() {
            Ok(t) if t.is_dir() => list(&entry.path(), format!("{rel}/"), out),
            Ok(_) => {
                out.insert(rel, entry.path());
            }
            Err(_) => {}
        }
    }
}
