//! Sampling episodes over many scenes: load each scene's baked grid, sample in parallel,
//! keep scene order, and gather rejection statistics. Sharding takes every n-th scene of the
//! sorted list, so the union of all shards equals one unsharded run.

use std::collections::BTreeMap;

use rayon::prelude::*;
use serde::Serialize;

use crate::body::BodyRule;
use crate::episode::sample::{sample_scene, SampleConfig, SceneEpisodes};
use crate::episode::Episode;
use crate::progress::Progress;
use crate::scene::SceneRef;
use crate::shard::Shard;
use crate::store::DataDir;

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

/// Samples `cfg` over `scenes` (`(scene id, split subset)`), reading grids from `data`; a
/// scene whose grid was baked for another body than `body`'s is a problem of that scene.
pub fn sample_scenes(
    data: &DataDir,
    scenes: &[(String, String)],
    cfg: &SampleConfig,
    body: BodyRule,
    shard: Shard,
    progress: &dyn Progress,
) -> EpisodeBatch {
    let mut sorted: Vec<&(String, String)> = scenes.iter().collect();
    sorted.sort();
    sorted.dedup();
    let mine: Vec<&(String, String)> = sorted
        .into_iter()
        .enumerate()
        .filter(|(i, _)| shard.keeps(*i))
        .map(|(_, s)| s)
        .collect();
    progress.set_total(mine.len() as u64);
    let results: Vec<(String, Result<SceneEpisodes, String>)> = mine
        .par_iter()
        .map(|(id, split)| {
            let r = data
                .read_grid(&SceneRef::parse(id))
                .map_err(|e| e.to_string())
                .and_then(|grid| {
                    body.check(&grid.params.body).map_err(|e| e.to_string())?;
                    Ok(sample_scene(&grid, id, split, cfg))
                });
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
