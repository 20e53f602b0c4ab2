//! A run folder: `manifest.json`'s checksums, the tables against each other, every image cell
//! decoding with its declared shape, `metrics.json`, and the LeRobot copy.

use std::collections::HashMap;
use std::path::Path;

use arrow::array::{Array, AsArray};
use arrow::datatypes::DataType;

use super::{checksums, lerobot, quote, read_json, tables, Found};
use crate::invalid::Invalid;
use crate::io::image_codec::{decode_cell, CellFormat};
use crate::io::run_dir::{RunDir, MANIFEST, TRAJECTORIES};
use crate::parquet_io::read_batches;
use crate::progress::Progress;

/// Checks the run folder `root`.
pub(super) fn check(root: &Path, found: &mut Found, progress: &dyn Progress) {
    let run = RunDir::new(root);
    let manifest_path = run.manifest();
    if let Some(manifest) = read_json(&manifest_path, found) {
        checksums::check(
            root,
            &manifest_path,
            manifest.get("files"),
            Some(&[MANIFEST]),
            found,
            progress,
        );
    }
    let traj_path = run.trajectories();
    let steps = trajectories(&traj_path, found);
    if let Some(steps) = &steps {
        observations(&run.observations(), steps, found);
    }
    let episodes = episodes(&run.episodes(), steps.as_ref(), found);
    if let Some(ids) = &episodes {
        metrics(&run.metrics(), ids, found);
    }
    if let Some(steps) = &steps {
        found.checked.push(format!(
            "{} episodes, {} steps",
            episodes.as_ref().map_or(0, Vec::len),
            steps.rows.len()
        ));
    }
    let copy = run.lerobot();
    if copy.join(crate::io::lerobot::layout::INFO).is_file() {
        let frames = lerobot::check_dataset(&copy, found);
        if let (Some(frames), Some(steps)) = (frames, &steps) {
            if frames != steps.rows.len() {
                found.problem(
                    &copy.join(crate::io::lerobot::layout::INFO),
                    "total_frames",
                    format!(
                        "{frames} frames where trajectories.parquet has {} rows",
                        steps.rows.len()
                    ),
                );
            }
        }
    }
}

/// The trajectory table's keys and each episode's rows and last `success`.
struct Steps {
    rows: Vec<(String, u64)>,
    /// Episode id → (rows, success on its last row).
    episodes: HashMap<String, (usize, bool)>,
}

fn trajectories(path: &Path, found: &mut Found) -> Option<Steps> {
    let table = tables::read(path, found)?;
    let read = || -> Result<_, Invalid> {
        Ok((
            tables::strings(&table, "episode_id")?,
            tables::numbers(&table, "step")?,
            tables::bools(&table, "success")?,
        ))
    };
    let (ids, step, success) = match read() {
        Ok(v) => v,
        Err(e) => {
            found.problem(path, "schema", e);
            return None;
        }
    };
    let rows: Vec<(String, u64)> = ids
        .into_iter()
        .zip(step.iter().map(|s| *s as u64))
        .collect();
    tables::check_steps(path, &rows, found);
    let mut episodes: HashMap<String, (usize, bool)> = HashMap::new();
    for ((id, _), ok) in rows.iter().zip(success) {
        let e = episodes.entry(id.clone()).or_default();
        e.0 += 1;
        e.1 = ok;
    }
    Some(Steps { rows, episodes })
}

/// The observation table: the trajectory table's rows, each camera cell decoding as its
/// column's metadata declares.
fn observations(path: &Path, steps: &Steps, found: &mut Found) {
    let batches = match read_batches(path) {
        Ok(b) => b,
        Err(e) => {
            found.problem(
                path,
                "file",
                tables::strip_path(&crate::escape::error_line(&e), path),
            );
            return;
        }
    };
    let schema = arrow::array::RecordBatchReader::schema(&batches);
    let mut cameras: Vec<(usize, String, CellFormat)> = Vec::new();
    for (i, f) in schema.fields().iter().enumerate() {
        if f.data_type() != &DataType::Binary {
            continue;
        }
        match CellFormat::from_metadata(f.metadata()) {
            Ok(format) => cameras.push((i, f.name().clone(), format)),
            Err(e) => found.problem(
                path,
                format!("column `{}`", f.name()),
                crate::escape::error_line(&e),
            ),
        }
    }
    let mut row = 0usize;
    let mut keys_ok = true;
    for batch in batches {
        let batch = match batch {
            Ok(b) => b,
            Err(e) => {
                found.problem(
                    path,
                    format!("rows from {row}"),
                    crate::escape::error_line(&e),
                );
                return;
            }
        };
        let (ids, step) = match (
            tables::strings(&batch, "episode_id"),
            tables::numbers(&batch, "step"),
        ) {
            (Ok(i), Ok(s)) => (i, s),
            (Err(e), _) | (_, Err(e)) => {
                found.problem(path, "schema", e);
                return;
            }
        };
        for k in 0..batch.num_rows() {
            let (id, s) = (&ids[k], step[k] as u64);
            let record = format!("row {} (episode `{id}` step {s})", row + k);
            if keys_ok {
                match steps.rows.get(row + k) {
                    Some((tid, ts)) if tid == id && *ts == s => {}
                    other => {
                        keys_ok = false;
                        let theirs = other.map_or("no row".to_string(), |(tid, ts)| {
                            format!("episode `{tid}` step {ts}")
                        });
                        found.problem(
                            path,
                            record.as_str(),
                            format!("trajectories.parquet has {theirs} there"),
                        );
                    }
                }
            }
            for (c, name, format) in &cameras {
                let col = batch.column(*c).as_binary::<i32>();
                if col.is_null(k) {
                    found.problem(path, record.as_str(), format!("`{name}` is null"));
                } else if let Err(e) = decode_cell(col.value(k), format) {
                    found.problem(
                        path,
                        record.as_str(),
                        format!("`{name}`: {}", crate::escape::error_line(&e)),
                    );
                }
            }
        }
        row += batch.num_rows();
    }
    if row != steps.rows.len() {
        found.problem(
            path,
            "rows",
            format!(
                "{row} rows where trajectories.parquet has {}",
                steps.rows.len()
            ),
        );
    }
}

/// The episode table against the trajectories; its ids in order.
fn episodes(path: &Path, steps: Option<&Steps>, found: &mut Found) -> Option<Vec<String>> {
    let table = tables::read(path, found)?;
    let read = || -> Result<_, Invalid> {
        Ok((
            tables::strings(&table, "episode_id")?,
            tables::numbers(&table, "steps")?,
            tables::bools(&table, "success")?,
        ))
    };
    let (ids, n, success) = match read() {
        Ok(v) => v,
        Err(e) => {
            found.problem(path, "schema", e);
            return None;
        }
    };
    if let Some(steps) = steps {
        for (i, id) in ids.iter().enumerate() {
            let record = format!("row {i} (episode `{id}`)");
            match steps.episodes.get(id) {
                None => found.problem(path, record, "no rows in trajectories.parquet"),
                Some((rows, last)) => {
                    if n[i] as usize != *rows {
                        found.problem(
                            path,
                            record.as_str(),
                            format!(
                                "steps {} where trajectories.parquet has {rows} rows",
                                quote(n[i])
                            ),
                        );
                    }
                    if success[i] != *last {
                        found.problem(
                            path,
                            record,
                            format!(
                                "success {} where its last trajectory row says {last}",
                                success[i]
                            ),
                        );
                    }
                }
            }
        }
        let listed: std::collections::HashSet<&String> = ids.iter().collect();
        let mut extra: Vec<&String> = steps
            .episodes
            .keys()
            .filter(|id| !listed.contains(id))
            .collect();
        extra.sort();
        for id in extra {
            found.problem(
                &path.with_file_name(TRAJECTORIES),
                format!("episode `{id}`"),
                "not in episodes.parquet",
            );
        }
    }
    Some(ids)
}

/// `metrics.json` lists the episode table's episodes, in order.
fn metrics(path: &Path, ids: &[String], found: &mut Found) {
    let Some(m) = read_json(path, found) else {
        return;
    };
    let listed: Vec<&str> = m
        .get("episodes")
        .and_then(|e| e.as_array())
        .map(|a| {
            a.iter()
                .map(|e| e.get("episode_id").and_then(|v| v.as_str()).unwrap_or(""))
                .collect()
        })
        .unwrap_or_default();
    if listed.len() != ids.len() {
        found.problem(
            path,
            "episodes",
            format!(
                "{} episodes where episodes.parquet has {}",
                listed.len(),
                ids.len()
            ),
        );
    } else if let Some((i, (a, b))) = listed
        .iter()
        .zip(ids)
        .enumerate()
        .find(|(_, (a, b))| **a != b.as_str())
    {
        found.problem(
            path,
            format!("episodes[{i}]"),
            format!("episode `{a}` where episodes.parquet has `{b}`"),
        );
    }
}
