//! `--video`: a run's colour camera as an H.264 video feature of its LeRobot copy. The
//! layout against LeRobot v3.0's (`videos/<key>/chunk-000/file-000.mp4`, `video_path`, the
//! episodes' `videos/<key>/…` places), every frame decoded back (OpenH264) within
//! [`MIN_PSNR`] dB of the run's own raw frames, depth and labels still exact, the same bytes
//! again from `export-dataset --video` at another thread count, `--video-qp` trading bytes
//! for quality, `minos verify` passing the dataset and finding a damaged video, a shifted
//! episode and a lying statistic.

use crate::common;

use std::path::{Path, PathBuf};

use arrow::array::{Array, BinaryArray, Float64Array, Int64Array, RecordBatch, StringArray};
use common::{every_task_episodes, minos, tree_bytes, RunOk};
use minos::episode::Episode;
use minos::io::image_codec::ImageEncoding;
use minos::io::lerobot::video_read::read_video;
use minos::pipeline::rollout::{rollout, AgentKind, RunConfig};
use minos::progress::NoProgress;
use minos::render::RendererChoice;
use minos::run::metrics::Reward;
use minos::shard::Shard;
use minos::sim::{AgentConfig, SensorSuite};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use serde_json::Value;

/// Camera width and height (not square, so rows and columns cannot be swapped).
const SIZE: [u32; 2] = [64, 48];

/// The smallest PSNR (dB, over all frames and channels) of the decoded video against the
/// raw frames: OpenH264 at constant QP 26 (the default) gives ≈ 38–45 dB on rendered rooms.
const MIN_PSNR: f64 = 32.0;

struct Fixture {
    /// This file's outputs.
    dir: tempfile::TempDir,
    /// The shared houses' DATA folder (read-only).
    data: minos::store::DataDir,
    #[allow(dead_code)]
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
        let report = rollout(&config(&f), &f.episodes, &NoProgress).expect("run");
        assert!(report.failures.is_empty(), "{:?}", report.failures);
        f
    })
}

fn config(f: &Fixture) -> RunConfig {
    let mut sensors = SensorSuite::minos(SIZE[0]);
    for c in &mut sensors.cameras {
        c.resolution = SIZE;
    }
    RunConfig {
        batch: None,
        data: f.data.clone(),
        out: f.dir.path().join("run"),
        agent: AgentKind::Oracle,
        agent_config: AgentConfig::habitat(),
        sensors,
        renderer: RendererChoice::Cpu,
        max_steps: Some(40),
        seed: 5,
        shard: Shard::ALL,
        resume: false,
        reward: Reward::Geodesic,
        encoding: ImageEncoding::Raw,
        lerobot: true,
        lerobot_video: Some(minos::io::lerobot::video::VideoSettings::default()),
        rerun: None,
        allow_body_mismatch: false,
        provenance: Default::default(),
    }
}

fn run_dir() -> PathBuf {
    fixture().dir.path().join("run")
}

fn dataset() -> PathBuf {
    run_dir().join("lerobot")
}

fn table(path: &Path) -> RecordBatch {
    let b: Vec<RecordBatch> =
        ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(path).expect("open"))
            .expect("parquet")
            .build()
            .expect("reader")
            .map(|b| b.expect("batch"))
            .collect();
    arrow::compute::concat_batches(&b[0].schema(), &b).expect("concat")
}

fn json(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).expect("read")).expect("json")
}

fn ints(b: &RecordBatch, name: &str) -> Vec<i64> {
    b.column_by_name(name)
        .unwrap_or_else(|| panic!("no column {name}"))
        .as_any()
        .downcast_ref::<Int64Array>()
        .unwrap_or_else(|| panic!("{name}: not int64"))
        .values()
        .to_vec()
}

fn floats(b: &RecordBatch, name: &str) -> Vec<f64> {
    b.column_by_name(name)
        .unwrap_or_else(|| panic!("no column {name}"))
        .as_any()
        .downcast_ref::<Float64Array>()
        .unwrap_or_else(|| panic!("{name}: not float64"))
        .values()
        .to_vec()
}

const KEY: &str = "observation.images.color";

#[test]
fn the_colour_camera_is_a_video_feature_laid_out_as_lerobot_v3() {
    let root = dataset();
    let info = json(&root.join("meta/info.json"));
    assert_eq!(
        info["video_path"],
        "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
    );
    let f = &info["features"][KEY];
    assert_eq!(f["dtype"], "video");
    assert_eq!(f["shape"], serde_json::json!([SIZE[1], SIZE[0], 3]));
    assert_eq!(
        f["names"],
        serde_json::json!(["height", "width", "channels"])
    );
    let fps = info["fps"].as_u64().expect("fps");
    for (k, v) in [
        ("video.height", serde_json::json!(SIZE[1])),
        ("video.width", serde_json::json!(SIZE[0])),
        ("video.codec", serde_json::json!("h264")),
        ("video.pix_fmt", serde_json::json!("yuv420p")),
        ("video.is_depth_map", serde_json::json!(false)),
        ("video.fps", serde_json::json!(fps)),
        ("video.channels", serde_json::json!(3)),
        ("has_audio", serde_json::json!(false)),
    ] {
        assert_eq!(f["info"][k], v, "{k}");
    }
    // Depth and labels stay lossless image files in the data files; the video is no column.
    assert_eq!(info["features"]["observation.depth"]["dtype"], "image");
    assert_eq!(info["features"]["observation.semantic"]["dtype"], "image");
    let data = table(&root.join("data/chunk-000/file-000.parquet"));
    assert!(data.column_by_name(KEY).is_none());
    assert!(data.column_by_name("observation.depth").is_some());
    let reader = ParquetRecordBatchReaderBuilder::try_new(
        std::fs::File::open(root.join("data/chunk-000/file-000.parquet")).expect("open"),
    )
    .expect("parquet");
    let hf: Value = serde_json::from_str(&reader.schema().metadata()["huggingface"]).expect("json");
    assert!(hf["info"]["features"].get(KEY).is_none(), "{hf}");

    // Episodes follow each other in one file, each from where the last ended.
    let eps = table(&root.join("meta/episodes/chunk-000/file-000.parquet"));
    let lengths = ints(&eps, "length");
    let from = floats(&eps, &format!("videos/{KEY}/from_timestamp"));
    let to = floats(&eps, &format!("videos/{KEY}/to_timestamp"));
    assert!(ints(&eps, &format!("videos/{KEY}/chunk_index"))
        .iter()
        .all(|c| *c == 0));
    assert!(ints(&eps, &format!("videos/{KEY}/file_index"))
        .iter()
        .all(|c| *c == 0));
    let mut start = 0i64;
    for (e, ((length, from), to)) in lengths.iter().zip(&from).zip(&to).enumerate() {
        assert_eq!(*from, start as f64 / fps as f64, "episode {e}");
        start += length;
        assert_eq!(*to, start as f64 / fps as f64, "episode {e}");
    }
    let video = root.join(format!("videos/{KEY}/chunk-000/file-000.mp4"));
    let contents = read_video(&video, false).expect("mp4");
    assert_eq!(contents.codec, "avc1");
    assert_eq!((contents.width, contents.height), (SIZE[0], SIZE[1]));
    assert_eq!(contents.samples.len() as i64, start);
    // Frame k at k / fps, and every episode starts on a key frame.
    let tick = u64::from(contents.timescale) / fps;
    assert_eq!(u64::from(contents.timescale), tick * fps);
    for (k, (t, _)) in contents.samples.iter().enumerate() {
        assert_eq!(*t, k as u64 * tick, "frame {k}");
    }
    let mut first = 0usize;
    for l in &lengths {
        assert!(
            contents.samples[first].1,
            "frame {first} is not a key frame"
        );
        first += *l as usize;
    }
}

/// The run's raw colour frames, in (episode, step) order as the dataset holds them.
fn raw_colour_frames() -> Vec<Vec<u8>> {
    let obs = table(&run_dir().join("observations.parquet"));
    let cells = obs
        .column_by_name("color")
        .expect("color column")
        .as_any()
        .downcast_ref::<BinaryArray>()
        .expect("binary")
        .clone();
    let ids = obs
        .column_by_name("episode_id")
        .expect("ids")
        .as_any()
        .downcast_ref::<StringArray>()
        .expect("strings")
        .clone();
    // The dataset's episode order is the episode table's.
    let order = table(&run_dir().join("episodes.parquet"));
    let order = order
        .column_by_name("episode_id")
        .expect("ids")
        .as_any()
        .downcast_ref::<StringArray>()
        .expect("strings")
        .clone();
    let mut out = Vec::new();
    for e in 0..order.len() {
        for r in 0..ids.len() {
            if ids.value(r) == order.value(e) {
                out.push(cells.value(r).to_vec());
            }
        }
    }
    out
}

fn psnr(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len());
    let mse = a
        .iter()
        .zip(b)
        .map(|(x, y)| (f64::from(*x) - f64::from(*y)).powi(2))
        .sum::<f64>()
        / a.len() as f64;
    10.0 * (255.0f64 * 255.0 / mse.max(1e-12)).log10()
}

#[test]
fn every_frame_decodes_close_to_the_raw_frame() {
    let raw = raw_colour_frames();
    let video = dataset().join(format!("videos/{KEY}/chunk-000/file-000.mp4"));
    let decoded = read_video(&video, true).expect("decodes");
    assert_eq!(decoded.frames.len(), raw.len());
    let all_raw: Vec<u8> = raw.concat();
    let all_dec: Vec<u8> = decoded.frames.concat();
    let total = psnr(&all_raw, &all_dec);
    assert!(total >= MIN_PSNR, "PSNR {total:.1} dB");
    for (k, (r, d)) in raw.iter().zip(&decoded.frames).enumerate() {
        assert_eq!(r.len(), (SIZE[0] * SIZE[1] * 3) as usize);
        let p = psnr(r, d);
        assert!(p >= MIN_PSNR - 4.0, "frame {k}: PSNR {p:.1} dB");
    }
    // Frames are not merely close to some frame: each is closest to its own raw frame
    // among its neighbours (no shift by one).
    for (k, (w, d)) in raw.windows(3).zip(&decoded.frames[1..]).enumerate() {
        if w[1] == w[0] || w[1] == w[2] {
            continue;
        }
        let own = psnr(&w[1], d);
        assert!(own >= psnr(&w[0], d), "frame {}", k + 1);
        assert!(own >= psnr(&w[2], d), "frame {}", k + 1);
    }
}

#[test]
fn export_dataset_video_gives_the_same_bytes_at_any_thread_count() {
    let out = fixture().dir.path().join("exported-video");
    minos()
        .args(["export-dataset", "--video", "--threads", "1", "--run"])
        .arg(run_dir())
        .arg("--out")
        .arg(&out)
        .arg("-q")
        .ok_output();
    assert_eq!(tree_bytes(&out), tree_bytes(&dataset()));
    // Without --video the colour camera is an image feature again, and the dataset larger.
    let images = fixture().dir.path().join("exported-images");
    minos()
        .args(["export-dataset", "--run"])
        .arg(run_dir())
        .arg("--out")
        .arg(&images)
        .arg("-q")
        .ok_output();
    let info = json(&images.join("meta/info.json"));
    assert_eq!(info["features"][KEY]["dtype"], "image");
    assert!(info["video_path"].is_null());
    assert!(!images.join("videos").exists());
}

#[test]
fn a_coarser_video_qp_gives_smaller_videos_further_from_the_raw_frames() {
    let coarse = fixture().dir.path().join("exported-qp38");
    minos()
        .args(["export-dataset", "--video", "--video-qp", "38", "--run"])
        .arg(run_dir())
        .arg("--out")
        .arg(&coarse)
        .arg("-q")
        .ok_output();
    let qp = |root: &Path| {
        json(&root.join("meta/info.json"))["features"][KEY]["info"]["minos.video_qp"].clone()
    };
    assert_eq!(qp(&coarse), 38);
    assert_eq!(qp(&dataset()), 26);
    let mp4 = |root: &Path| root.join(format!("videos/{KEY}/chunk-000/file-000.mp4"));
    let size = |root: &Path| std::fs::metadata(mp4(root)).expect("video").len();
    // Six steps of the quantiser double its step size: well under 70 % of the bytes.
    assert!(
        10 * size(&coarse) < 7 * size(&dataset()),
        "{} against {} bytes",
        size(&coarse),
        size(&dataset())
    );
    let raw: Vec<u8> = raw_colour_frames().concat();
    let quality = |root: &Path| {
        psnr(
            &raw,
            &read_video(&mp4(root), true)
                .expect("decodes")
                .frames
                .concat(),
        )
    };
    let (fine, rough) = (quality(&dataset()), quality(&coarse));
    assert!(rough < fine - 3.0, "{rough:.1} dB against {fine:.1} dB");
    assert!(rough > 24.0, "{rough:.1} dB");
    // Only the video changes: the data files are the same bytes.
    let data =
        |root: &Path| std::fs::read(root.join("data/chunk-000/file-000.parquet")).expect("data");
    assert_eq!(data(&coarse), data(&dataset()));
}

fn verify(path: &Path) -> (bool, String) {
    let out = minos()
        .arg("verify")
        .arg(path)
        .output()
        .expect("minos verify runs");
    (
        out.status.success(),
        format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ),
    )
}

/// A copy of the dataset to damage.
fn copy_of_dataset(name: &str) -> PathBuf {
    let to = fixture().dir.path().join(name);
    let from = dataset();
    for (rel, bytes) in tree_bytes(&from) {
        let p = to.join(&rel);
        std::fs::create_dir_all(p.parent().expect("parent")).expect("dir");
        std::fs::write(p, bytes).expect("write");
    }
    to
}

#[test]
fn verify_decodes_the_videos_and_finds_what_is_wrong_with_them() {
    let (ok, report) = verify(&dataset());
    assert!(ok, "{report}");
    assert!(report.contains("frames decoded"), "{report}");

    // A video cut short: its index is gone.
    let cut = copy_of_dataset("cut-video");
    let video = cut.join(format!("videos/{KEY}/chunk-000/file-000.mp4"));
    let bytes = std::fs::read(&video).expect("read");
    std::fs::write(&video, &bytes[..bytes.len() - 200]).expect("write");
    let (ok, report) = verify(&cut);
    assert!(!ok);
    assert!(
        report
            .lines()
            .any(|l| l.contains("file-000.mp4: file:") && !l.contains("sha256")),
        "{report}"
    );

    // A video with a frame dropped from its episode places: the second episode shifted
    // by one frame, and its statistics of another camera.
    let shifted = copy_of_dataset("shifted-video");
    let meta = shifted.join("meta/episodes/chunk-000/file-000.parquet");
    let eps = table(&meta);
    let col = format!("videos/{KEY}/from_timestamp");
    let mut from = floats(&eps, &col);
    from[1] += 1.0
        / json(&shifted.join("meta/info.json"))["fps"]
            .as_f64()
            .expect("fps");
    let mean_col = format!("stats/{KEY}/mean");
    let columns: Vec<std::sync::Arc<dyn Array>> = eps
        .schema()
        .fields()
        .iter()
        .enumerate()
        .map(|(i, f)| {
            if f.name() == &col {
                std::sync::Arc::new(Float64Array::from(from.clone())) as std::sync::Arc<dyn Array>
            } else if f.name() == &mean_col {
                // Episode 0's mean claims a white picture.
                let mut b = arrow::array::ListBuilder::new(arrow::array::ListBuilder::new(
                    arrow::array::ListBuilder::new(arrow::array::Float64Builder::new()),
                ));
                for r in 0..eps.num_rows() {
                    let old = eps
                        .column(i)
                        .as_any()
                        .downcast_ref::<arrow::array::ListArray>()
                        .expect("list")
                        .value(r);
                    let old = old
                        .as_any()
                        .downcast_ref::<arrow::array::ListArray>()
                        .expect("list");
                    for c in 0..old.len() {
                        let inner = old.value(c);
                        let inner = inner
                            .as_any()
                            .downcast_ref::<arrow::array::ListArray>()
                            .expect("list")
                            .value(0);
                        let v = inner
                            .as_any()
                            .downcast_ref::<Float64Array>()
                            .expect("f64")
                            .value(0);
                        b.values()
                            .values()
                            .values()
                            .append_value(if r == 0 { 1.0 } else { v });
                        b.values().values().append(true);
                        b.values().append(true);
                    }
                    b.append(true);
                }
                std::sync::Arc::new(b.finish()) as std::sync::Arc<dyn Array>
            } else {
                eps.column(i).clone()
            }
        })
        .collect();
    let schema = std::sync::Arc::new(arrow::datatypes::Schema::new(
        eps.schema()
            .fields()
            .iter()
            .zip(&columns)
            .map(|(f, c)| arrow::datatypes::Field::new(f.name(), c.data_type().clone(), true))
            .collect::<Vec<_>>(),
    ));
    let batch = RecordBatch::try_new(schema.clone(), columns).expect("batch");
    let mut w = parquet::arrow::ArrowWriter::try_new(
        std::fs::File::create(&meta).expect("create"),
        schema,
        None,
    )
    .expect("writer");
    w.write(&batch).expect("write");
    w.close().expect("close");
    let (ok, report) = verify(&shifted);
    assert!(!ok);
    assert!(
        report
            .lines()
            .any(|l| l.contains("row 1 (episode 1)") && l.contains("where its frames")),
        "{report}"
    );
    assert!(
        report
            .lines()
            .any(|l| l.contains("row 0 (episode 0)") && l.contains("stats mean[0]")),
        "{report}"
    );
}
