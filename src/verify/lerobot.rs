//! A LeRobot v3.0 dataset: checksums (`meta/provenance.json`), the data files' schema
//! against `info.json`, index continuity, episode boundaries against `meta/episodes`, the
//! totals, every image decoding with its declared shape, and the statistics recomputed from
//! the frames with the exporter's own functions (per episode bit for bit; `stats.json` as
//! LeRobot aggregates them, to the precision of its JSON numbers).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use arrow::array::{Array, AsArray, RecordBatch};
use arrow::datatypes::{DataType, Schema};
use serde_json::Value;

use super::{checksums, quote, read_json, tables, Found};
use crate::invalid::Invalid;
use crate::io::lerobot::image_file::{decode, ImageFile};
use crate::io::lerobot::layout::{self, FileIndex, PROVENANCE};
use crate::io::lerobot::stats::{FeatureStats, StatLayout};
use crate::parquet_io::read_batches;
use crate::progress::Progress;
use crate::render::Image;

/// Checks the LeRobot dataset `root` with its provenance record.
pub(super) fn check(root: &Path, found: &mut Found, progress: &dyn Progress) {
    let record = root.join(PROVENANCE);
    if record.is_file() {
        if let Some(v) = read_json(&record, found) {
            checksums::check(
                root,
                &record,
                v.get("files"),
                Some(&[PROVENANCE]),
                found,
                progress,
            );
        }
    } else {
        found.problem(&record, "file", "missing: no checksums to compare");
    }
    check_dataset(root, found);
}

/// One feature as `info.json` declares it.
struct Declared {
    key: String,
    dtype: String,
    shape: Vec<u64>,
}

impl Declared {
    fn is_image(&self) -> bool {
        self.dtype == "image"
    }

    /// A video feature: in `videos/`, not a column of the data files.
    fn is_video(&self) -> bool {
        self.dtype == "video"
    }

    fn layout(&self) -> StatLayout {
        if self.is_image() || self.is_video() || self.shape.len() == 3 {
            StatLayout::Image
        } else {
            StatLayout::Flat
        }
    }

    fn describe(&self) -> String {
        format!("{} {:?}", self.dtype, self.shape)
    }

    /// Whether a column of type `t` holds this feature.
    fn accepts(&self, t: &DataType) -> bool {
        let scalar = |t: &DataType| match self.dtype.as_str() {
            "float32" => t == &DataType::Float32,
            "float64" => t == &DataType::Float64,
            "int64" => t == &DataType::Int64,
            "bool" => t == &DataType::Boolean,
            "uint8" => t == &DataType::UInt8,
            "uint16" => t == &DataType::UInt16,
            "uint32" => t == &DataType::UInt32,
            _ => false,
        };
        let inner = |t: &DataType| match t {
            DataType::List(f) | DataType::FixedSizeList(f, _) => Some(f.data_type().clone()),
            _ => None,
        };
        if self.is_image() {
            return matches!(t, DataType::Struct(fields)
                if fields.iter().any(|f| f.name() == "bytes" && f.data_type() == &DataType::Binary));
        }
        match self.shape[..] {
            [1] => scalar(t),
            [n] => match t {
                DataType::FixedSizeList(f, len) => *len as u64 == n && scalar(f.data_type()),
                DataType::List(f) => scalar(f.data_type()),
                _ => false,
            },
            [_, _, _] => inner(t)
                .and_then(|t| inner(&t))
                .and_then(|t| inner(&t))
                .is_some_and(|t| scalar(&t)),
            _ => false,
        }
    }
}

/// What one feature's frames of the current episode add up to.
enum Acc {
    /// Values per channel.
    Channels(Vec<Vec<f64>>),
    /// 8-bit pictures: a histogram per channel.
    Histograms(Vec<[u64; 256]>),
}

impl Acc {
    fn stats(self, frames: u64) -> FeatureStats {
        match self {
            Acc::Channels(mut c) => FeatureStats::of_channels(&mut c, frames),
            Acc::Histograms(mut h) => {
                if h.len() == 1 {
                    h = vec![h[0]; 3];
                }
                FeatureStats::of_histograms(&h, frames)
            }
        }
    }
}

/// The episode being read.
struct Current {
    episode: i64,
    frames: u64,
    first_index: i64,
    file: (u64, u64),
    acc: Vec<Option<Acc>>,
}

/// One row of `meta/episodes`.
pub(super) struct EpisodeRow {
    /// The `meta/episodes` file.
    pub(super) path: PathBuf,
    /// Its rows.
    pub(super) batch: RecordBatch,
    /// The episode's row.
    pub(super) row: usize,
}

/// Checks the dataset's files against each other; the frames it holds, when known.
pub(super) fn check_dataset(root: &Path, found: &mut Found) -> Option<usize> {
    let info_path = root.join(layout::INFO);
    let info = read_json(&info_path, found)?;
    let fps = info.get("fps").and_then(Value::as_u64).unwrap_or(0);
    if fps == 0 {
        found.problem(&info_path, "fps", "missing or not a positive integer");
    }
    let declared: Vec<Declared> = info
        .get("features")
        .and_then(Value::as_object)
        .map(|m| {
            m.iter()
                .map(|(k, v)| Declared {
                    key: k.clone(),
                    dtype: v.get("dtype").and_then(Value::as_str).unwrap_or("").into(),
                    shape: v
                        .get("shape")
                        .and_then(Value::as_array)
                        .map(|a| a.iter().filter_map(Value::as_u64).collect())
                        .unwrap_or_default(),
                })
                .collect()
        })
        .unwrap_or_default();
    if declared.is_empty() {
        found.problem(&info_path, "features", "no features declared");
        return None;
    }

    // meta/episodes, by episode index.
    let mut metas: HashMap<i64, EpisodeRow> = HashMap::new();
    let mut meta_rows = 0usize;
    for path in parquet_files(&root.join(layout::EPISODES)) {
        let Some(batch) = tables::read(&path, found) else {
            continue;
        };
        match tables::numbers(&batch, "episode_index") {
            Err(e) => found.problem(&path, "schema", e),
            Ok(idx) => {
                for (row, e) in idx.iter().enumerate() {
                    meta_rows += 1;
                    metas.insert(
                        *e as i64,
                        EpisodeRow {
                            path: path.clone(),
                            batch: batch.clone(),
                            row,
                        },
                    );
                }
            }
        }
    }

    let mut all_stats: Vec<Vec<FeatureStats>> = vec![Vec::new(); declared.len()];
    let mut index: i64 = 0;
    let mut episodes_seen = 0usize;
    let mut current: Option<Current> = None;
    let data_files = parquet_files(&root.join(layout::DATA));
    if data_files.is_empty() {
        found.problem(&root.join(layout::DATA), "file", "no data files");
    }
    for path in &data_files {
        let place = file_place(path);
        let batches = match read_batches(path) {
            Ok(b) => b,
            Err(e) => {
                found.problem(
                    path,
                    "file",
                    tables::strip_path(&crate::escape::error_line(&e), path),
                );
                continue;
            }
        };
        let schema = arrow::array::RecordBatchReader::schema(&batches);
        let columns = match schema_columns(path, &schema, &declared, found) {
            Some(c) => c,
            None => continue,
        };
        let mut row_in_file = 0usize;
        for batch in batches {
            let batch = match batch {
                Ok(b) => b,
                Err(e) => {
                    found.problem(
                        path,
                        format!("rows from {row_in_file}"),
                        crate::escape::error_line(&e),
                    );
                    break;
                }
            };
            let num = |name: &str| tables::numbers(&batch, name).unwrap_or_default();
            let (idx, ep, frame, ts) = (
                num("index"),
                num("episode_index"),
                num("frame_index"),
                num("timestamp"),
            );
            for r in 0..batch.num_rows() {
                let e = ep.get(r).copied().unwrap_or(f64::NAN) as i64;
                let f = frame.get(r).copied().unwrap_or(f64::NAN);
                let record = format!("row {} (episode {e} frame {f})", row_in_file + r);
                if current.as_ref().is_none_or(|c| c.episode != e) {
                    if let Some(done) = current.take() {
                        finish(done, &declared, &metas, &mut all_stats, found);
                    }
                    let expected = episodes_seen as i64;
                    if e != expected {
                        found.problem(
                            path,
                            record.as_str(),
                            format!("episode_index {e} where {expected} comes next"),
                        );
                    }
                    episodes_seen += 1;
                    current = Some(Current {
                        episode: e,
                        frames: 0,
                        first_index: index,
                        file: place,
                        acc: declared.iter().map(|_| None).collect(),
                    });
                }
                let Some(cur) = current.as_mut() else {
                    continue;
                };
                if idx.get(r).copied() != Some(index as f64) {
                    found.problem(
                        path,
                        record.as_str(),
                        format!(
                            "index {} where {index} comes next",
                            quote(idx.get(r).copied().unwrap_or(f64::NAN))
                        ),
                    );
                }
                if f != cur.frames as f64 {
                    found.problem(
                        path,
                        record.as_str(),
                        format!("frame_index {f} where {} comes next", cur.frames),
                    );
                }
                let want_ts = cur.frames as f32 / fps.max(1) as f32;
                if let Some(t) = ts.get(r) {
                    if *t as f32 != want_ts {
                        found.problem(
                            path,
                            record.as_str(),
                            format!(
                                "timestamp {t} where frame {} at {fps} fps is {want_ts}",
                                cur.frames
                            ),
                        );
                    }
                }
                for (k, d) in declared.iter().enumerate() {
                    let Some(c) = columns[k] else { continue };
                    let col = batch.column(c);
                    if let Err(message) = accumulate(d, col.as_ref(), r, &mut cur.acc[k]) {
                        found.problem(path, record.as_str(), format!("`{}`: {message}", d.key));
                    }
                }
                cur.frames += 1;
                index += 1;
            }
            row_in_file += batch.num_rows();
        }
    }
    if let Some(done) = current.take() {
        finish(done, &declared, &metas, &mut all_stats, found);
    }

    // Totals.
    let total = |key: &str| info.get(key).and_then(Value::as_u64);
    if total("total_episodes") != Some(episodes_seen as u64) {
        found.problem(
            &info_path,
            "total_episodes",
            format!(
                "{} where the data files hold {episodes_seen} episodes",
                quote(info.get("total_episodes").unwrap_or(&Value::Null))
            ),
        );
    }
    if total("total_frames") != Some(index as u64) {
        found.problem(
            &info_path,
            "total_frames",
            format!(
                "{} where the data files hold {index} frames",
                quote(info.get("total_frames").unwrap_or(&Value::Null))
            ),
        );
    }
    if meta_rows != episodes_seen {
        found.problem(
            &root.join(layout::EPISODES),
            "rows",
            format!("{meta_rows} episode rows where the data files hold {episodes_seen} episodes"),
        );
    }
    dataset_stats(root, &declared, &all_stats, found);
    let videos: Vec<(String, Vec<u64>)> = declared
        .iter()
        .filter(|d| d.is_video())
        .map(|d| (d.key.clone(), d.shape.clone()))
        .collect();
    super::video::check(root, &info, fps, &videos, &metas, found);
    found.checked.push(format!(
        "LeRobot: {episodes_seen} episodes, {index} frames, statistics recomputed"
    ));
    Some(index as usize)
}

/// The data files' column for each declared feature (`None` where missing or mistyped, which
/// is a problem), and a problem for each undeclared column.
fn schema_columns(
    path: &Path,
    schema: &Schema,
    declared: &[Declared],
    found: &mut Found,
) -> Option<Vec<Option<usize>>> {
    let mut out = Vec::with_capacity(declared.len());
    for d in declared {
        if d.is_video() {
            // In `videos/` (checked by `video::check`).
            if schema.index_of(&d.key).is_ok() {
                found.problem(
                    path,
                    format!("column `{}`", d.key),
                    "a video feature of info.json stored as a column",
                );
            }
            out.push(None);
            continue;
        }
        match schema.index_of(&d.key) {
            Err(_) => {
                found.problem(
                    path,
                    format!("column `{}`", d.key),
                    format!("missing (info.json declares {})", d.describe()),
                );
                out.push(None);
            }
            Ok(i) => {
                let t = schema.field(i).data_type();
                if d.accepts(t) {
                    out.push(Some(i));
                } else {
                    found.problem(
                        path,
                        format!("column `{}`", d.key),
                        format!("type {t} where info.json declares {}", d.describe()),
                    );
                    out.push(None);
                }
            }
        }
    }
    for f in schema.fields() {
        if !declared.iter().any(|d| &d.key == f.name() && !d.is_video()) {
            found.problem(
                path,
                format!("column `{}`", f.name()),
                "not a feature of info.json",
            );
        }
    }
    Some(out)
}

/// Adds row `r` of `col` (feature `d`) to the episode's accumulator; images are decoded and
/// their shape checked.
fn accumulate(
    d: &Declared,
    col: &dyn Array,
    r: usize,
    acc: &mut Option<Acc>,
) -> Result<(), Invalid> {
    if col.is_null(r) {
        return Err("null".into());
    }
    if d.is_image() {
        let bytes = col
            .as_struct()
            .column_by_name("bytes")
            .map(|b| b.as_binary::<i32>().value(r).to_vec())
            .unwrap_or_default();
        let frame = decode(&bytes)?;
        let c = u64::from(frame.file.channels());
        let got = [u64::from(frame.height), u64::from(frame.width), c];
        if d.shape[..] != got {
            return Err(format!(
                "a {}×{}×{c} image where info.json declares {:?}",
                frame.height, frame.width, d.shape
            )
            .into());
        }
        let a = acc.get_or_insert_with(|| {
            if frame.file.scaled() {
                Acc::Histograms(vec![[0; 256]; c as usize])
            } else {
                Acc::Channels(vec![Vec::new(); c as usize])
            }
        });
        match (a, &frame.image) {
            (Acc::Histograms(h), Image::U8 { data, .. })
                if matches!(frame.file, ImageFile::Ppm | ImageFile::Pgm8) =>
            {
                let n = h.len().max(1);
                for px in data.chunks_exact(n) {
                    for (k, v) in px.iter().enumerate() {
                        h[k][*v as usize] += 1;
                    }
                }
            }
            (Acc::Channels(ch), img) if !frame.file.scaled() => {
                let values: Vec<f64> = match img {
                    Image::U8 { data, .. } => data.iter().map(|v| f64::from(*v)).collect(),
                    Image::U16(d) => d.iter().map(|v| f64::from(*v)).collect(),
                    Image::U32(d) => d.iter().map(|v| f64::from(*v)).collect(),
                    Image::F32 { data, .. } => data.iter().map(|v| f64::from(*v)).collect(),
                };
                if let Some(c0) = ch.first_mut() {
                    c0.extend(values);
                }
            }
            _ => {
                return Err(format!(
                    "a {} file where earlier frames are another format",
                    frame.file.name()
                )
                .into())
            }
        }
        return Ok(());
    }
    if d.shape.len() == 3 {
        let planes = match col.data_type() {
            DataType::List(_) => col.as_list::<i32>().value(r),
            _ => return Err("not a nested list".into()),
        };
        let c = d.shape[0] as usize;
        if planes.len() != c {
            return Err(format!(
                "{} channels where info.json declares {:?}",
                planes.len(),
                d.shape
            )
            .into());
        }
        let a = acc.get_or_insert_with(|| Acc::Channels(vec![Vec::new(); c]));
        let Acc::Channels(ch) = a else {
            return Err("mixed types".into());
        };
        let planes = planes.as_list::<i32>();
        for (k, channel) in ch.iter_mut().enumerate() {
            let values = tables::all_f64(&planes.value(k));
            if values.len() as u64 != d.shape[1] * d.shape[2] {
                return Err(format!(
                    "channel {k} has {} values where info.json declares {:?}",
                    values.len(),
                    d.shape
                )
                .into());
            }
            channel.extend(values);
        }
        return Ok(());
    }
    let values = tables::cell_f64(col, r);
    let n = d.shape.first().copied().unwrap_or(1) as usize;
    if values.len() != n {
        return Err(format!(
            "{} values where info.json declares {:?}",
            values.len(),
            d.shape
        )
        .into());
    }
    let a = acc.get_or_insert_with(|| Acc::Channels(vec![Vec::new(); n]));
    if let Acc::Channels(ch) = a {
        for (c, v) in ch.iter_mut().zip(values) {
            c.push(v);
        }
    }
    Ok(())
}

/// An episode read whole: its boundaries and statistics against its `meta/episodes` row.
fn finish(
    done: Current,
    declared: &[Declared],
    metas: &HashMap<i64, EpisodeRow>,
    all_stats: &mut [Vec<FeatureStats>],
    found: &mut Found,
) {
    let stats: Vec<Option<FeatureStats>> = done
        .acc
        .into_iter()
        .map(|a| a.map(|a| a.stats(done.frames)))
        .collect();
    for (k, s) in stats.iter().enumerate() {
        if let Some(s) = s {
            all_stats[k].push(s.clone());
        }
    }
    let Some(meta) = metas.get(&done.episode) else {
        return;
    };
    let (path, b, row) = (&meta.path, &meta.batch, meta.row);
    let record = format!("row {row} (episode {})", done.episode);
    let int = |name: &str| -> Option<i64> {
        tables::numbers(b, name)
            .ok()
            .and_then(|v| v.get(row).map(|x| *x as i64))
    };
    let expect = [
        ("length", done.frames as i64),
        ("dataset_from_index", done.first_index),
        ("dataset_to_index", done.first_index + done.frames as i64),
        ("data/chunk_index", done.file.0 as i64),
        ("data/file_index", done.file.1 as i64),
    ];
    for (name, want) in expect {
        match int(name) {
            Some(got) if got == want => {}
            got => found.problem(
                path,
                record.as_str(),
                format!(
                    "{name} {} where the data files give {want}",
                    got.map_or("missing".into(), |g| g.to_string())
                ),
            ),
        }
    }
    for (k, d) in declared.iter().enumerate() {
        let Some(s) = &stats[k] else { continue };
        for (stat, value) in s.named(d.layout()) {
            let column = format!("stats/{}/{stat}", d.key);
            let Some(c) = b.column_by_name(&column) else {
                found.problem(path, record.as_str(), format!("`{column}` is missing"));
                break;
            };
            let stored = tables::cell_f64(c.as_ref(), row);
            let mine = json_numbers(&value);
            let same = |x: &f64, y: &f64| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan());
            if let Some(what) = first_unlike(&stored, &mine, same) {
                found.problem(path, record.as_str(), format!("`{column}`{what}"));
                break;
            }
        }
    }
}

/// `meta/stats.json` against the recomputed episodes' statistics aggregated as LeRobot does.
fn dataset_stats(root: &Path, declared: &[Declared], all: &[Vec<FeatureStats>], found: &mut Found) {
    let path = root.join(layout::STATS);
    let Some(stats) = read_json(&path, found) else {
        return;
    };
    for (k, d) in declared.iter().enumerate() {
        let parts: Vec<&FeatureStats> = all[k].iter().collect();
        let Some(mine) = FeatureStats::aggregate(&parts) else {
            continue;
        };
        for (stat, value) in mine.named(d.layout()) {
            let stored = stats.get(&d.key).and_then(|s| s.get(stat));
            let Some(stored) = stored else {
                found.problem(&path, format!("{}.{stat}", d.key), "missing");
                continue;
            };
            let (a, b) = (json_numbers(stored), json_numbers(&value));
            let close = |x: &f64, y: &f64| {
                (x.is_nan() && y.is_nan()) || (x - y).abs() <= 1e-12 * x.abs().max(y.abs())
            };
            if let Some(what) = first_unlike(&a, &b, close) {
                found.problem(
                    &path,
                    format!("{}.{stat}", d.key),
                    what.trim_start().to_string(),
                );
            }
        }
    }
}

/// Every number of a JSON value, nested arrays flattened (null as NaN).
fn json_numbers(v: &Value) -> Vec<f64> {
    match v {
        Value::Array(a) => a.iter().flat_map(json_numbers).collect(),
        Value::Number(n) => vec![n.as_f64().unwrap_or(f64::NAN)],
        _ => vec![f64::NAN],
    }
}

/// `None` when `stored` and `recomputed` agree value by value; else ` has N values where the
/// frames give M` or `[k] is A where the frames give B` for the first that differs.
fn first_unlike(
    stored: &[f64],
    recomputed: &[f64],
    same: impl Fn(&f64, &f64) -> bool,
) -> Option<String> {
    if stored.len() != recomputed.len() {
        return Some(format!(
            " has {} values where the frames give {}",
            stored.len(),
            recomputed.len()
        ));
    }
    let k = stored
        .iter()
        .zip(recomputed)
        .position(|(x, y)| !same(x, y))?;
    Some(format!(
        "[{k}] is {} where the frames give {}",
        stored[k], recomputed[k]
    ))
}

/// The `.parquet` files under `dir`, sorted by path.
fn parquet_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(d) = pending.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') {
                continue;
            }
            let p = e.path();
            if p.is_dir() {
                pending.push(p);
            } else if name.ends_with(".parquet") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// `(chunk, file)` of `data/chunk-NNN/file-NNN.parquet` (`(0, 0)` for another name).
fn file_place(path: &Path) -> (u64, u64) {
    FileIndex::of_path(path).map_or((0, 0), |i| (i.chunk as u64, i.file as u64))
}
