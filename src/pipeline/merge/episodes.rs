//! Merging episode files: the shards' episodes, scene by scene in sorted scene order (each
//! scene's episodes come whole from the one shard that sampled it), and their statistics
//! (per-scene outcomes joined, rejection counts summed, means recomputed in episode order).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::{check_shards, recorded_shard, MergeError, MergeReport};
use crate::episode::format::read_episodes;
use crate::pipeline::episodes::EpisodeBatch;
use crate::progress::Progress;
use crate::shard::Shard;

/// Joins the episode files `parts` (each with its `<part>.stats.json`) into `out` and
/// `<out>.stats.json`: the bytes `minos episodes` writes without `--shard`. `progress`
/// counts each shard read, then the write.
pub fn merge_episodes(
    parts: &[PathBuf],
    out: &Path,
    progress: &dyn Progress,
) -> Result<MergeReport, MergeError> {
    progress.set_total(parts.len() as u64 + 1);
    let mut found: Vec<(PathBuf, Shard)> = Vec::new();
    let mut batches: Vec<EpisodeBatch> = Vec::new();
    for part in parts {
        let stats_path = PathBuf::from(format!("{}.stats.json", part.display()));
        let bytes = std::fs::read(&stats_path).map_err(|source| MergeError::NoStats {
            path: stats_path.clone(),
            source,
        })?;
        let mut batch: EpisodeBatch =
            serde_json::from_slice(&bytes).map_err(|source| MergeError::ShardJson {
                path: stats_path.clone(),
                source,
            })?;
        found.push((
            part.clone(),
            recorded_shard(
                &stats_path,
                Some(batch.shard.as_str()).filter(|s| !s.is_empty()),
            )?,
        ));
        batch.episodes = read_episodes(part).map_err(MergeError::ShardEpisodes)?;
        if batch.episodes.len() != batch.total {
            return Err(MergeError::Shards(format!(
                "{}: {} episodes, but its statistics count {}",
                part.display(),
                batch.episodes.len(),
                batch.total
            )));
        }
        batches.push(batch);
        progress.advance(1);
    }
    check_shards(&found)?;
    let mut merged = EpisodeBatch {
        shard: Shard::ALL.to_string(),
        ..EpisodeBatch::default()
    };
    let mut owner: BTreeMap<String, &Path> = BTreeMap::new();
    for (batch, (part, _)) in batches.iter_mut().zip(&found) {
        for (scene, stats) in std::mem::take(&mut batch.scenes) {
            if let Some(other) = owner.insert(scene.clone(), part) {
                return Err(MergeError::Shards(format!(
                    "{}: scene `{scene}` was also sampled by {}: the shards overlap",
                    part.display(),
                    other.display()
                )));
            }
            merged.scenes.insert(scene, stats);
        }
        for (why, n) in &batch.rejected {
            *merged.rejected.entry(why.clone()).or_insert(0) += n;
        }
        merged.episodes.append(&mut batch.episodes);
    }
    // Scene by scene in sorted (scene, split) order, as one unsharded batch lists them; the
    // sort is stable, so each scene's episodes keep their order.
    merged
        .episodes
        .sort_by(|a, b| (&a.scene_id, &a.split).cmp(&(&b.scene_id, &b.split)));
    merged.summarise();
    let stats = merged.write(out).map_err(MergeError::WriteEpisodes)?;
    progress.advance(1);
    Ok(MergeReport {
        shards: parts.len(),
        episodes: merged.total,
        written: vec![out.to_path_buf(), stats],
        ..MergeReport::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicU64, Ordering};

    #[derive(Default)]
    struct Counted {
        total: AtomicU64,
        done: AtomicU64,
    }

    impl Progress for Counted {
        fn set_total(&self, total: u64) {
            self.total.store(total, Ordering::Relaxed);
        }
        fn advance(&self, n: u64) {
            self.done.fetch_add(n, Ordering::Relaxed);
        }
    }

    #[test]
    fn progress_counts_each_shard_and_the_write_to_its_total() {
        let dir = tempfile::tempdir().expect("temp dir");
        let parts: Vec<PathBuf> = (0..3)
            .map(|i| {
                let part = dir.path().join(format!("e{i}.parquet"));
                let batch = EpisodeBatch {
                    shard: format!("{i}/3"),
                    ..EpisodeBatch::default()
                };
                batch.write(&part).expect("write a shard");
                part
            })
            .collect();
        let progress = Counted::default();
        let out = dir.path().join("all.parquet");
        let report = merge_episodes(&parts, &out, &progress).expect("merge");
        assert_eq!(report.shards, 3);
        assert_eq!(progress.total.load(Ordering::Relaxed), 4);
        assert_eq!(progress.done.load(Ordering::Relaxed), 4);
        assert!(out.is_file());
    }
}
