//! Sampling episodes over many scenes: load each scene's baked grid, sample in parallel,
//! keep scene order, and gather rejection statistics. Sharding takes every n-th scene of the
//! sorted list, so the union of all shards equals one unsharded run.

use std::collections::BTreeMap;
use std::path::Path;

use rayon::prelude::*;
use serde::Serialize;

use crate::io::variant_store::grid_ref;
use crate::navmesh::file::{nav_path, read_nav};
use crate::progress::Progress;

use super::sample::{sample_scene, SampleConfig};
use super::Episode;

/// One shard of a scene list: `index` of `count` (`0/1` is everything).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard (0-based).
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl Shard {
    /// Everything.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Parses `i/n` with `0 <= i < n`.
    pub fn parse(s: &str) -> Result<Shard, String> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| format!("`{s}`: expected i/n, e.g. 0/4"))?;
        let num = |t: &str| {
            t.trim()
                .parse::<usize>()
                .map_err(|_| format!("`{s}`: `{t}` is not a whole number"))
        };
        let (index, count) = (num(i)?, num(n)?);
        if count == 0 || index >= count {
            return Err(format!("`{s}`: need 0 <= i < n"));
        }
        Ok(Shard { index, count })
    }
}

/// Per-scene outcome in the statistics.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SceneStats {
    /// Episodes sampled.
    pub episodes: usize,
    /// Rejected draws by reason.
    pub rejected: BTreeMap<String, u64>,
    /// Why the scene yielded nothing, if so.
    pub problem: Option<String>,
}

/// What a batch produced.
#[derive(Debug, Default, Serialize)]
pub struct EpisodeBatch {
    /// All episodes, scene by scene in sorted scene order.
    #[serde(skip)]
    pub episodes: Vec<Episode>,
    /// Total episodes.
    pub total: usize,
    /// Rejected draws by reason, over all scenes.
    pub rejected: BTreeMap<String, u64>,
    /// Mean geodesic distance of the episodes (m).
    pub mean_geodesic: f64,
    /// Mean straight-line distance of the episodes (m).
    pub mean_euclidean: f64,
    /// Mean of each episode's geodesic / Euclidean distance ratio: how much the layout makes
    /// the agent detour (MINOS compared it between empty and furnished houses).
    pub mean_ratio: f64,
    /// Per scene.
    pub scenes: BTreeMap<String, SceneStats>,
}

/// Samples `cfg` over `scenes` (`(scene id, split subset)`), reading grids from `data`.
pub fn sample_scenes(
    data: &Path,
    scenes: &[(String, String)],
    cfg: &SampleConfig,
    shard: Shard,
    progress: &dyn Progress,
) -> EpisodeBatch {
    let mut sorted: Vec<&(String, String)> = scenes.iter().collect();
    sorted.sort();
    sorted.dedup();
    let mine: Vec<&(String, String)> = sorted
        .into_iter()
        .enumerate()
        .filter(|(i, _)| i % shard.count == shard.index)
        .map(|(_, s)| s)
        .collect();
    progress.set_total(mine.len() as u64);
    let results: Vec<(String, Result<super::sample::SceneEpisodes, String>)> = mine
        .par_iter()
        .map(|(id, split)| {
            let r = read_nav(&nav_path(data, &grid_ref(data, id)))
                .map_err(|e| format!("{e} (run `minos bake`)"))
                .map(|grid| sample_scene(&grid, id, split, cfg));
            progress.advance(1);
            (id.clone(), r)
        })
        .collect();
    let mut batch = EpisodeBatch::default();
    for (id, r) in results {
        let mut stats = SceneStats::default();
        match r {
            Ok(s) => {
                stats.episodes = s.episodes.len();
                for (why, n) in &s.rejected {
                    *batch.rejected.entry(why.to_string()).or_insert(0) += n;
                    stats.rejected.insert(why.to_string(), *n);
                }
                stats.problem = s.unusable.or_else(|| {
                    (s.episodes.len() < cfg.per_scene).then(|| {
                        format!(
                            "only {} of {} episodes after all attempts",
                            s.episodes.len(),
                            cfg.per_scene
                        )
                    })
                });
                batch.episodes.extend(s.episodes);
            }
            Err(e) => stats.problem = Some(e),
        }
        batch.scenes.insert(id, stats);
    }
    batch.total = batch.episodes.len();
    if batch.total > 0 {
        let n = batch.total as f64;
        let eps = &batch.episodes;
        batch.mean_geodesic = eps
            .iter()
            .map(|e| f64::from(e.geodesic_distance))
            .sum::<f64>()
            / n;
        batch.mean_euclidean = eps
            .iter()
            .map(|e| f64::from(e.euclidean_distance))
            .sum::<f64>()
            / n;
        batch.mean_ratio = eps
            .iter()
            .map(|e| f64::from(e.geodesic_distance) / f64::from(e.euclidean_distance).max(1e-6))
            .sum::<f64>()
            / n;
    }
    batch
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse() {
        assert_eq!(Shard::parse("1/4"), Ok(Shard { index: 1, count: 4 }));
        assert!(Shard::parse("4/4").is_err());
        assert!(Shard::parse("1").is_err());
    }
}
