//! A DATA folder: `provenance.json`'s checksums, the manifest, every compiled scene's header
//! and every navigation grid reading.

use std::path::Path;

use super::{checksums, read_json, tables, Found};
use crate::progress::Progress;
use crate::scene::SceneRef;
use crate::store::DataDir;

/// Checks the DATA folder `root`.
pub(super) fn check(root: &Path, found: &mut Found, progress: &dyn Progress) {
    let record = root.join("provenance.json");
    if record.is_file() {
        if let Some(v) = read_json(&record, found) {
            checksums::check(
                root,
                &record,
                v.get("files"),
                Some(&["provenance.json"]),
                found,
                progress,
            );
        }
    } else {
        found.problem(&record, "file", "missing: no checksums to compare");
    }
    let data = DataDir::new(root);
    let rows = match data.read_manifest() {
        Ok(rows) => rows.len(),
        Err(e) => {
            let path = data.manifest_path();
            found.problem(
                &path,
                "file",
                tables::strip_path(&crate::escape::error_line(&e), &path),
            );
            0
        }
    };
    let mut scenes = 0;
    for path in files_with(&data.scenes_dir(), "mscene") {
        scenes += 1;
        if let Err(e) = crate::store::scene_file::read_header(&path) {
            found.problem(
                &path,
                "header",
                tables::strip_path(&crate::escape::error_line(&e), &path),
            );
        }
    }
    let mut grids = 0;
    for path in files_with(&data.nav_dir(), "nav") {
        grids += 1;
        let id = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        if let Err(e) = data.read_grid(&SceneRef::parse(&id)) {
            found.problem(
                &path,
                "grid",
                tables::strip_path(&crate::escape::error_line(&e), &path),
            );
        }
    }
    found.checked.push(format!(
        "{rows} manifest rows, {scenes} compiled scenes and {grids} grids read"
    ));
}

/// The visible files of `dir` with extension `ext`, sorted.
fn files_with(dir: &Path, ext: &str) -> Vec<std::path::PathBuf> {
    let mut out: Vec<_> = std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .flatten()
                .map(|e| e.path())
                .filter(|p| {
                    p.extension().is_some_and(|e| e == ext)
                        && !p
                            .file_name()
                            .is_some_and(|n| n.to_string_lossy().starts_with('.'))
                })
                .collect()
        })
        .unwrap_or_default();
    out.sort();
    out
}
