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

/// Replaces libfuzzer-sys's panic hook (which aborts on every panic, even one minos catches)
/// by a silent one, for targets whose reader runs a dependency under `catch_unwind`: a panic
/// minos does not catch still reaches `fuzz_target!`, which aborts, so it is still a crash.
pub fn count_only_uncaught_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| std::panic::set_hook(Box::new(|_| {})));
}
