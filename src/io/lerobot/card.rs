//! The dataset card (`README.md`, with the Hugging Face dataset-card YAML header the Hub and
//! `huggingface_hub.DatasetCard` read) and the provenance record (`meta/provenance.json`) of
//! a LeRobot export, written last: the record lists the sha256 of every other file.

use std::path::Path;

use serde_json::{json, Value};

use super::layout::{CARD, INFO, PROVENANCE};
use super::{io, LerobotError, RunTables};
use crate::atomic::write_bytes_atomic;
use crate::provenance::{self, MINOS};


fn provenance_error(e: crate::file_error::FileError) -> LerobotError {
    super::write_error(&e.path, e.source)
}

/// Writes `root/README.md` from `root/meta/info.json`, then `root/meta/provenance.json`.
/// Neither names the folder: a copy written elsewhere has the same bytes.
pub fn write_card_and_provenance(
    sources: &[&RunTables],
    root: &Path,
    run: Option<&Value>,
) -> Result<(), LerobotError> {
    let info_path = root.join(INFO);
    let info: Value = std::fs::read(&info_path)
        .map_err(io(&info_path))
        .and_then(|b| serde_json::from_slice(&b).map_err(|e| super::write_error(&info_path, e)))?;
    let readme = root.join(CARD);
    write_bytes_atomic(&readme, dataset_card(&info).as_bytes()).map_err(io(&readme))?;
    let mut source = serde_json::Map::new();
    let name = |p: &Path| {
        p.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    for (table, run) in sources.iter().flat_map(|t| {
        [&t.episodes, &t.trajectories, &t.observations]
            .into_iter()
            .map(move |f| (f, t))
    }) {
        // One run: the file's name (as always); several: `<run folder>/<file>`.
        let key = if sources.len() == 1 {
            name(table)
        } else {
            let folder = run.episodes.parent().map(name).unwrap_or_default();
            format!("{folder}/{}", name(table))
        };
        let sum = provenance::sha256_file(table).map_err(provenance_error)?;
        source.insert(key, json!(sum));
    }
    let files = provenance::checksums(root, &[PROVENANCE]).map_err(provenance_error)?;
    let record = json!({
        "format": provenance::FORMAT,
        "kind": "lerobot-dataset",
        "minos": MINOS,
        "run": run,
        "source_run_tables": source,
        "files": files,
    });
    provenance::write_record(&root.join(PROVENANCE), &record).map_err(provenance_error)
}

/// The card: YAML header (task categories, tags, the data files; no `license`, which is the
/// publisher's to choose), then what the dataset holds, its features, and how it was made.
pub fn dataset_card(info: &Value) -> String {
    let n = |key: &str| info.get(key).and_then(Value::as_i64).unwrap_or(0);
    let mut features = String::new();
    if let Some(map) = info.get("features").and_then(Value::as_object) {
        for (key, f) in map {
            let dtype = f.get("dtype").and_then(Value::as_str).unwrap_or("?");
            let shape = f
                .get("shape")
                .map(|s| s.to_string())
                .unwrap_or_else(|| "?".into());
            let meaning = f
                .pointer("/info/minos/meaning")
                .and_then(Value::as_str)
                .unwrap_or("")
                .replace('|', "\\|");
            features.push_str(&format!("| `{key}` | {dtype} | {shape} | {meaning} |\n"));
        }
    }
    let mut splits = String::new();
    if let Some(map) = info.get("splits").and_then(Value::as_object) {
        for (split, range) in map {
            let range = range
                .as_str()
                .map_or_else(|| range.to_string(), str::to_string);
            splits.push_str(&format!("| {split} | {range} |\n"));
        }
    }
    format!(
        "---\n\
         # license: not set by minos: choose one; the source scenes' terms apply to their images\n\
         task_categories:\n\
         - robotics\n\
         tags:\n\
         - LeRobot\n\
         - minos\n\
         - navigation\n\
         - embodied-ai\n\
         configs:\n\
         - config_name: default\n  \
         data_files: data/*/*.parquet\n\
         ---\n\
         \n\
         # A minos navigation dataset\n\
         \n\
         An indoor navigation dataset in the LeRobot {version} format: {episodes} episodes, \
         {frames} frames at {fps} frames per second, {tasks} distinct task instructions \
         (robot type `{robot}`). Made by minos {minos} (source commit `{commit}`).\n\
         \n\
         ## Features\n\
         \n\
         | feature | dtype | shape | meaning |\n\
         |---|---|---|---|\n\
         {features}\
         \n\
         ## Splits (episode ranges)\n\
         \n\
         | split | episodes |\n\
         |---|---|\n\
         {splits}\
         \n\
         ## How it was made\n\
         \n\
         An agent of `minos run` stepped through episodes sampled on navigation grids baked \
         from indoor scenes; this dataset is a copy of that run's tables (`minos run --format \
         lerobot` or `minos export-dataset`). The run folder's `manifest.json` records the \
         command. `meta/provenance.json` holds the minos version and commit, the run's \
         configuration (episode file, agent, body, sensors, seed, reward, and the scenes with \
         the sha256 of each compiled scene and of its source files), the sha256 of the run \
         tables this copy was made from and the sha256 of every file here but itself: check \
         a downloaded copy against it.\n\
         \n\
         ## Loading\n\
         \n\
         ```python\n\
         from lerobot.datasets.lerobot_dataset import LeRobotDataset\n\
         dataset = LeRobotDataset(\"<user>/<dataset>\", root=\"path/to/this/folder\")\n\
         ```\n{videos}",
        version = info
            .get("codebase_version")
            .and_then(Value::as_str)
            .unwrap_or("v3.0"),
        episodes = n("total_episodes"),
        frames = n("total_frames"),
        fps = n("fps"),
        tasks = n("total_tasks"),
        robot = info.get("robot_type").and_then(Value::as_str).unwrap_or(""),
        minos = MINOS.version,
        commit = MINOS.commit,
        videos = if info.get("video_path").is_some_and(|p| !p.is_null()) {
            "\nColour cameras are `video` features: H.264 in MP4 under `videos/` (lossy; depth \
             and labels stay lossless in the data files). LeRobot decodes them with torchcodec, \
             which needs the FFmpeg libraries, or with PyAV: `LeRobotDataset(..., \
             video_backend=\"pyav\")`.\n"
        } else {
            ""
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_card_has_the_hub_header_features_and_splits() {
        let info = json!({
            "codebase_version": "v3.0", "total_episodes": 3, "total_frames": 40, "fps": 10,
            "total_tasks": 2, "robot_type": "minos",
            "splits": {"train": "0:2", "val": "2:3"},
            "features": {"action": {"dtype": "int64", "shape": [1],
                                    "info": {"minos": {"meaning": "a|b"}}}},
        });
        let card = dataset_card(&info);
        let header = card.split("---\n").nth(1).unwrap();
        assert!(header.contains("task_categories:\n- robotics\n"), "{card}");
        assert!(header.contains("- LeRobot\n"), "{card}");
        assert!(
            header.contains("  data_files: data/*/*.parquet\n"),
            "{card}"
        );
        assert!(!header.lines().any(|l| l.starts_with("license:")), "{card}");
        assert!(
            card.contains("| `action` | int64 | [1] | a\\|b |"),
            "{card}"
        );
        assert!(card.contains("| val | 2:3 |"), "{card}");
        assert!(
            card.contains("3 episodes, 40 frames at 10 frames per second"),
            "{card}"
        );
        assert!(card.contains(MINOS.commit), "{card}");
    }
}
