//! A LeRobot dataset's video features (`dtype: video`): every file `meta/episodes` points at
//! exists and holds one H.264 track of the declared size, every frame decodes (OpenH264, the
//! crate family that wrote it) at that size, frame `k` is shown at `k / fps`, each episode's
//! frames are where its `from_timestamp` / `to_timestamp` say, the episodes of a file
//! follow each other and fill it, each episode starts on a key frame, and each episode's
//! stored mean per channel is that of its decoded frames within [`MEAN_TOLERANCE`] (the
//! statistics are of the camera's own frames; the video is lossy).

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use serde_json::Value;

use super::lerobot::EpisodeRow;
use super::{tables, Found};
use crate::io::lerobot::layout::{self, FileIndex, VIDEO_PATH};
use crate::io::lerobot::video::CODEC;
use crate::io::lerobot::video_read::read_video;

/// How far an episode's stored mean (per channel, in \[0, 1\]) may be from its decoded
/// frames' mean: the encoding error of a mean over many pixels is far below this, a wrong
/// episode or camera is not.
pub const MEAN_TOLERANCE: f64 = 0.02;

/// One episode's place in a video feature's files, as `meta/episodes` says.
struct Place {
    episode: i64,
    length: u64,
    file: (i64, i64),
    from: f64,
    to: f64,
    mean: Vec<f64>,
    meta: PathBuf,
    row: usize,
}

/// Checks every video feature (`key`, declared `[h, w, c]` shape) of the dataset `root`.
pub(super) fn check(
    root: &Path,
    info: &Value,
    fps: u64,
    videos: &[(String, Vec<u64>)],
    metas: &HashMap<i64, EpisodeRow>,
    found: &mut Found,
) {
    if videos.is_empty() {
        return;
    }
    let info_path = root.join(layout::INFO);
    if info.get("video_path").and_then(Value::as_str) != Some(VIDEO_PATH) {
        found.problem(
            &info_path,
            "video_path",
            format!(
                "{} where the dataset has video features (LeRobot's is `{VIDEO_PATH}`)",
                info.get("video_path").unwrap_or(&Value::Null)
            ),
        );
        return;
    }
    let fps = fps.max(1);
    let mut order: Vec<i64> = metas.keys().copied().collect();
    order.sort_unstable();
    let mut frames_checked = 0u64;
    for (key, shape) in videos {
        let f_info = info.pointer(&format!("/features/{}/info", key.replace('/', "~1")));
        let declared_fps = f_info
            .and_then(|i| i.get("video.fps"))
            .and_then(Value::as_u64);
        if declared_fps != Some(fps) {
            found.problem(
                &info_path,
                format!("features.{key}.info.video.fps"),
                format!("{declared_fps:?} where the dataset's fps is {fps}"),
            );
        }
        let codec = f_info
            .and_then(|i| i.get("video.codec"))
            .and_then(Value::as_str);
        if codec != Some(CODEC) {
            found.problem(
                &info_path,
                format!("features.{key}.info.video.codec"),
                format!("{codec:?} where the files are `{CODEC}`"),
            );
        }
        // Episodes by file, in episode order.
        let mut by_file: BTreeMap<FileIndex, Vec<Place>> = BTreeMap::new();
        for e in &order {
            let m = &metas[e];
            let num = |name: &str| {
                tables::numbers(&m.batch, name)
                    .ok()
                    .and_then(|v| v.get(m.row).copied())
            };
            let col = |what: &str| layout::video_column(key, what);
            let values = (
                num(&col("chunk_index")),
                num(&col("file_index")),
                num(&col("from_timestamp")),
                num(&col("to_timestamp")),
                num("length"),
            );
            let (Some(c), Some(f), Some(from), Some(to), Some(length)) = values else {
                found.problem(
                    &m.path,
                    format!("row {} (episode {e})", m.row),
                    format!("`videos/{key}/…` place or `length` missing"),
                );
                continue;
            };
            let mean = m
                .batch
                .column_by_name(&format!("stats/{key}/mean"))
                .map(|c| tables::cell_f64(c.as_ref(), m.row))
                .unwrap_or_default();
            by_file
                .entry(FileIndex {
                    chunk: c as usize,
                    file: f as usize,
                })
                .or_default()
                .push(Place {
                    episode: *e,
                    length: length as u64,
                    file: (c as i64, f as i64),
                    from,
                    to,
                    mean,
                    meta: m.path.clone(),
                    row: m.row,
                });
        }
        for (index, places) in &by_file {
            let path = root.join(index.video(key));
            frames_checked += check_file(&path, shape, fps, places, found);
        }
    }
    found.checked.push(format!(
        "LeRobot videos: {} features, {frames_checked} frames decoded",
        videos.len()
    ));
}

/// One video file against the episodes that point at it; the frames decoded.
fn check_file(path: &Path, shape: &[u64], fps: u64, places: &[Place], found: &mut Found) -> u64 {
    let contents = match read_video(path, true) {
        Ok(c) => c,
        Err(e) => {
            found.problem(path, "file", crate::escape::error_line(&e));
            return 0;
        }
    };
    let (h, w) = (
        shape.first().copied().unwrap_or(0),
        shape.get(1).copied().unwrap_or(0),
    );
    if (u64::from(contents.height), u64::from(contents.width)) != (h, w) {
        found.problem(
            path,
            "track",
            format!(
                "{}×{} frames where info.json declares {:?}",
                contents.width, contents.height, shape
            ),
        );
        return 0;
    }
    let n = contents.samples.len();
    if contents.frames.len() != n {
        found.problem(
            path,
            "frames",
            format!("{} of {n} frames decode", contents.frames.len()),
        );
    }
    if let Some((k, (dw, dh))) = contents
        .decoded_sizes
        .iter()
        .enumerate()
        .find(|(_, s)| (u64::from(s.1), u64::from(s.0)) != (h, w))
    {
        found.problem(
            path,
            format!("frame {k}"),
            format!("decodes as {dw}×{dh} where info.json declares {shape:?}"),
        );
    }
    let ts = u64::from(contents.timescale);
    if ts == 0 || !ts.is_multiple_of(fps) {
        found.problem(
            path,
            "track",
            format!("timescale {ts} is not a multiple of {fps} fps"),
        );
        return contents.frames.len() as u64;
    }
    let tick = ts / fps;
    if let Some(k) = (0..n).find(|k| contents.samples[*k].0 != *k as u64 * tick) {
        found.problem(
            path,
            format!("frame {k}"),
            format!(
                "shown at {} s where frame {k} at {fps} fps is {} s",
                contents.samples[k].0 as f64 / ts as f64,
                k as f64 / fps as f64
            ),
        );
    }
    let mut start = 0u64;
    for p in places {
        let record = format!("row {} (episode {})", p.row, p.episode);
        let want_from = start as f64 / fps as f64;
        let want_to = (start + p.length) as f64 / fps as f64;
        // LeRobot's decoders accept 1e-4 s; the exporter writes these exactly.
        if (p.from - want_from).abs() > 1e-9 || (p.to - want_to).abs() > 1e-9 {
            found.problem(
                &p.meta,
                record.as_str(),
                format!(
                    "video {}/{} from {} to {} s where its frames {start}..{} of {} are {want_from} to {want_to} s",
                    p.file.0,
                    p.file.1,
                    p.from,
                    p.to,
                    start + p.length,
                    path.display()
                ),
            );
        }
        let first = start as usize;
        if first < n && !contents.samples[first].1 {
            found.problem(
                path,
                format!("frame {first}"),
                format!("episode {}'s first frame is not a key frame", p.episode),
            );
        }
        let end = (start + p.length) as usize;
        if end <= contents.frames.len() && !p.mean.is_empty() {
            let mean = channel_means(&contents.frames[first..end]);
            if let Some(c) = (0..3).find(|c| {
                p.mean
                    .get(*c)
                    .is_none_or(|m| (m - mean[*c]).abs() > MEAN_TOLERANCE)
            }) {
                found.problem(
                    &p.meta,
                    record.as_str(),
                    format!(
                        "stats mean[{c}] {:?} where its decoded frames give {:.4} (± {MEAN_TOLERANCE})",
                        p.mean.get(c),
                        mean[c]
                    ),
                );
            }
        }
        start += p.length;
    }
    if start != n as u64 {
        found.problem(
            path,
            "frames",
            format!("{n} frames where its episodes have {start}"),
        );
    }
    contents.frames.len() as u64
}

/// Mean per RGB channel in \[0, 1\] of interleaved frames.
fn channel_means(frames: &[Vec<u8>]) -> [f64; 3] {
    let mut sum = [0u64; 3];
    let mut count = 0u64;
    for f in frames {
        for px in f.chunks_exact(3) {
            for (s, v) in sum.iter_mut().zip(px) {
                *s += u64::from(*v);
            }
            count += 1;
        }
    }
    let count = count.max(1) as f64;
    sum.map(|s| s as f64 / count / 255.0)
}
