//! Helpers the fuzz targets share (included with `#[path]`; not a target).

#![allow(dead_code)]

use std::path::PathBuf;

/// A folder of this fuzzing process's own (`$TMPDIR/minos-fuzz-<pid>`).
pub fn temp_dir() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("minos-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("create the fuzzing folder");
    dir
}

/// Writes `bytes` to `name` in [`temp_dir`] and returns the path (readers that take paths).
pub fn temp_file(name: &str, bytes: &[u8]) -> PathBuf {
    let path = temp_dir().join(name);
    std::fs::write(&path, bytes).expect("write the fuzzing input");
    path
}

/// Asserts that an error message is one line and names `what` (a file name).
pub fn one_line_naming(message: &str, what: &str) {
    assert!(
        !message.contains('\n') && message.contains(what),
        "bad error message (one line naming {what:?} expected): {message:?}"
    );
}
