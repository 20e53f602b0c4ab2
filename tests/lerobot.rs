//! The LeRobot v3.0 copy of a run: its layout checked against LeRobot's documented v3.0
//! schema without LeRobot, its frames against the run's own tables (decoded independently),
//! its statistics against the frames, `export-dataset` against `run --format lerobot`, the
//! PNG image encoding against the raw one; and, when Python can `import lerobot`, loaded by
//! the real `LeRobotDataset` (tests/python/check_lerobot.py).

use crate::common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use arrow::array::{
    Array, BinaryArray, BooleanArray, FixedSizeListArray, Float32Array, Float64Array, Int64Array,
    ListArray, RecordBatch, StringArray, StructArray, UInt32Array,
};
use common::{every_task_episodes, minos, tree_bytes, RunOk};
use minos::episode::Episode;
use minos::io::image_codec::ImageEncoding;
use minos::pipeline::rollout::{rollout, AgentKind, RunConfig};
use minos::progress::NoProgress;
use minos::render::RendererChoice;
use minos::run::metrics::Reward;
use minos::shard::Shard;
use minos::sim::{AgentConfig, SensorSuite};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use serde_json::Value;

/// Width and height of every camera (not square, so rows and columns cannot be swapped).
const SIZE: [u32; 2] = [16, 12];

/// A DATA folder with two baked houses, episodes of the three tasks, and one oracle run
/// with every camera modality, written as raw pixels and as PNG.
struct Fixture {
    /// This file's outputs.
    dir: tempfile::TempDir,
    /// The shared houses' DATA folder (read-only).
    data: minos::store::DataDir,
    episodes: Vec<Episode>,
}

fn fixture() -> &'static Fixture {
    static F: std::sync::OnceLock<Fixture> = std::sync::OnceLock::new();
    F.get_or_init(|| {
        let houses = common::lerobot_houses();
        let dir = common::shared_tempdir();
        let data = houses.data.clone();
        let scenes = houses.scenes("val");
        let episodes = every_task_episodes(&data, &scenes, 1, 3);
        assert!(episodes.len() >= 4, "{} episodes", episodes.len());
        let f = Fixture {
            dir,
            data,
            episodes,
        };
        for (name, encoding) in [("raw", ImageEncoding::Raw), ("png", ImageEncoding::Png)] {
            let report =
                rollout(&config(&f, name, encoding), &f.episodes, &NoProgress).expect("run");
            assert!(report.failures.is_empty(), "{:?}", report.failures);
        }
        f
    })
}

fn sensors() -> SensorSuite {
    let mut s = SensorSuite::all(SIZE[0]);
    for c in &mut s.cameras {
        c.resolution = SIZE;
    }
    s
}

fn config(f: &Fixture, name: &str, encoding: ImageEncoding) -> RunConfig {
    RunConfig {
        batch: None,
        data: f.data.clone(),
        out: f.dir.path().join(name),
        agent: AgentKind::Oracle,
        agent_config: AgentConfig::habitat(),
        sensors: sensors(),
        renderer: RendererChoice::Cpu,
        max_steps: Some(40),
        seed: 5,
        shard: Shard::ALL,
        resume: false,
        reward: Reward::Geodesic,
        encoding,
        lerobot: true,
        lerobot_video: None,
        rerun: None,
        allow_body_mismatch: false,
        provenance: Default::default(),
    }
}

fn run_dir(name: &str) -> PathBuf {
    fixture().dir.path().join(name)
}

fn batches(path: &Path) -> Vec<RecordBatch> {
    ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(path).expect("open"))
        .expect("parquet")
        .build()
        .expect("reader")
        .map(|b| b.expect("batch"))
        .collect()
}

fn table(path: &Path) -> RecordBatch {
    let b = batches(path);
    arrow::compute::concat_batches(&b[0].schema(), &b).expect("concat")
}

fn col<'a, T: 'static>(b: &'a RecordBatch, name: &str) -> &'a T {
    b.column_by_name(name)
        .unwrap_or_else(|| panic!("no column {name}"))
        .as_any()
        .downcast_ref::<T>()
        .unwrap_or_else(|| {
            panic!(
                "column {name}: {:?}",
                b.column_by_name(name).map(|c| c.data_type().clone())
            )
        })
}

fn json(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).expect("read")).expect("json")
}

/// The value of `key` in a Parquet file's key-value metadata.
fn file_metadata(path: &Path, key: &str) -> String {
    let reader =
        parquet::file::reader::SerializedFileReader::new(std::fs::File::open(path).expect("open"))
            .expect("parquet");
    let kv = parquet::file::reader::FileReader::metadata(&reader)
        .file_metadata()
        .key_value_metadata()
        .cloned()
        .unwrap_or_default();
    kv.iter()
        .find(|k| k.key == key)
        .and_then(|k| k.value.clone())
        .unwrap_or_else(|| panic!("{}: no `{key}` metadata", path.display()))
}

/// Every data file of a dataset, in chunk/file order.
fn data_files(root: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = tree_bytes(&root.join("data"))
        .into_iter()
        .map(|(p, _)| root.join("data").join(p))
        .collect();
    files.sort();
    files
}

/// All frames of a dataset as one batch.
fn frames(root: &Path) -> RecordBatch {
    let b: Vec<RecordBatch> = data_files(root).iter().flat_map(|f| batches(f)).collect();
    arrow::compute::concat_batches(&b[0].schema(), &b).expect("concat")
}

#[test]
fn the_dataset_follows_the_lerobot_v3_layout() {
    let root = run_dir("raw").join("lerobot");
    let info = json(&root.join("meta/info.json"));
    // info.json: the v3.0 fields with their types.
    assert_eq!(info["codebase_version"], "v3.0");
    let fps = info["fps"].as_u64().expect("integer fps");
    assert_eq!(
        fps,
        u64::from(minos::io::lerobot::fps_of_step(AgentConfig::habitat().dt))
    );
    assert_eq!(
        info["data_path"],
        "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    );
    for key in [
        "chunks_size",
        "data_files_size_in_mb",
        "video_files_size_in_mb",
    ] {
        assert!(info[key].as_u64().is_some_and(|v| v > 0), "{key}");
    }
    assert!(info["video_path"].is_null());
    let episodes = fixture().episodes.len() as u64;
    assert_eq!(info["total_episodes"].as_u64(), Some(episodes));
    assert_eq!(
        info["splits"],
        serde_json::json!({"val": format!("0:{episodes}")})
    );
    let features = info["features"].as_object().expect("features");
    for (key, f) in features {
        assert!(
            f["dtype"].is_string() && f["shape"].is_array(),
            "{key}: {f}"
        );
        assert!(f.get("names").is_some(), "{key}");
    }
    let h = u64::from(SIZE[1]);
    let w = u64::from(SIZE[0]);
    assert_eq!(features["observation.images.color"]["dtype"], "image");
    assert_eq!(
        features["observation.images.color"]["shape"],
        serde_json::json!([h, w, 3])
    );
    // One-channel cameras are lossless image files, which LeRobot returns channel-first
    // like its pictures; normals (three float channels) are a channel-first array.
    for (key, sensor_dtype, storage) in [
        ("observation.depth", "float32", "PFM"),
        ("observation.semantic", "uint16", "PGM (P5, 16-bit)"),
        ("observation.instance", "uint32", "TIFF"),
        ("observation.room", "uint32", "TIFF"),
        ("observation.room_class", "uint8", "PGM (P5, 16-bit)"),
    ] {
        assert_eq!(features[key]["dtype"], "image", "{key}");
        assert_eq!(
            features[key]["shape"],
            serde_json::json!([h, w, 1]),
            "{key}"
        );
        let info = &features[key]["info"];
        assert_eq!(info["minos.sensor_dtype"], sensor_dtype, "{key}");
        let stored = info["minos.storage"].as_str().expect("storage");
        assert!(stored.starts_with(storage), "{key}: {stored}");
    }
    assert_eq!(
        features["observation.depth"]["info"]["minos.unit"],
        "m (0 = no return)"
    );
    assert_eq!(features["observation.normal"]["dtype"], "float32");
    assert_eq!(
        features["observation.normal"]["shape"],
        serde_json::json!([3, h, w])
    );
    assert_eq!(
        features["observation.normal"]["names"],
        serde_json::json!(["channels", "height", "width"])
    );

    // Data files: one column per feature, typed as the Hugging Face metadata says.
    let frames = frames(&root);
    let schema = frames.schema();
    let columns: BTreeSet<&str> = schema.fields().iter().map(|f| f.name().as_str()).collect();
    let keys: BTreeSet<&str> = features.keys().map(String::as_str).collect();
    assert_eq!(columns, keys);
    // The Hugging Face features, in the file's key-value metadata as `datasets` writes them.
    let hf: Value =
        serde_json::from_str(&file_metadata(&data_files(&root)[0], "huggingface")).expect("hf");
    for (key, f) in features {
        let t = &hf["info"]["features"][key];
        let expected = match f["dtype"].as_str() {
            Some("image") => "Image",
            _ if f["shape"].as_array().map(Vec::len) == Some(3) => "Array3D",
            _ if f["shape"] == serde_json::json!([1]) => "Value",
            _ => "List",
        };
        assert_eq!(t["_type"], expected, "{key}: {t}");
    }
    let total = frames.num_rows() as u64;
    assert_eq!(info["total_frames"].as_u64(), Some(total));
    let index = col::<Int64Array>(&frames, "index");
    assert!((0..frames.num_rows()).all(|i| index.value(i) == i as i64));

    // meta/episodes: contiguous ranges covering every frame, in existing data files.
    let eps = table(&root.join("meta/episodes/chunk-000/file-000.parquet"));
    assert_eq!(eps.num_rows() as u64, episodes);
    let (from, to, length) = (
        col::<Int64Array>(&eps, "dataset_from_index"),
        col::<Int64Array>(&eps, "dataset_to_index"),
        col::<Int64Array>(&eps, "length"),
    );
    let mut next = 0;
    for e in 0..eps.num_rows() {
        assert_eq!(col::<Int64Array>(&eps, "episode_index").value(e), e as i64);
        assert_eq!(from.value(e), next);
        assert_eq!(to.value(e) - from.value(e), length.value(e));
        next = to.value(e);
        let file = root.join(format!(
            "data/chunk-{:03}/file-{:03}.parquet",
            col::<Int64Array>(&eps, "data/chunk_index").value(e),
            col::<Int64Array>(&eps, "data/file_index").value(e)
        ));
        assert!(file.is_file(), "{}", file.display());
        let episode_index = col::<Int64Array>(&frames, "episode_index");
        let frame_index = col::<Int64Array>(&frames, "frame_index");
        for (k, i) in (from.value(e)..to.value(e)).enumerate() {
            assert_eq!(episode_index.value(i as usize), e as i64);
            assert_eq!(frame_index.value(i as usize), k as i64);
        }
        let done = col::<BooleanArray>(&frames, "next.done");
        assert!(
            done.value(to.value(e) as usize - 1),
            "episode {e} ends done"
        );
        assert_eq!(col::<ListArray>(&eps, "tasks").value(e).len(), 1);
    }
    assert_eq!(next as u64, total);
    for key in features.keys() {
        for stat in [
            "min", "max", "mean", "std", "count", "q01", "q10", "q50", "q90", "q99",
        ] {
            let name = format!("stats/{key}/{stat}");
            assert!(eps.column_by_name(&name).is_some(), "{name}");
        }
    }

    // meta/tasks.parquet: the instructions as a pandas index, numbered in order.
    let tasks = table(&root.join("meta/tasks.parquet"));
    let pandas: Value =
        serde_json::from_str(&file_metadata(&root.join("meta/tasks.parquet"), "pandas"))
            .expect("pandas");
    assert_eq!(pandas["index_columns"], serde_json::json!(["task"]));
    let task_index = col::<Int64Array>(&tasks, "task_index");
    assert!((0..tasks.num_rows()).all(|i| task_index.value(i) == i as i64));
    assert_eq!(info["total_tasks"].as_u64(), Some(tasks.num_rows() as u64));
    let texts = col::<StringArray>(&tasks, "task");
    let by_episode = col::<ListArray>(&eps, "tasks");
    let frame_tasks = col::<Int64Array>(&frames, "task_index");
    for e in 0..eps.num_rows() {
        let t = by_episode.value(e);
        let t = t.as_any().downcast_ref::<StringArray>().expect("text");
        let i = frame_tasks.value(from.value(e) as usize) as usize;
        assert_eq!(texts.value(i), t.value(0));
    }
    // Stats in stats.json for every feature, nested as LeRobot nests them.
    let stats = json(&root.join("meta/stats.json"));
    for key in features.keys() {
        assert!(stats[key]["mean"].is_array(), "{key}");
    }
    assert_eq!(
        stats["observation.images.color"]["mean"]
            .as_array()
            .map(Vec::len),
        Some(3)
    );
    assert!(stats["observation.images.color"]["mean"][0][0][0].is_number());
    // Cameras' statistics are (c, 1, 1), broadcasting against their (c, h, w) tensors.
    for (key, c) in [("observation.normal", 3), ("observation.depth", 1)] {
        assert_eq!(
            stats[key]["mean"].as_array().map(Vec::len),
            Some(c),
            "{key}"
        );
        assert!(stats[key]["q50"][c - 1][0][0].is_number(), "{key}");
    }
}

/// Each column chunk of a Parquet file: (path, physical type, encodings, codec), per row
/// group; and the file's key-value metadata keys.
#[allow(clippy::type_complexity)]
fn column_chunks(
    path: &Path,
) -> (
    Vec<
        Vec<(
            String,
            parquet::basic::Type,
            Vec<parquet::basic::Encoding>,
            String,
        )>,
    >,
    Vec<String>,
) {
    let reader =
        parquet::file::reader::SerializedFileReader::new(std::fs::File::open(path).expect("open"))
            .expect("parquet");
    let meta = parquet::file::reader::FileReader::metadata(&reader);
    let groups = meta
        .row_groups()
        .iter()
        .map(|g| {
            g.columns()
                .iter()
                .map(|c| {
                    (
                        c.column_path().string(),
                        c.column_type(),
                        c.encodings().collect(),
                        format!("{:?}", c.compression()),
                    )
                })
                .collect()
        })
        .collect();
    let keys = meta
        .file_metadata()
        .key_value_metadata()
        .map(|kv| kv.iter().map(|k| k.key.clone()).collect())
        .unwrap_or_default();
    (groups, keys)
}

#[test]
fn parquet_files_pack_numbers_by_kind_in_row_groups_of_whole_episodes() {
    use parquet::basic::{Encoding, Type};
    let root = run_dir("raw").join("lerobot");
    let files = data_files(&root);
    assert_eq!(files.len(), 1, "{files:?}");
    let (groups, keys) = column_chunks(&files[0]);
    // A small dataset is one row group (it was one per episode), so every episode is whole
    // in it; the schema metadata stays.
    let episodes = fixture().episodes.len();
    assert!(episodes >= 4);
    assert_eq!(groups.len(), 1, "{episodes} episodes");
    assert!(keys.contains(&"huggingface".to_string()), "{keys:?}");
    assert!(keys.contains(&"ARROW:schema".to_string()), "{keys:?}");
    let (mut ints, mut floats) = (0, 0);
    for (path, kind, encodings, codec) in &groups[0] {
        assert!(codec.starts_with("ZSTD"), "{path}: {codec}");
        assert!(
            !encodings.contains(&Encoding::RLE_DICTIONARY)
                && !encodings.contains(&Encoding::PLAIN_DICTIONARY),
            "{path}: {encodings:?}"
        );
        match kind {
            Type::INT64 | Type::INT32 => {
                ints += 1;
                assert!(
                    encodings.contains(&Encoding::DELTA_BINARY_PACKED),
                    "{path}: {encodings:?}"
                );
            }
            Type::FLOAT | Type::DOUBLE => {
                floats += 1;
                assert!(
                    encodings.contains(&Encoding::BYTE_STREAM_SPLIT),
                    "{path}: {encodings:?}"
                );
            }
            _ => {}
        }
    }
    // index, frame_index, episode_index, task_index; the vectors, timestamp, reward.
    assert!(
        ints >= 4 && floats >= 5,
        "{ints} integer, {floats} float columns"
    );
    // The index columns read back as the frames' own numbering.
    let b = frames(&root);
    let index = col::<Int64Array>(&b, "index");
    assert!(index
        .values()
        .iter()
        .enumerate()
        .all(|(i, v)| *v == i as i64));

    // meta/episodes: numbers packed the same way, no statistics and no serialised Arrow
    // schema in the footer; the types are the Parquet schema's own.
    let path = root.join("meta/episodes/chunk-000/file-000.parquet");
    let (groups, keys) = column_chunks(&path);
    assert!(!keys.contains(&"ARROW:schema".to_string()), "{keys:?}");
    for (path, kind, encodings, _) in &groups[0] {
        if matches!(kind, Type::DOUBLE) {
            assert!(
                encodings.contains(&Encoding::BYTE_STREAM_SPLIT),
                "{path}: {encodings:?}"
            );
        }
    }
    let reader =
        parquet::file::reader::SerializedFileReader::new(std::fs::File::open(&path).expect("open"))
            .expect("parquet");
    let rg = parquet::file::reader::FileReader::metadata(&reader).row_group(0);
    assert!(rg.columns().iter().all(|c| c.statistics().is_none()));
    let e = table(&path);
    assert_eq!(e.num_rows(), episodes);
    assert_eq!(
        e.schema()
            .field_with_name("tasks")
            .expect("tasks")
            .data_type(),
        &arrow::datatypes::DataType::List(std::sync::Arc::new(arrow::datatypes::Field::new(
            "item",
            arrow::datatypes::DataType::Utf8,
            true
        )))
    );
    let lengths = col::<Int64Array>(&e, "length");
    assert_eq!(
        lengths.values().iter().sum::<i64>() as usize,
        b.num_rows(),
        "episode lengths add up to the frames"
    );
}

/// The run's observation rows: (episode id, step) → column → cell bytes.
fn observation_cells(run: &Path) -> BTreeMap<(String, u32), BTreeMap<String, Vec<u8>>> {
    let mut out = BTreeMap::new();
    for b in batches(&run.join("observations.parquet")) {
        let ids = col::<StringArray>(&b, "episode_id");
        let steps = col::<UInt32Array>(&b, "step");
        for r in 0..b.num_rows() {
            let mut cells = BTreeMap::new();
            for f in b.schema().fields().iter().skip(2) {
                cells.insert(
                    f.name().clone(),
                    col::<BinaryArray>(&b, f.name()).value(r).to_vec(),
                );
            }
            out.insert((ids.value(r).to_string(), steps.value(r)), cells);
        }
    }
    out
}

/// The values of row `r` of a channel-first `[c][h][w]` list column of `c` channels,
/// flattened in that order.
fn nested<T: 'static + Clone>(
    column: &ListArray,
    r: usize,
    c: usize,
    leaf: impl Fn(&dyn Array) -> Vec<T>,
) -> Vec<T> {
    let planes = column.value(r);
    let planes = planes.as_any().downcast_ref::<ListArray>().expect("planes");
    assert_eq!(planes.len(), c);
    let mut out = Vec::new();
    for p in 0..c {
        let rows = planes.value(p);
        let rows = rows.as_any().downcast_ref::<ListArray>().expect("rows");
        assert_eq!(rows.len(), SIZE[1] as usize);
        for y in 0..rows.len() {
            let px = rows.value(y);
            assert_eq!(px.len(), SIZE[0] as usize);
            out.extend(leaf(px.as_ref()));
        }
    }
    out
}

/// Interleaved `[h][w][c]` values in channel-first `[c][h][w]` order.
fn channel_first<T: Copy>(v: &[T], c: usize) -> Vec<T> {
    (0..c)
        .flat_map(|k| v.iter().skip(k).step_by(c).copied())
        .collect()
}

/// A frame file's width, height and samples in row-major order, read from the formats'
/// specifications (Netpbm `P5`/`P6` and `Pf`, baseline TIFF), not with minos's writer.
fn read_image_file(b: &[u8]) -> (u32, u32, Vec<f64>) {
    if b.starts_with(b"II*\0") {
        let u16_at = |i: usize| u16::from_le_bytes([b[i], b[i + 1]]);
        let u32_at = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        let ifd = u32_at(4) as usize;
        let mut tags = BTreeMap::new();
        for k in 0..u16_at(ifd) as usize {
            let e = ifd + 2 + 12 * k;
            let value = match u16_at(e + 2) {
                3 => u32::from(u16_at(e + 8)),
                _ => u32_at(e + 8),
            };
            tags.insert(u16_at(e), value);
        }
        assert_eq!((tags[&258], tags[&259], tags[&277]), (32, 1, 1), "{tags:?}");
        assert_eq!(tags[&339], 2, "signed samples");
        let (w, h, start) = (tags[&256], tags[&257], tags[&273] as usize);
        let values = b[start..start + (w * h * 4) as usize]
            .chunks_exact(4)
            .map(|c| f64::from(i32::from_le_bytes([c[0], c[1], c[2], c[3]])))
            .collect();
        return (w, h, values);
    }
    let text = |from: usize| {
        let end = from + b[from..].iter().position(|c| *c == b'\n').expect("line");
        (
            String::from_utf8(b[from..end].to_vec()).expect("ascii"),
            end + 1,
        )
    };
    let (magic, at) = text(0);
    let (size, at) = text(at);
    let (third, at) = text(at);
    let mut wh = size.split(' ').map(|v| v.parse::<u32>().expect("size"));
    let (w, h) = (wh.next().expect("w"), wh.next().expect("h"));
    let body = &b[at..];
    let values: Vec<f64> = match (magic.as_str(), third.as_str()) {
        ("P6" | "P5", "255") => body.iter().map(|v| f64::from(*v)).collect(),
        ("P5", "65535") => body
            .chunks_exact(2)
            .map(|c| f64::from(u16::from_be_bytes([c[0], c[1]])))
            .collect(),
        ("Pf", scale) if scale.starts_with('-') => {
            // Little-endian, bottom row first.
            let rows: Vec<Vec<f64>> = body
                .chunks_exact(4 * w as usize)
                .map(|r| {
                    r.chunks_exact(4)
                        .map(|c| f64::from(f32::from_le_bytes([c[0], c[1], c[2], c[3]])))
                        .collect()
                })
                .collect();
            rows.into_iter().rev().flatten().collect()
        }
        other => panic!("unexpected header {other:?}"),
    };
    (w, h, values)
}

/// The samples of row `r` of an image-file column.
fn file_values(b: &RecordBatch, key: &str, r: usize) -> Vec<f64> {
    let s = col::<StructArray>(b, key);
    let bytes = s.column_by_name("bytes").expect("bytes");
    let bytes = bytes
        .as_any()
        .downcast_ref::<BinaryArray>()
        .expect("binary");
    let (w, h, values) = read_image_file(bytes.value(r));
    assert_eq!((w, h), (SIZE[0], SIZE[1]), "{key}");
    values
}

fn le_f32(b: &[u8]) -> Vec<f32> {
    b.chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

#[test]
fn frames_equal_the_runs_own_tables() {
    let run = run_dir("raw");
    let frames = frames(&run.join("lerobot"));
    let cells = observation_cells(&run);
    let eps = table(&run.join("lerobot/meta/episodes/chunk-000/file-000.parquet"));
    let ids = col::<StringArray>(&eps, "minos/episode_id");
    let from = col::<Int64Array>(&eps, "dataset_from_index");
    let traj = table(&run.join("trajectories.parquet"));
    let fps = json(&run.join("lerobot/meta/info.json"))["fps"]
        .as_f64()
        .expect("fps");
    let vocabulary: Vec<String> = serde_json::from_value(
        json(&run.join("lerobot/meta/info.json"))["features"]["observation.goal_object"]["info"]
            ["minos.vocabulary"]
            .clone(),
    )
    .expect("the goal object vocabulary");
    let state = col::<FixedSizeListArray>(&frames, "observation.state");
    let action = col::<FixedSizeListArray>(&frames, "action");
    let timestamp = col::<Float32Array>(&frames, "timestamp");
    for i in 0..frames.num_rows() {
        let e = (0..eps.num_rows())
            .rev()
            .find(|e| from.value(*e) as usize <= i)
            .expect("episode");
        let step = (i - from.value(e) as usize) as u32;
        let key = (ids.value(e).to_string(), step);
        let row = &cells[&key];
        // Colour: the PPM holds the raw pixels.
        let color = file_values(&frames, "observation.images.color", i);
        let raw: Vec<f64> = row["color"].iter().map(|v| f64::from(*v)).collect();
        assert_eq!(color, raw, "colour of {key:?}");
        // One-channel cameras: exactly the sensor's values.
        let depth = file_values(&frames, "observation.depth", i);
        let raw: Vec<f64> = le_f32(&row["depth"]).into_iter().map(f64::from).collect();
        assert_eq!(depth, raw, "depth of {key:?}");
        let semantic = file_values(&frames, "observation.semantic", i);
        let raw: Vec<f64> = row["semantic"]
            .chunks_exact(2)
            .map(|c| f64::from(u16::from_le_bytes([c[0], c[1]])))
            .collect();
        assert_eq!(semantic, raw, "semantic of {key:?}");
        for name in ["instance", "room"] {
            let ids = file_values(&frames, &format!("observation.{name}"), i);
            let raw: Vec<f64> = row[name]
                .chunks_exact(4)
                .map(|c| f64::from(u32::from_le_bytes([c[0], c[1], c[2], c[3]])))
                .collect();
            assert_eq!(ids, raw, "{name} of {key:?}");
        }
        let classes = file_values(&frames, "observation.room_class", i);
        let raw: Vec<f64> = row["room_class"].iter().map(|v| f64::from(*v)).collect();
        assert_eq!(classes, raw, "room classes of {key:?}");
        // Normals: a channel-first array of the sensor's values.
        let normal = nested(col::<ListArray>(&frames, "observation.normal"), i, 3, |a| {
            a.as_any()
                .downcast_ref::<Float32Array>()
                .expect("f32")
                .values()
                .to_vec()
        });
        assert_eq!(normal, channel_first(&le_f32(&row["normal"]), 3));
        // State, action and time from the trajectory table (same row order).
        let s = state.value(i);
        let s = s.as_any().downcast_ref::<Float32Array>().expect("f32");
        for (k, name) in ["x", "y", "z", "yaw", "tilt"].iter().enumerate() {
            assert_eq!(s.value(k), col::<Float32Array>(&traj, name).value(i));
        }
        let a = action.value(i);
        let a = a.as_any().downcast_ref::<Float32Array>().expect("f32");
        let stop = col::<StringArray>(&traj, "action").value(i) == "stop";
        assert_eq!(a.value(8), if stop { 1.0 } else { 0.0 });
        let strengths = col::<ListArray>(&traj, "action_strengths").value(i);
        let strengths = strengths
            .as_any()
            .downcast_ref::<Float32Array>()
            .expect("f32");
        assert_eq!(&a.values()[..8], strengths.values());
        assert!((f64::from(timestamp.value(i)) - f64::from(step) / fps).abs() < 1e-5);
        // The per-step features: the trajectory row's columns, and the previous frame's
        // action vector.
        let vector = |key: &str| -> Vec<f32> {
            if let Some(v) = frames
                .column_by_name(key)
                .and_then(|c| c.as_any().downcast_ref::<Float32Array>())
            {
                return vec![v.value(i)];
            }
            let v = col::<FixedSizeListArray>(&frames, key).value(i);
            v.as_any()
                .downcast_ref::<Float32Array>()
                .expect("f32")
                .values()
                .to_vec()
        };
        let t = |name: &str| col::<Float32Array>(&traj, name).value(i);
        assert_eq!(
            vector("observation.goal"),
            [t("euclidean_distance"), t("goal_right"), t("goal_forward")]
        );
        let previous = vector("observation.previous_action");
        if step == 0 {
            assert_eq!(previous, [0.0; 9]);
        } else {
            let a = action.value(i - 1);
            let a = a.as_any().downcast_ref::<Float32Array>().expect("f32");
            assert_eq!(previous, a.values().to_vec(), "previous action of {key:?}");
        }
        let steps_left = col::<UInt32Array>(&traj, "steps_left").value(i);
        assert_eq!(vector("observation.steps_left"), [steps_left as f32]);
        let flag = |name: &str| f32::from(u8::from(col::<BooleanArray>(&traj, name).value(i)));
        assert_eq!(vector("observation.at_goal"), [flag("at_goal")]);
        assert_eq!(
            vector("observation.collision"),
            [flag("previous_collision")]
        );
        let contacts = col::<ListArray>(&traj, "contacts").value(i);
        let contacts = contacts
            .as_any()
            .downcast_ref::<BooleanArray>()
            .expect("bool");
        let bits: Vec<f32> = (0..contacts.len())
            .map(|k| f32::from(u8::from(contacts.value(k))))
            .collect();
        assert_eq!(vector("observation.contact"), bits);
        let room = col::<StringArray>(&traj, "goal_room");
        let mut one_hot = [0.0f32; 9];
        if room.is_valid(i) {
            let class = minos::scene::RoomClass::from_label(room.value(i)).expect("class");
            one_hot[class.index() as usize] = 1.0;
        }
        assert_eq!(vector("observation.goal_room"), one_hot);
        let object = col::<StringArray>(&traj, "goal_object");
        let index = col::<Int64Array>(&frames, "observation.goal_object").value(i);
        if object.is_valid(i) {
            assert_eq!(vocabulary[index as usize], object.value(i));
        } else {
            assert_eq!(index, -1);
        }
    }
    // Every observation row made it into the dataset.
    assert_eq!(cells.len(), frames.num_rows());
}

#[test]
fn statistics_are_those_of_the_frames() {
    let root = run_dir("raw").join("lerobot");
    let frames = frames(&root);
    let stats = json(&root.join("meta/stats.json"));
    let n = frames.num_rows();
    // observation.state: mean, min, max per element over every frame.
    let state = col::<FixedSizeListArray>(&frames, "observation.state");
    for k in 0..5 {
        let v: Vec<f64> = (0..n)
            .map(|i| {
                let s = state.value(i);
                f64::from(
                    s.as_any()
                        .downcast_ref::<Float32Array>()
                        .expect("f32")
                        .value(k),
                )
            })
            .collect();
        let mean = v.iter().sum::<f64>() / n as f64;
        let got = stats["observation.state"]["mean"][k]
            .as_f64()
            .expect("mean");
        assert!(
            (got - mean).abs() <= 1e-9 * (1.0 + mean.abs()),
            "{k}: {got} vs {mean}"
        );
        // (serde_json's default float parsing may be off in the last digit.)
        let min = v.iter().copied().fold(f64::INFINITY, f64::min);
        let got = stats["observation.state"]["min"][k].as_f64().expect("min");
        assert!(
            (got - min).abs() <= 1e-15 * (1.0 + min.abs()),
            "{got} vs {min}"
        );
    }
    // Depth: one channel, over every pixel of every frame.
    let all: Vec<f64> = (0..n)
        .flat_map(|i| file_values(&frames, "observation.depth", i))
        .collect();
    let mean = all.iter().sum::<f64>() / all.len() as f64;
    let var = all.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / all.len() as f64;
    let s = &stats["observation.depth"];
    assert!((s["mean"][0][0][0].as_f64().expect("mean") - mean).abs() < 1e-9);
    assert!((s["std"][0][0][0].as_f64().expect("std") - var.sqrt()).abs() < 1e-9);
    assert_eq!(s["count"][0].as_u64(), Some(n as u64));
    // Colour: per channel in [0, 1] over every pixel.
    let mut sums = [0f64; 3];
    let mut count = 0f64;
    for i in 0..n {
        let rgb = file_values(&frames, "observation.images.color", i);
        for p in rgb.chunks_exact(3) {
            for (sum, v) in sums.iter_mut().zip(p) {
                *sum += v / 255.0;
            }
            count += 1.0;
        }
    }
    for (c, sum) in sums.iter().enumerate() {
        let got = stats["observation.images.color"]["mean"][c][0][0]
            .as_f64()
            .expect("mean");
        assert!((got - sum / count).abs() < 1e-9, "channel {c}");
    }
    // Per-episode statistics cover their episode's frames only.
    let eps = table(&root.join("meta/episodes/chunk-000/file-000.parquet"));
    let counts = col::<ListArray>(&eps, "stats/index/count");
    let maxima = col::<ListArray>(&eps, "stats/index/max");
    let to = col::<Int64Array>(&eps, "dataset_to_index");
    for e in 0..eps.num_rows() {
        let c = counts.value(e);
        let c = c.as_any().downcast_ref::<Int64Array>().expect("i64");
        assert_eq!(c.value(0), col::<Int64Array>(&eps, "length").value(e));
        let m = maxima.value(e);
        let m = m.as_any().downcast_ref::<Float64Array>().expect("f64");
        assert_eq!(m.value(0), (to.value(e) - 1) as f64);
    }
}

#[test]
fn export_dataset_rebuilds_the_same_bytes_and_png_runs_hold_the_same_data() {
    let raw = run_dir("raw");
    let out = fixture().dir.path().join("exported");
    minos()
        .args(["export-dataset", "--run"])
        .arg(&raw)
        .arg("--out")
        .arg(&out)
        .arg("-q")
        .ok_output();
    assert_eq!(tree_bytes(&out), tree_bytes(&raw.join("lerobot")));
    // Nothing left beside it: no temporary folder.
    let names: Vec<String> = std::fs::read_dir(fixture().dir.path())
        .expect("dir")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert!(!names.iter().any(|n| n.contains(".tmp-")), "{names:?}");

    // A run stored as PNG holds the same images: integers exactly, depth within 0.5 mm.
    let png = observation_cells(&run_dir("png"));
    let rawc = observation_cells(&raw);
    assert_eq!(png.len(), rawc.len());
    let schema = batches(&run_dir("png").join("observations.parquet"))[0].schema();
    for f in schema.fields().iter().skip(2) {
        let meta = f.metadata();
        let lossless = meta["lossless"] == "true";
        assert_eq!(
            lossless,
            f.name() != "depth" && f.name() != "normal",
            "{}",
            f.name()
        );
    }
    let png_frames = frames(&run_dir("png").join("lerobot"));
    let raw_frames = frames(&raw.join("lerobot"));
    for key in [
        "observation.images.color",
        "observation.semantic",
        "observation.instance",
        "observation.room",
        "observation.room_class",
        "observation.state",
    ] {
        assert_eq!(
            png_frames.column_by_name(key).expect(key).to_data(),
            raw_frames.column_by_name(key).expect(key).to_data(),
            "{key}"
        );
    }
    let d = |b: &RecordBatch, i| file_values(b, "observation.depth", i);
    for i in 0..raw_frames.num_rows() {
        for (a, b) in d(&png_frames, i).iter().zip(d(&raw_frames, i)) {
            assert!((a - b.min(65.535)).abs() <= 0.0005 + 1e-6, "{a} vs {b}");
        }
    }
}

#[test]
fn corrupt_or_mismatched_run_tables_are_one_line_errors_naming_the_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = dir.path().join("run");
    std::fs::create_dir_all(&run).expect("dir");
    for f in [
        "trajectories.parquet",
        "observations.parquet",
        "episodes.parquet",
        "manifest.json",
    ] {
        std::fs::copy(run_dir("raw").join(f), run.join(f)).expect("copy");
    }
    // Observations cut short: the trajectories then have a step the observations lack.
    let bytes = std::fs::read(run.join("observations.parquet")).expect("read");
    std::fs::write(run.join("observations.parquet"), &bytes[..bytes.len() / 2]).expect("write");
    let export_fails = || {
        let out = minos()
            .args(["export-dataset", "--run"])
            .arg(&run)
            .arg("--out")
            .arg(dir.path().join("lr"))
            .output()
            .expect("runs");
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let err = export_fails();
    assert!(err.contains("observations.parquet"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(!dir.path().join("lr").exists());
    // The trajectories of another run: the tables disagree.
    std::fs::copy(
        run_dir("raw").join("observations.parquet"),
        run.join("observations.parquet"),
    )
    .expect("copy");
    let mut eps = std::fs::read(run_dir("raw").join("episodes.parquet")).expect("read");
    eps.truncate(eps.len() - 3);
    std::fs::write(run.join("episodes.parquet"), eps).expect("write");
    let err = export_fails();
    assert!(err.contains("episodes.parquet"), "{err}");
}

#[test]
fn lerobot_itself_loads_the_dataset() {
    let python = std::env::var("MINOS_PYTHON").unwrap_or_else(|_| "python3".into());
    let probe = std::process::Command::new(&python)
        .args(["-c", "import lerobot"])
        .output();
    match probe {
        Ok(o) if o.status.success() => {}
        _ => {
            common::skip(format!(
                "`{python} -c 'import lerobot'` fails (pip install lerobot, or set \
                 MINOS_PYTHON to a Python that has it)"
            ));
            return;
        }
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/check_lerobot.py");
    let root = run_dir("raw").join("lerobot");
    let out = std::process::Command::new(&python)
        .arg(&script)
        .arg(&root)
        .arg(run_dir("raw"))
        .env("HF_HUB_OFFLINE", "1")
        .env("HF_DATASETS_OFFLINE", "1")
        .env("HF_HOME", fixture().dir.path().join("hf-home"))
        .output()
        .expect("python runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("lerobot loaded"), "{stdout}");
}

#[test]
fn the_dataset_card_and_provenance_record_check_out() {
    let run = run_dir("raw");
    let root = run.join("lerobot");
    let record = json(&root.join("meta/provenance.json"));
    assert_eq!(record["format"], "minos-provenance/1");
    assert_eq!(record["minos"]["version"], env!("CARGO_PKG_VERSION"));
    assert!(!record["minos"]["commit"].as_str().unwrap_or("").is_empty());
    // Every file but the record itself is listed, with its sha256 and size.
    let listed = record["files"].as_object().expect("files");
    let on_disk: BTreeSet<String> = tree_bytes(&root)
        .into_iter()
        .map(|(p, _)| p.to_string_lossy().replace('\\', "/"))
        .filter(|p| p != "meta/provenance.json")
        .collect();
    assert_eq!(listed.keys().cloned().collect::<BTreeSet<_>>(), on_disk);
    assert!(on_disk.contains("README.md"));
    for (name, sum) in listed {
        let again = minos::provenance::sha256_file(&root.join(name)).unwrap();
        assert_eq!(sum["sha256"], again.sha256.as_str(), "{name}");
        assert_eq!(sum["bytes"], again.bytes, "{name}");
    }
    for table in [
        "episodes.parquet",
        "trajectories.parquet",
        "observations.parquet",
    ] {
        let sum = minos::provenance::sha256_file(&run.join(table)).unwrap();
        assert_eq!(
            record["source_run_tables"][table]["sha256"],
            sum.sha256.as_str()
        );
    }
    // The card: the Hub's YAML header, the features of info.json.
    let card = std::fs::read_to_string(root.join("README.md")).unwrap();
    assert!(card.starts_with("---\n"), "{card}");
    let info = json(&root.join("meta/info.json"));
    for key in info["features"].as_object().unwrap().keys() {
        assert!(card.contains(&format!("| `{key}` |")), "{key}: {card}");
    }
    // The run folder's manifest lists its scenes and the checksums of its other files.
    let manifest = json(&run.join("manifest.json"));
    assert_eq!(manifest["minos_commit"], record["minos"]["commit"]);
    let scenes = manifest["scenes"].as_array().expect("scenes");
    let ids: BTreeSet<&str> = fixture()
        .episodes
        .iter()
        .map(|e| e.scene_id.as_str())
        .collect();
    assert_eq!(
        scenes
            .iter()
            .map(|s| s["id"].as_str().unwrap())
            .collect::<BTreeSet<_>>(),
        ids
    );
    for s in scenes {
        assert_eq!(s["compiled_sha256"].as_str().unwrap_or("").len(), 64, "{s}");
        assert!(
            s["sources"].as_array().is_some_and(|v| !v.is_empty()),
            "{s}"
        );
    }
    // The copy records the run's configuration but its command (and the run's file list).
    let mut configuration = manifest.clone();
    for key in ["command", "rerun", "files"] {
        configuration.as_object_mut().unwrap().remove(key);
    }
    assert_eq!(record["run"], configuration);
    assert!(record["run"]["sensors"].is_object() && record["run"]["seed"].is_u64());
    let files = manifest["files"].as_object().expect("files");
    assert!(files.contains_key("lerobot/meta/provenance.json"));
    let sum = minos::provenance::sha256_file(&run.join("metrics.json")).unwrap();
    assert_eq!(files["metrics.json"]["sha256"], sum.sha256.as_str());
    assert!(!files.contains_key("manifest.json"));

    // huggingface_hub reads the card's header as the Hub does, when Python has it.
    let python = std::env::var("MINOS_PYTHON").unwrap_or_else(|_| "python3".into());
    let has_hub = std::process::Command::new(&python)
        .args(["-c", "import huggingface_hub"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !has_hub {
        common::skip(format!(
            "the huggingface_hub check: `{python} -c 'import huggingface_hub'` fails (pip \
             install huggingface_hub, or set MINOS_PYTHON)"
        ));
        return;
    }
    let script = "import sys; from huggingface_hub import DatasetCard; \
                  d = DatasetCard.load(sys.argv[1]).data; \
                  print(d.task_categories, d.tags, d.license)";
    let o = std::process::Command::new(&python)
        .args(["-c", script])
        .arg(root.join("README.md"))
        .output()
        .expect("python runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        String::from_utf8_lossy(&o.stdout).trim(),
        "['robotics'] ['LeRobot', 'minos', 'navigation', 'embodied-ai'] None"
    );
}
