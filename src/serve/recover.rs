//! Sessions a killed server left: at start-up, every session folder of the output folder
//! that still holds part files (`<session>/.parts/`: the server died while the session was
//! live) is finished as its session would have ended after its last finished episode
//! ([`finish_live`]): its tables, metrics, manifest and `played.parquet` are written from the
//! finished episodes' parts, byte for byte what an uninterrupted session writes, and the parts
//! are removed. A folder in which no episode finished is removed. One folder's problem is
//! logged and the others go on.

use std::path::Path;

use super::session::{run_config, Shared};
use crate::io::run_dir::RunDir;
use crate::lock::LOCK_FILE;
use crate::pipeline::rollout::finish_live;

/// Finishes the interrupted sessions in `shared.out` (see the module documentation).
pub fn finish_sessions(shared: &Shared) {
    let entries = match std::fs::read_dir(&shared.out) {
        Ok(e) => e,
        // A first start: nothing was left.
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return,
        Err(e) => {
            tracing::warn!("{}: {e}", shared.out.display());
            return;
        }
    };
    let mut names: Vec<String> = entries
        .filter_map(Result::ok)
        .filter(|e| RunDir::new(e.path()).parts().is_dir())
        .filter_map(|e| e.file_name().to_str().map(str::to_string))
        .collect();
    names.sort();
    for name in names {
        let cfg = run_config(shared, &name);
        match finish_live(&cfg) {
            Ok(Some(report)) if report.episodes.is_empty() => {
                remove_if_empty(&cfg.out);
                tracing::info!("session {name}: interrupted before any episode finished; removed");
            }
            Ok(Some(report)) => tracing::info!(
                "session {name}: interrupted; its {} finished episodes written",
                report.episodes.len()
            ),
            Ok(None) => {}
            Err(e) => tracing::warn!(
                "session {name} (interrupted) left as it is: {}",
                crate::escape::error_line(&e)
            ),
        }
    }
}

/// Removes session folder `dir` when it holds nothing but its (released) lock file.
fn remove_if_empty(dir: &Path) {
    let only_lock = std::fs::read_dir(dir).is_ok_and(|entries| {
        entries
            .filter_map(Result::ok)
            .all(|e| e.file_name() == LOCK_FILE)
    });
    if only_lock {
        if let Err(e) = std::fs::remove_dir_all(dir) {
            tracing::warn!("{}: {e}", dir.display());
        }
    }
}
