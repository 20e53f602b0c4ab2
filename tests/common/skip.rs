//! The one way a test says it skipped part of its work: `skipped: <binary>::<test>: <why>` on
//! stderr and, when `MINOS_SKIP_LOG` names a file, the same line appended to it (`.ci/run`
//! sets it and prints the count of skips beside passed and failed, since cargo hides the
//! output of tests that pass).

use std::io::Write;

/// Records that the running test skipped something, and why (one line).
pub fn skip(why: impl std::fmt::Display) {
    let binary = std::env::current_exe()
        .ok()
        .and_then(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .map(|s| match s.rsplit_once('-') {
            Some((name, hash)) if hash.chars().all(|c| c.is_ascii_hexdigit()) => name.to_string(),
            _ => s,
        })
        .unwrap_or_default();
    let test = std::thread::current().name().unwrap_or("main").to_string();
    let why = why.to_string().replace(['\n', '\r'], " ");
    let line = format!("skipped: {binary}::{test}: {why}");
    eprintln!("{line}");
    if let Some(path) = std::env::var_os("MINOS_SKIP_LOG") {
        if let Ok(mut f) = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
        {
            // One write per line: appends of short lines do not interleave.
            let _ = f.write_all(format!("{line}\n").as_bytes());
        }
    }
}
