//! The `meta/` files of a LeRobot v3.0 dataset: `info.json`, `stats.json`, `tasks.parquet`
//! (tasks as a pandas index, as LeRobot reads them) and `episodes/chunk-*/file-*.parquet`
//! (one row per episode: its tasks, length, where its frames are, and its statistics).

use crate::file_error::FileError;
use std::collections::BTreeMap;
use std::fs::File;
use std::path::Path;
use std::sync::Arc;

use arrow::array::{
    ArrayRef, Float64Array, Float64Builder, Int64Array, Int64Builder, ListBuilder, RecordBatch,
    StringArray, StringBuilder,
};
use arrow::datatypes::{Field, Schema};
use parquet::arrow::arrow_writer::ArrowWriterOptions;
use parquet::arrow::ArrowWriter;
use parquet::file::metadata::KeyValue;
use serde_json::{json, Value};

use super::features::{Camera, Feature};
use super::layout::{self, FileIndex, CHUNK_SIZE, DATA_PATH, VIDEO_PATH};
use super::stats::{FeatureStats, StatLayout};
use super::{compact_columns, write_error, zstd, LerobotError};
use parquet::file::properties::{EnabledStatistics, WriterProperties};

/// LeRobot's format version this module writes.
pub const CODEBASE_VERSION: &str = "v3.0";

/// Largest data file before the next episode starts a new one (LeRobot's default), MB.
pub const DATA_FILE_MB: u64 = 100;

/// One row of `meta/episodes`.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeMeta {
    /// LeRobot's episode index.
    pub episode_index: i64,
    /// Its task (instruction).
    pub task: String,
    /// Frames.
    pub length: i64,
    /// The data file holding its frames.
    pub data: FileIndex,
    /// Dataset index of its first frame.
    pub from_index: i64,
    /// One past its last frame's dataset index.
    pub to_index: i64,
    /// minos's episode id.
    pub episode_id: String,
    /// minos's scene id.
    pub scene_id: String,
    /// Statistics per feature, in feature order.
    pub stats: Vec<FeatureStats>,
    /// Where its frames are in each video feature's files, in feature order.
    pub videos: Vec<VideoPlace>,
}

/// An episode's place in one camera's video files.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VideoPlace {
    /// The video file.
    pub file: FileIndex,
    /// When its first frame is shown, seconds from the file's start.
    pub from_timestamp: f64,
    /// When its last frame ends.
    pub to_timestamp: f64,
}

/// Episode rows per `meta/episodes` file.
pub const EPISODES_PER_META_FILE: usize = 1000;

/// Writes one Parquet file of `batch` (zstd, the numeric columns compacted, no column
/// statistics: a reader filters these few rows in memory), its schema metadata also as the
/// file's key-value metadata (where pandas and pyarrow write theirs). `arrow_schema`: also
/// the serialised Arrow schema (`ARROW:schema`); without it readers take the types from
/// the Parquet schema, which says all of them for plain integers, floats, strings and lists
/// (it was a quarter of a `meta/episodes` file of 60 episodes).
fn write_parquet(path: &Path, batch: &RecordBatch, arrow_schema: bool) -> Result<(), LerobotError> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)
            .map_err(|source| LerobotError::Io(FileError::new(dir, source)))?;
    }
    let file =
        File::create(path).map_err(|source| LerobotError::Io(FileError::new(path, source)))?;
    let builder = WriterProperties::builder()
        .set_compression(zstd())
        .set_statistics_enabled(EnabledStatistics::None)
        .set_key_value_metadata(Some(
            batch
                .schema()
                .metadata()
                .iter()
                .map(|(k, v)| KeyValue::new(k.clone(), v.clone()))
                .collect(),
        ));
    let props = compact_columns(builder, &batch.schema())
        .map_err(|e| write_error(path, e))?
        .build();
    let options = ArrowWriterOptions::new()
        .with_properties(props)
        .with_skip_arrow_metadata(!arrow_schema);
    let mut w = ArrowWriter::try_new_with_options(file, batch.schema(), options)
        .map_err(|e| write_error(path, e))?;
    w.write(batch).map_err(|e| write_error(path, e))?;
    w.close().map_err(|e| write_error(path, e))?;
    Ok(())
}

/// Writes `meta/tasks.parquet`: `task_index` and the task text as the pandas index `task`.
pub fn write_tasks(root: &Path, tasks: &[String]) -> Result<(), LerobotError> {
    let pandas = json!({
        "index_columns": ["task"],
        "column_indexes": [{"name": null, "field_name": null, "pandas_type": "unicode", "numpy_type": "object", "metadata": {"encoding": "UTF-8"}}],
        "columns": [
            {"name": "task_index", "field_name": "task_index", "pandas_type": "int64", "numpy_type": "int64", "metadata": null},
            {"name": "task", "field_name": "task", "pandas_type": "unicode", "numpy_type": "object", "metadata": null},
        ],
        "attributes": {},
        "creator": {"library": "minos", "version": env!("CARGO_PKG_VERSION")},
        "pandas_version": "2.2.0",
    });
    let schema = Arc::new(
        Schema::new(vec![
            Field::new("task_index", arrow::datatypes::DataType::Int64, true),
            Field::new("task", arrow::datatypes::DataType::Utf8, true),
        ])
        .with_metadata([("pandas".to_string(), pandas.to_string())].into()),
    );
    let path = root.join(layout::TASKS);
    let batch = RecordBatch::try_new(
        schema,
        vec![
            Arc::new((0..tasks.len() as i64).collect::<Int64Array>()),
            Arc::new(StringArray::from_iter_values(tasks)),
        ],
    )
    .map_err(|e| write_error(&path, e))?;
    write_parquet(&path, &batch, true)
}

/// A list column of f64 lists nested `depth` deep (1: `[v]`, 3: `[[[v]]]`) from JSON.
fn nested_f64(values: &[&Value], depth: usize) -> ArrayRef {
    fn num(v: &Value) -> Option<f64> {
        v.as_f64()
    }
    fn items(v: &Value) -> &[Value] {
        v.as_array().map(|a| a.as_slice()).unwrap_or(&[])
    }
    if depth == 1 {
        let mut b = ListBuilder::new(Float64Builder::new());
        for v in values {
            for x in items(v) {
                b.values().append_option(num(x));
            }
            b.append(true);
        }
        Arc::new(b.finish())
    } else {
        let mut b = ListBuilder::new(ListBuilder::new(ListBuilder::new(Float64Builder::new())));
        for v in values {
            for a in items(v) {
                for bb in items(a) {
                    for x in items(bb) {
                        b.values().values().values().append_option(num(x));
                    }
                    b.values().values().append(true);
                }
                b.values().append(true);
            }
            b.append(true);
        }
        Arc::new(b.finish())
    }
}

/// Writes `meta/episodes/chunk-*/file-*.parquet` ([`EPISODES_PER_META_FILE`] rows each).
pub fn write_episodes(
    root: &Path,
    episodes: &[EpisodeMeta],
    features: &[Feature],
) -> Result<(), LerobotError> {
    let mut place = FileIndex::default();
    for (k, rows) in episodes.chunks(EPISODES_PER_META_FILE).enumerate() {
        if k > 0 {
            place = place.next();
        }
        let path = root.join(place.path(layout::EPISODES));
        let mut fields = Vec::new();
        let mut columns: Vec<ArrayRef> = Vec::new();
        let mut push = |name: &str, column: ArrayRef| {
            fields.push(Field::new(name, column.data_type().clone(), true));
            columns.push(column);
        };
        let ints = |f: &dyn Fn(&EpisodeMeta) -> i64| -> ArrayRef {
            Arc::new(rows.iter().map(f).collect::<Int64Array>())
        };
        push("episode_index", ints(&|e| e.episode_index));
        let mut tasks = ListBuilder::new(StringBuilder::new());
        for e in rows {
            tasks.values().append_value(&e.task);
            tasks.append(true);
        }
        push("tasks", Arc::new(tasks.finish()));
        push("length", ints(&|e| e.length));
        push("data/chunk_index", ints(&|e| e.data.chunk as i64));
        push("data/file_index", ints(&|e| e.data.file as i64));
        push("dataset_from_index", ints(&|e| e.from_index));
        push("dataset_to_index", ints(&|e| e.to_index));
        let video_keys = features.iter().filter(|f| !f.in_data()).map(|f| &f.key);
        for (v, key) in video_keys.enumerate() {
            let at = |e: &EpisodeMeta| e.videos.get(v).copied();
            push(
                &layout::video_column(key, "chunk_index"),
                Arc::new(
                    rows.iter()
                        .map(|e| at(e).map(|p| p.file.chunk as i64))
                        .collect::<Int64Array>(),
                ),
            );
            push(
                &layout::video_column(key, "file_index"),
                Arc::new(
                    rows.iter()
                        .map(|e| at(e).map(|p| p.file.file as i64))
                        .collect::<Int64Array>(),
                ),
            );
            push(
                &layout::video_column(key, "from_timestamp"),
                Arc::new(
                    rows.iter()
                        .map(|e| at(e).map(|p| p.from_timestamp))
                        .collect::<Float64Array>(),
                ),
            );
            push(
                &layout::video_column(key, "to_timestamp"),
                Arc::new(
                    rows.iter()
                        .map(|e| at(e).map(|p| p.to_timestamp))
                        .collect::<Float64Array>(),
                ),
            );
        }
        push("meta/episodes/chunk_index", ints(&|_| place.chunk as i64));
        push("meta/episodes/file_index", ints(&|_| place.file as i64));
        push(
            "minos/episode_id",
            Arc::new(StringArray::from_iter_values(
                rows.iter().map(|e| e.episode_id.as_str()),
            )),
        );
        push(
            "minos/scene_id",
            Arc::new(StringArray::from_iter_values(
                rows.iter().map(|e| e.scene_id.as_str()),
            )),
        );
        for (fi, f) in features.iter().enumerate() {
            let layout = f.stat_layout();
            let named: Vec<Vec<(&'static str, Value)>> =
                rows.iter().map(|e| e.stats[fi].named(layout)).collect();
            let Some(first) = named.first() else { continue };
            for (si, (stat, _)) in first.iter().enumerate() {
                let values: Vec<&Value> = named.iter().map(|n| &n[si].1).collect();
                let column: ArrayRef = if *stat == "count" {
                    let mut b = ListBuilder::new(Int64Builder::new());
                    for v in &values {
                        for x in v.as_array().map(|a| a.as_slice()).unwrap_or(&[]) {
                            b.values().append_option(x.as_i64());
                        }
                        b.append(true);
                    }
                    Arc::new(b.finish())
                } else {
                    nested_f64(&values, if layout == StatLayout::Image { 3 } else { 1 })
                };
                push(&format!("stats/{}/{stat}", f.key), column);
            }
        }
        let batch = RecordBatch::try_new(Arc::new(Schema::new(fields)), columns)
            .map_err(|e| write_error(&path, e))?;
        write_parquet(&path, &batch, false)?;
    }
    Ok(())
}

/// The dataset statistics (`meta/stats.json`): each feature's episodes combined.
pub fn stats_json(episodes: &[EpisodeMeta], features: &[Feature]) -> Value {
    let mut out = serde_json::Map::new();
    for (fi, f) in features.iter().enumerate() {
        let parts: Vec<&FeatureStats> = episodes.iter().map(|e| &e.stats[fi]).collect();
        if let Some(all) = FeatureStats::aggregate(&parts) {
            let named: serde_json::Map<String, Value> = all
                .named(f.stat_layout())
                .into_iter()
                .map(|(k, v)| (k.to_string(), v))
                .collect();
            out.insert(f.key.clone(), Value::Object(named));
        }
    }
    Value::Object(out)
}

/// `splits` of `info.json`: each split's contiguous episode range (`"0:12"`). Episodes are
/// in id order, so a split is contiguous only when the run's episodes were; when they are
/// not, or have no split, every episode is `train` (LeRobot's default).
pub fn splits(episodes: &[(String, usize)], total: usize) -> Value {
    let mut ranges: BTreeMap<&str, (usize, usize, usize)> = BTreeMap::new();
    for (split, index) in episodes {
        let r = ranges.entry(split.as_str()).or_insert((*index, *index, 0));
        r.0 = r.0.min(*index);
        r.1 = r.1.max(*index);
        r.2 += 1;
    }
    let contiguous = ranges
        .iter()
        .all(|(name, (lo, hi, n))| !name.is_empty() && hi - lo + 1 == *n);
    if total > 0 && contiguous {
        Value::Object(
            ranges
                .into_iter()
                .map(|(name, (lo, hi, _))| (name.to_string(), json!(format!("{lo}:{}", hi + 1))))
                .collect(),
        )
    } else {
        json!({"train": format!("0:{total}")})
    }
}

/// How the dataset whose `meta/info.json` is `info` encodes its video features: `None`
/// without video (no `video_path`); a feature that records no quantiser (minos before
/// `minos.video_qp`) was encoded at [`super::video::DEFAULT_QP`].
pub fn video_settings(info: &Value) -> Option<super::video::VideoSettings> {
    if info.get("video_path").is_none_or(|p| p.is_null()) {
        return None;
    }
    let recorded = info
        .get("features")
        .and_then(|f| f.as_object())
        .into_iter()
        .flat_map(|f| f.values())
        .filter(|f| f.get("dtype").and_then(|d| d.as_str()) == Some("video"))
        .find_map(|f| f.pointer("/info/minos.video_qp").and_then(|q| q.as_u64()));
    Some(
        recorded
            .and_then(|q| u8::try_from(q).ok())
            .and_then(super::video::VideoSettings::with_qp)
            .unwrap_or_default(),
    )
}

/// The contents of `meta/info.json`.
#[allow(clippy::too_many_arguments)]
pub fn info_json(
    features: &[Feature],
    cameras: &[Camera],
    robot_type: &str,
    fps: u32,
    total_episodes: usize,
    total_frames: i64,
    total_tasks: usize,
    splits: Value,
) -> Value {
    let has_video = features.iter().any(|f| !f.in_data());
    let feats: serde_json::Map<String, Value> = features
        .iter()
        .map(|f| (f.key.clone(), f.info(cameras)))
        .collect();
    json!({
        "codebase_version": CODEBASE_VERSION,
        "robot_type": robot_type,
        "total_episodes": total_episodes,
        "total_frames": total_frames,
        "total_tasks": total_tasks,
        "chunks_size": CHUNK_SIZE,
        "data_files_size_in_mb": DATA_FILE_MB,
        "video_files_size_in_mb": super::video::VIDEO_FILE_MB,
        "fps": fps,
        "splits": splits,
        "data_path": DATA_PATH,
        "video_path": if has_video { json!(VIDEO_PATH) } else { Value::Null },
        "features": feats,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_are_ranges_only_when_contiguous() {
        let eps = |v: &[&str]| -> Vec<(String, usize)> {
            v.iter()
                .enumerate()
                .map(|(i, s)| (s.to_string(), i))
                .collect()
        };
        assert_eq!(
            splits(&eps(&["train", "train", "val"]), 3),
            json!({"train": "0:2", "val": "2:3"})
        );
        assert_eq!(
            splits(&eps(&["train", "val", "train"]), 3),
            json!({"train": "0:3"})
        );
        assert_eq!(splits(&eps(&["", ""]), 2), json!({"train": "0:2"}));
    }

    #[test]
    fn a_datasets_video_settings_are_read_back_from_its_info() {
        let info = |qp: Value| {
            json!({
                "video_path": VIDEO_PATH,
                "features": {
                    "observation.state": {"dtype": "float32", "info": null},
                    "observation.images.color": {"dtype": "video", "info": {"minos.video_qp": qp}},
                },
            })
        };
        let qp = |v: Option<super::super::video::VideoSettings>| v.map(|s| s.qp);
        assert_eq!(qp(video_settings(&info(json!(34)))), Some(34));
        // Written before minos recorded it: the quantiser there was, the default.
        assert_eq!(qp(video_settings(&info(Value::Null))), Some(26));
        assert_eq!(qp(video_settings(&info(json!(99)))), Some(26));
        // No video path: no video.
        let mut images = info(json!(34));
        images["video_path"] = Value::Null;
        assert_eq!(qp(video_settings(&images)), None);
        assert_eq!(qp(video_settings(&json!({}))), None);
    }
}
