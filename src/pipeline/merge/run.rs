//! Merging run folders: every finished episode's rows, in episode-id order (the order one
//! unsharded run writes), taken from the shard that ran it.
//!
//! - `episodes.parquet` and `trajectories.parquet` are small: read whole, their rows
//!   reordered and written as the run writes them (trajectory rows re-batched per episode
//!   exactly as a run joins its episode parts);
//! - `observations.parquet`: each episode's row groups are copied as they are (a run writes
//!   every episode into row groups of its own), so images are never decoded;
//! - `metrics.json` from the merged episode table and the shards' failures;
//! - the rerun recording: the first `rerun_episodes` episodes of the whole run, each taken
//!   from its shard's recording (a shard records its own first ones, which include them);
//! - the LeRobot copy is rebuilt from the merged tables, as a run builds it;
//! - `manifest.json`: the shards' manifest (which must agree but for `command`, `shard` and
//!   `rerun`) with shard `0/1`, the merged recording, and the merge's own command.

use crate::file_error::FileError;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use arrow::array::{Array, BooleanArray, Float32Array, RecordBatch, StringArray, UInt32Array};
use serde_json::Value;

use super::{check_shards, recorded_shard, MergeError, MergeReport};
use crate::atomic::{sweep_stale, write_bytes_atomic};
use crate::io::lerobot::video::VideoSettings;
use crate::io::rrd::{recordings_of, write_recordings};
use crate::io::run_dir::{RunDir, RunManifest, RunManifestError};
use crate::io::tables::{
    copy_row_groups_from, read_table, row_group_episodes, write_episode_batch,
    write_trajectory_pieces,
};
use crate::lock::{DirLock, LockMode};
use crate::pipeline::rollout::{write_lerobot, write_metrics, FailedEpisode};
use crate::progress::Progress;
use crate::run::metrics::{aggregate, EpisodeMetrics, MetricRow};
use crate::shard::Shard;

/// Where a run merge writes, and how.
#[derive(Debug, Clone, Default)]
pub struct RunMerge {
    /// The merged run folder.
    pub out: PathBuf,
    /// The merged rerun recording (needed when the shards recorded one).
    pub rerun: Option<PathBuf>,
    /// The merge's command line, recorded in `manifest.json` (empty for library callers).
    pub command: Vec<String>,
    /// Fail at once when another process writes `out`, or wait for it.
    pub lock: LockMode,
}

/// Manifest keys that differ between the shards of one run (each shard's scenes and files).
const PER_SHARD_KEYS: [&str; 5] = ["command", "shard", "rerun", "scenes", "files"];

/// One shard's run folder, read.
struct ShardRun {
    dir: RunDir,
    manifest: RunManifest,
    episodes: RecordBatch,
    failures: Vec<FailedEpisode>,
    lerobot: bool,
    /// Its LeRobot copy stores cameras as video, encoded so (as its `info.json` says).
    lerobot_video: Option<VideoSettings>,
}

/// What is wrong with a shard's file `path`.
fn shard_error(path: &Path, what: impl std::fmt::Display) -> MergeError {
    MergeError::Shards(format!("{}: {what}", path.display()))
}

/// `path` of the merged output could not be written.
fn write_io(path: &Path) -> impl FnOnce(std::io::Error) -> MergeError + '_ {
    move |source| MergeError::WriteIo(FileError::new(path, source))
}

/// Reads a shard's manifest, episode table and failures.
fn read_shard(dir: &Path) -> Result<(ShardRun, Shard), MergeError> {
    let dir = RunDir::new(dir);
    let manifest = dir.read_manifest().map_err(|e| match e {
        RunManifestError::Read { path, source } => MergeError::Unfinished {
            manifest: path,
            source,
        },
        RunManifestError::Json { path, source } => MergeError::ShardJson { path, source },
        e => MergeError::ShardManifest(e),
    })?;
    let shard = recorded_shard(
        manifest.path(),
        manifest.value().get("shard").and_then(Value::as_str),
    )?;
    let episodes = read_table(&dir.episodes()).map_err(MergeError::ShardTable)?;
    let metrics_path = dir.metrics();
    let metrics: Value = std::fs::read(&metrics_path)
        .map_err(|source| MergeError::ShardIo(FileError::new(&metrics_path, source)))
        .and_then(|b| {
            serde_json::from_slice(&b).map_err(|source| MergeError::ShardJson {
                path: metrics_path.clone(),
                source,
            })
        })?;
    let failures = metrics
        .get("failures")
        .and_then(Value::as_array)
        .ok_or_else(|| shard_error(&metrics_path, "no `failures` list"))?
        .iter()
        .map(|f| {
            let field = |k: &str| f.get(k).and_then(Value::as_str).map(str::to_string);
            let (id, error) = field("episode_id")
                .zip(field("error"))
                .ok_or_else(|| shard_error(&metrics_path, "a failure without episode_id/error"))?;
            // Groups: empty when an older shard did not record them.
            Ok::<_, MergeError>(FailedEpisode {
                episode_id: id,
                error,
                task: field("task").unwrap_or_default(),
                split: field("split").unwrap_or_default(),
                difficulty: field("difficulty").unwrap_or_default(),
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let info = dir.lerobot().join(crate::io::lerobot::layout::INFO);
    let run = ShardRun {
        dir,
        manifest,
        episodes,
        failures,
        lerobot: info.is_file(),
        lerobot_video: std::fs::read(&info)
            .ok()
            .and_then(|b| serde_json::from_slice::<Value>(&b).ok())
            .and_then(|info| crate::io::lerobot::video_settings(&info)),
    };
    Ok((run, shard))
}

/// The manifest without the keys that differ between shards.
fn shared_part(manifest: &Value) -> Value {
    let mut v = manifest.clone();
    if let Some(map) = v.as_object_mut() {
        for k in PER_SHARD_KEYS {
            map.remove(k);
        }
    }
    v
}

/// Checks that the shards ran the same job (same episodes file, agent, sensors, seed, …).
fn check_same_job(runs: &[ShardRun]) -> Result<(), MergeError> {
    let first = &runs[0];
    let reference = shared_part(first.manifest.value());
    for run in &runs[1..] {
        let mine = shared_part(run.manifest.value());
        if mine != reference {
            let keys: BTreeSet<&String> = reference
                .as_object()
                .into_iter()
                .chain(mine.as_object())
                .flat_map(|m| m.keys())
                .collect();
            let key = keys
                .into_iter()
                .find(|k| reference.get(k.as_str()) != mine.get(k.as_str()))
                .map_or("(structure)".to_string(), |k| format!("`{k}`"));
            return Err(shard_error(
                run.manifest.path(),
                format!(
                    "{key} differs from {}: not shards of one run",
                    first.manifest.path().display()
                ),
            ));
        }
        if run.lerobot != first.lerobot {
            return Err(shard_error(
                run.dir.root(),
                format!(
                    "has {}a LeRobot copy but {} has {}: not shards of one run",
                    if run.lerobot { "" } else { "no " },
                    first.dir.root().display(),
                    if first.lerobot { "one" } else { "none" }
                ),
            ));
        }
        // The merged copy is encoded once, so its cameras' encoding must be every shard's.
        if run.lerobot_video != first.lerobot_video {
            let encoding = |v: Option<VideoSettings>| {
                v.map_or("images, not video".to_string(), |v| {
                    format!("video at quantiser {}", v.qp)
                })
            };
            return Err(shard_error(
                run.dir.root(),
                format!(
                    "its LeRobot copy stores cameras as {} but {}'s as {}: not shards of one run",
                    encoding(run.lerobot_video),
                    first.dir.root().display(),
                    encoding(first.lerobot_video)
                ),
            ));
        }
    }
    Ok(())
}

fn column<'a, T: 'static>(
    batch: &'a RecordBatch,
    name: &str,
    path: &Path,
) -> Result<&'a T, MergeError> {
    batch
        .column_by_name(name)
        .and_then(|c| c.as_any().downcast_ref::<T>())
        .ok_or_else(|| {
            shard_error(
                path,
                format!("column `{name}` is missing or of another type"),
            )
        })
}

/// The `episode_id` column of a table.
fn episode_ids<'a>(batch: &'a RecordBatch, path: &Path) -> Result<&'a StringArray, MergeError> {
    column::<StringArray>(batch, "episode_id", path)
}

/// The rows of a merged episode table as the aggregate wants them, with each episode's metrics.
type MetricRows = (Vec<MetricRow>, Vec<String>);

fn metric_rows(batch: &RecordBatch, path: &Path) -> Result<MetricRows, MergeError> {
    let s = |n| column::<StringArray>(batch, n, path);
    let f = |n| column::<Float32Array>(batch, n, path);
    let u = |n| column::<UInt32Array>(batch, n, path);
    let (ids, task, split, difficulty) =
        (s("episode_id")?, s("task")?, s("split")?, s("difficulty")?);
    let success = column::<BooleanArray>(batch, "success", path)?;
    let (spl, soft_spl, speed, path_length, final_geodesic) = (
        f("spl")?,
        f("soft_spl")?,
        f("speed")?,
        f("path_length")?,
        f("final_geodesic")?,
    );
    let (steps, collisions) = (u("steps")?, u("collisions")?);
    let ndtw = f("ndtw")?;
    let mut rows = Vec::with_capacity(batch.num_rows());
    let mut names = Vec::with_capacity(batch.num_rows());
    for r in 0..batch.num_rows() {
        let m = EpisodeMetrics {
            success: success.value(r),
            speed: speed.value(r),
            spl: spl.value(r),
            soft_spl: soft_spl.value(r),
            path_length: path_length.value(r),
            steps: steps.value(r),
            collisions: collisions.value(r),
            final_geodesic: if final_geodesic.is_null(r) {
                f32::NAN
            } else {
                final_geodesic.value(r)
            },
            ndtw: if ndtw.is_null(r) {
                f32::NAN
            } else {
                ndtw.value(r)
            },
        };
        rows.push((
            task.value(r).to_string(),
            split.value(r).to_string(),
            difficulty.value(r).to_string(),
            Some(m),
        ));
        names.push(ids.value(r).to_string());
    }
    Ok((rows, names))
}

/// Each episode's contiguous rows `(start, len)` in a table ordered by episode.
fn episode_ranges(
    batch: &RecordBatch,
    path: &Path,
) -> Result<BTreeMap<String, (usize, usize)>, MergeError> {
    let ids = episode_ids(batch, path)?;
    let mut ranges: BTreeMap<String, (usize, usize)> = BTreeMap::new();
    let mut r = 0;
    while r < ids.len() {
        let id = ids.value(r);
        let start = r;
        while r < ids.len() && ids.value(r) == id {
            r += 1;
        }
        if ranges.insert(id.to_string(), (start, r - start)).is_some() {
            return Err(shard_error(
                path,
                format!("the rows of episode `{id}` are not together"),
            ));
        }
    }
    Ok(ranges)
}

/// Joins the run folders `shards` (`minos run --shard i/n`) into `opts.out`: the files one
/// unsharded run writes (see the module documentation).
pub fn merge_runs(
    shards: &[PathBuf],
    opts: &RunMerge,
    progress: &dyn Progress,
) -> Result<MergeReport, MergeError> {
    let mut runs = Vec::new();
    let mut found = Vec::new();
    for dir in shards {
        let (run, shard) = read_shard(dir)?;
        found.push((dir.clone(), shard));
        runs.push(run);
    }
    check_shards(&found)?;
    // Shards in shard order, so "the first shard" is the same whatever order they are given.
    let mut order: Vec<usize> = (0..runs.len()).collect();
    order.sort_by_key(|&i| found[i].1.index);
    let runs: Vec<ShardRun> = {
        let mut slots: Vec<Option<ShardRun>> = runs.into_iter().map(Some).collect();
        order.iter().filter_map(|&i| slots[i].take()).collect()
    };
    check_same_job(&runs)?;
    let out = &opts.out;
    let out_abs = std::path::absolute(out).map_err(write_io(out))?;
    for run in &runs {
        let dir = std::path::absolute(run.dir.root())
            .map_err(|source| MergeError::ShardIo(FileError::new(run.dir.root(), source)))?;
        if out_abs.starts_with(&dir) || dir.starts_with(&out_abs) {
            return Err(shard_error(
                out,
                format!(
                    "the merged folder must lie outside the shard {}",
                    run.dir.root().display()
                ),
            ));
        }
    }
    let first = &runs[0];
    let recorded_shards: Vec<Option<PathBuf>> = runs
        .iter()
        .map(|r| {
            r.manifest
                .value()
                .get("rerun")
                .and_then(Value::as_str)
                .map(PathBuf::from)
        })
        .collect();
    let rerun_episodes = first
        .manifest
        .value()
        .get("rerun_episodes")
        .and_then(Value::as_u64)
        .unwrap_or(0) as usize;
    match (&opts.rerun, recorded_shards.iter().all(Option::is_some)) {
        (None, true) => {
            return Err(MergeError::RecordingUnnamed {
                manifest: first.manifest.path().to_path_buf(),
            })
        }
        (Some(p), false) => return Err(MergeError::NothingRecorded { file: p.clone() }),
        _ => {}
    }
    progress.set_total(6);
    std::fs::create_dir_all(out).map_err(write_io(out))?;
    let _lock = DirLock::acquire(out, "merge", opts.lock)?;
    sweep_stale(out).map_err(write_io(out))?;

    // Episodes: every shard's rows, in episode-id order.
    let schema = first.episodes.schema();
    let mut owner: BTreeMap<String, (usize, usize)> = BTreeMap::new();
    for (s, run) in runs.iter().enumerate() {
        let path = run.dir.episodes();
        if run.episodes.schema() != schema {
            return Err(shard_error(&path, "schema differs from the first shard's"));
        }
        let ids = episode_ids(&run.episodes, &path)?;
        for r in 0..ids.len() {
            if owner.insert(ids.value(r).to_string(), (s, r)).is_some() {
                return Err(shard_error(
                    &path,
                    format!("episode `{}` was also run by another shard", ids.value(r)),
                ));
            }
        }
    }
    let all: Vec<&RecordBatch> = runs.iter().map(|r| &r.episodes).collect();
    let offsets: Vec<usize> = all
        .iter()
        .scan(0, |acc, b| {
            let at = *acc;
            *acc += b.num_rows();
            Some(at)
        })
        .collect();
    let joined =
        arrow::compute::concat_batches(&schema, all.iter().copied()).map_err(MergeError::Join)?;
    let take: UInt32Array = owner
        .values()
        .map(|&(s, r)| (offsets[s] + r) as u32)
        .collect();
    let merged = arrow::compute::take_record_batch(&joined, &take).map_err(MergeError::Join)?;
    let out_dir = RunDir::new(out);
    let episodes_path = out_dir.episodes();
    write_episode_batch(&episodes_path, merged.clone()).map_err(MergeError::WriteTable)?;
    progress.advance(1);

    // Metrics: aggregates over the merged rows, failures in episode order.
    let (rows, ids) = metric_rows(&merged, &episodes_path)?;
    let mut failures: Vec<FailedEpisode> = runs
        .iter()
        .flat_map(|r| r.failures.iter().cloned())
        .collect();
    failures.sort_by(|a, b| (&a.episode_id, &a.error).cmp(&(&b.episode_id, &b.error)));
    let metrics: Vec<(&str, EpisodeMetrics)> = ids
        .iter()
        .map(String::as_str)
        .zip(rows.iter().filter_map(|r| r.3))
        .collect();
    // Failed episodes count as failures in their groups (they add nothing to any sum, so
    // where they sit among the rows changes no byte).
    let mut all_rows = rows.clone();
    all_rows.extend(failures.iter().map(FailedEpisode::metric_row));
    write_metrics(out, &aggregate(&all_rows), &metrics, &failures)
        .map_err(|e| MergeError::WriteRun(Box::new(e)))?;
    progress.advance(1);

    // Trajectories: each episode's rows from its shard, re-batched as a run joins its parts.
    let mut trajectories = Vec::new();
    for run in &runs {
        let path = run.dir.trajectories();
        let table = read_table(&path).map_err(MergeError::ShardTable)?;
        let ranges = episode_ranges(&table, &path)?;
        trajectories.push((path, table, ranges));
    }
    let mut pieces = Vec::with_capacity(owner.len());
    for (id, &(s, _)) in &owner {
        let (path, table, ranges) = &trajectories[s];
        let &(start, len) = ranges
            .get(id)
            .ok_or_else(|| shard_error(path, format!("no steps of episode `{id}`")))?;
        pieces.push(table.slice(start, len));
    }
    write_trajectory_pieces(&out_dir.trajectories(), pieces).map_err(MergeError::WriteTable)?;
    progress.advance(1);

    // Observations: each episode's row groups, copied.
    let obs_paths: Vec<PathBuf> = runs.iter().map(|r| r.dir.observations()).collect();
    let mut groups_of: BTreeMap<String, Vec<(usize, usize)>> = BTreeMap::new();
    for (s, path) in obs_paths.iter().enumerate() {
        for (g, id) in row_group_episodes(path)
            .map_err(MergeError::ShardTable)?
            .into_iter()
            .enumerate()
        {
            groups_of.entry(id).or_default().push((s, g));
        }
    }
    let mut groups: Vec<(&Path, usize)> = Vec::new();
    for (id, &(s, _)) in &owner {
        let mine = groups_of.get(id).ok_or_else(|| {
            shard_error(&obs_paths[s], format!("no observations of episode `{id}`"))
        })?;
        groups.extend(mine.iter().map(|&(s, g)| (obs_paths[s].as_path(), g)));
    }
    let obs_schema =
        crate::parquet_io::read_batches_with(&obs_paths[0], |b| Ok(b.with_row_groups(vec![])))
            .map(|r| arrow::array::RecordBatchReader::schema(&r))
            .map_err(|e| MergeError::ShardTable(e.into()))?;
    copy_row_groups_from(&groups, obs_schema, &out_dir.observations())
        .map_err(MergeError::WriteTable)?;
    progress.advance(1);

    // The rerun recording: the first episodes of the whole run that finished.
    let mut recorded = 0;
    if let Some(rerun) = &opts.rerun {
        let mut everyone: Vec<&str> = owner.keys().map(String::as_str).collect();
        everyone.extend(failures.iter().map(|f| f.episode_id.as_str()));
        everyone.sort_unstable();
        let wanted: Vec<&str> = everyone
            .into_iter()
            .take(rerun_episodes)
            .filter(|id| owner.contains_key(*id))
            .collect();
        let mut by_id = BTreeMap::new();
        for path in recorded_shards.iter().flatten() {
            for (id, msgs) in recordings_of(path).map_err(MergeError::ShardRecording)? {
                by_id.insert(id, (path.clone(), msgs));
            }
        }
        let mut chosen = Vec::with_capacity(wanted.len());
        for id in &wanted {
            let (_, msgs) = by_id.get(*id).ok_or_else(|| {
                let s = owner[*id].0;
                MergeError::Shards(format!(
                    "{}: no recording of episode `{id}`",
                    recorded_shards[s]
                        .as_deref()
                        .unwrap_or(Path::new("?"))
                        .display()
                ))
            })?;
            chosen.push(msgs.as_slice());
        }
        write_recordings(rerun, chosen)?;
        recorded = wanted.len();
    }
    progress.advance(1);

    let mut manifest = first.manifest.value().clone();
    // The shards' scenes, each once, in id order (as one run over all the episodes lists them).
    let mut scenes: Vec<Value> = runs
        .iter()
        .flat_map(|s| {
            s.manifest
                .value()
                .get("scenes")
                .and_then(Value::as_array)
                .cloned()
                .unwrap_or_default()
        })
        .collect();
    let id = |v: &Value| {
        v.get("id")
            .and_then(Value::as_str)
            .unwrap_or("")
            .to_string()
    };
    scenes.sort_by_key(|v| id(v));
    scenes.dedup_by_key(|v| id(v));
    let mut lists_files = false;
    if let Some(map) = manifest.as_object_mut() {
        if map.contains_key("scenes") {
            map.insert("scenes".into(), Value::Array(scenes));
        }
        // The merged folder's own files, once everything else is written.
        lists_files = map.remove("files").is_some();
        map.insert("shard".into(), Value::String(Shard::ALL.to_string()));
        map.insert("command".into(), serde_json::json!(opts.command));
        map.insert(
            "rerun".into(),
            serde_json::json!(opts.rerun.as_ref().map(|p| p.display().to_string())),
        );
    }

    if first.lerobot {
        // The step is the shards' (the merged manifest keeps their `body`): a shard's
        // manifest without one is the shard's problem.
        first.manifest.step().map_err(MergeError::ShardManifest)?;
        let merged = RunManifest::new(out_dir.manifest(), manifest);
        write_lerobot(&out_dir, &merged, first.lerobot_video)
            .map_err(|e| MergeError::WriteRun(Box::new(e)))?;
        manifest = merged.into_value();
    }
    progress.advance(1);

    if lists_files {
        manifest["files"] = crate::pipeline::rollout::manifest::files_of(out)
            .map_err(|e| MergeError::WriteRun(Box::new(e)))?;
    }
    let path = out_dir.manifest();
    // A JSON value always serialises.
    let bytes = serde_json::to_vec_pretty(&manifest).unwrap_or_default();
    write_bytes_atomic(&path, &bytes).map_err(write_io(&path))?;
    Ok(MergeReport {
        shards: shards.len(),
        episodes: owner.len(),
        failures: failures.len(),
        recorded,
        written: vec![
            episodes_path,
            out_dir.metrics(),
            out_dir.trajectories(),
            out_dir.observations(),
            path,
        ],
    })
}
