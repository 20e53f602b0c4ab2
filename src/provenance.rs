//! Provenance records: which minos made an output (version and source commit) and the
//! sha256 of every file it wrote, so that a copy that left the machine can be checked and two
//! outputs told apart (see docs/FORMATS.md, "Provenance records").
//!
//! Records hold no wall-clock time and no host name: the same inputs give the same bytes.

use crate::file_error::FileError;
use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

use serde::Serialize;
use sha2::{Digest, Sha256};

/// The `format` of every provenance record.
pub const FORMAT: &str = "minos-provenance/1";

/// The source commit this minos was built from (`git rev-parse HEAD` at build time, the
/// `MINOS_SOURCE_COMMIT` environment variable when set, or `unknown`).
pub const SOURCE_COMMIT: &str = env!("MINOS_SOURCE_COMMIT");

/// The minos that made an output: `{"version": …, "commit": …}`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Minos {
    /// The crate version.
    pub version: &'static str,
    /// The source commit ([`SOURCE_COMMIT`]).
    pub commit: &'static str,
}

/// This build of minos.
pub const MINOS: Minos = Minos {
    version: env!("CARGO_PKG_VERSION"),
    commit: SOURCE_COMMIT,
};

/// A file's checksum and size.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct FileSum {
    /// Lower-case hex sha256 of the file's bytes.
    pub sha256: String,
    /// Its size in bytes.
    pub bytes: u64,
}

/// The sha256 (lower-case hex) and size of the file at `path`, read in 1 MiB blocks.
pub fn sha256_file(path: &Path) -> Result<FileSum, FileError> {
    let err = |source| FileError::new(path, source);
    let mut file = std::fs::File::open(path).map_err(err)?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    let mut bytes = 0u64;
    loop {
        let n = file.read(&mut buf).map_err(err)?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
        bytes += n as u64;
    }
    Ok(FileSum {
        sha256: hex(&hasher.finalize()),
        bytes,
    })
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// The checksum of every file under `dir` by its path relative to `dir` (`/`-separated,
/// sorted), skipping hidden names (temporary files start with `.`) and the relative paths
/// in `skip` (the record itself).
pub fn checksums(dir: &Path, skip: &[&str]) -> Result<BTreeMap<String, FileSum>, FileError> {
    let mut out = BTreeMap::new();
    let mut pending = vec![(dir.to_path_buf(), String::new())];
    while let Some((folder, prefix)) = pending.pop() {
        let err = |source| FileError::new(&folder, source);
        for entry in std::fs::read_dir(&folder).map_err(err)? {
            let entry = entry.map_err(err)?;
            let name = entry.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') {
                continue;
            }
            let rel = format!("{prefix}{name}");
            let kind = entry.file_type().map_err(err)?;
            if kind.is_dir() {
                pending.push((entry.path(), format!("{rel}/")));
            } else if !skip.contains(&rel.as_str()) {
                out.insert(rel, sha256_file(&entry.path())?);
            }
        }
    }
    Ok(out)
}

/// Writes `record` as pretty JSON (keys in the order the value holds them) to `path`,
/// atomically, after removing what a killed writer of `path` left beside it (every record
/// is written last, so a kill between its output and it would otherwise leave litter that no
/// rerun sweeps).
pub fn write_record(path: &Path, record: &serde_json::Value) -> Result<(), FileError> {
    crate::atomic::sweep_stale_of(path).map_err(|source| FileError::new(path, source))?;
    let mut bytes = serde_json::to_vec_pretty(record)
        .map_err(|e| FileError::new(path, std::io::Error::other(e)))?;
    bytes.push(b'\n');
    crate::atomic::write_bytes_atomic(path, &bytes).map_err(|source| FileError::new(path, source))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_sweeps_what_a_killed_writer_of_it_left() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.parquet.provenance.json");
        // Above the largest process id Linux hands out: a writer that is gone.
        let dead = 4_194_305 + 17;
        let left = dir
            .path()
            .join(format!(".out.parquet.provenance.json.tmp-{dead}"));
        let other = dir.path().join(format!(".out.parquet.tmp-{dead}"));
        std::fs::write(&left, b"{").unwrap();
        std::fs::write(&other, b"x").unwrap();
        write_record(&path, &serde_json::json!({"kind": "test"})).unwrap();
        assert!(!left.exists(), "the record's own temporary is swept");
        assert!(
            other.exists(),
            "another file's temporary is its writer's to sweep"
        );
        assert_eq!(
            std::fs::read(&path).unwrap(),
            b"{\n  \"kind\": \"test\"\n}\n"
        );
    }

    #[test]
    fn checksums_are_sha256_of_every_visible_file_but_the_skipped_ones() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("meta/sub")).unwrap();
        std::fs::write(dir.path().join("a.txt"), b"abc").unwrap();
        std::fs::write(dir.path().join("meta/sub/b"), b"").unwrap();
        std::fs::write(dir.path().join("meta/record.json"), b"{}").unwrap();
        std::fs::write(dir.path().join(".a.tmp-1"), b"partial").unwrap();
        let sums = checksums(dir.path(), &["meta/record.json"]).unwrap();
        let names: Vec<&str> = sums.keys().map(String::as_str).collect();
        assert_eq!(names, ["a.txt", "meta/sub/b"]);
        // The published test vectors of sha256.
        assert_eq!(
            sums["a.txt"].sha256,
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(sums["a.txt"].bytes, 3);
        assert_eq!(
            sums["meta/sub/b"].sha256,
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
        let missing = sha256_file(&dir.path().join("none"))
            .unwrap_err()
            .to_string();
        assert!(missing.contains("none"), "{missing}");
        assert!(!MINOS.commit.is_empty() && MINOS.version == env!("CARGO_PKG_VERSION"));
    }
}
