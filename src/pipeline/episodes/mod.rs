//! Sampling episodes over many scenes: load each scene's baked grid, sample in parallel,
//! keep scene order, and gather rejection statistics. Sharding takes every n-th scene of the
//! sorted list, so the union of all shards equals one unsharded run.

use crate::file_error::FileError;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::atomic::{sweep_stale_of, write_bytes_atomic};
use crate::body::BodyRule;
use crate::episode::format::{read_episodes, write_episodes, EpisodeFileError};
use crate::episode::sample::{sample_scene_from, SampleConfig, SceneEpisodes, Start};
use crate::episode::Episode;
use crate::progress::Progress;
use crate::scene::SceneRef;
use crate::shard::Shard;
use crate::store::DataDir;

mod import;
mod job;
mod rules;
pub use import::{import_job, ImportJob, ImportJobError, ImportReport};
pub use job::{
    default_min_geodesic, default_min_rooms, default_same_level, default_success_radius,
    expand_categories, parse_room_classes, run_job, select_scenes, EpisodesJob, EpisodesJobError,
    EpisodesOutcome, Stratify,
};
pub use rules::{check_options, EpisodeOptionsError};

/// Per-scene outcome in the statistics.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct SceneStats {
    /// Episodes sampled.
    pub episodes: usize,
    /// Rejected draws by reason.
    pub rejected: BTreeMap<String, u64>,
    /// Why the scene yielded nothing, if so.
    pub problem: Option<String>,
}

/// What a batch produced (its statistics are the `<out>.stats.json` beside the episode
/// file).
#[derive(Debug, Default, Serialize, Deserialize)]
pub struct EpisodeBatch {
    /// All episodes, scene by scene in sorted scene order.
    #[serde(skip)]
    pub episodes: Vec<Episode>,
    /// The shard of the scene list this batch sampled (`i/n`; `0/1` for all of it):
    /// `minos merge` checks that shards make a whole.
    pub shard: String,
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
    /// Episodes per distance bin (`easy`, `medium`, `hard`).
    #[serde(default)]
    pub difficulty: BTreeMap<String, usize>,
    /// Episodes per number of levels crossed (`"0"`, `"1"`, …).
    #[serde(default)]
    pub levels_crossed: BTreeMap<String, usize>,
    /// ObjectGoal: the category vocabulary of the episodes — every goal category with its
    /// episode count (categories are drawn uniformly among those reachable from the start,
    /// so counts differ only where scenes lack a category). Empty for other tasks.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub categories: BTreeMap<String, usize>,
    /// VLN: length and difficulty statistics of the routes and their instructions.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vln: Option<VlnStats>,
    /// Per scene.
    pub scenes: BTreeMap<String, SceneStats>,
    /// The object categories (lower case) of the sampled scenes' grids: `minos episodes`
    /// refuses an ObjectGoal category none of them has.
    #[serde(skip)]
    pub object_categories: std::collections::BTreeSet<String>,
}

/// Given starts by scene id, each scene's in the order given ([`read_starts`]).
pub type StartsByScene = BTreeMap<String, Vec<Start>>;

/// The starts (positions and yaws) of an episode file's episodes, by scene id in file order:
/// MINOS's episode states, for sampling another task's goals from the same starts.
pub fn read_starts(path: &Path) -> Result<StartsByScene, EpisodeFileError> {
    let mut out = StartsByScene::new();
    for e in read_episodes(path)? {
        out.entry(e.scene_id).or_default().push(Start {
            position: e.start_position,
            yaw: e.start_yaw,
        });
    }
    Ok(out)
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
    sample_scenes_from(data, scenes, cfg, body, shard, None, progress)
}

/// [`sample_scenes`], each scene's episodes from its given starts where `starts` is
/// ([`sample_scene_from`]; a scene without starts there yields none, a problem of that
/// scene).
pub fn sample_scenes_from(
    data: &DataDir,
    scenes: &[(String, String)],
    cfg: &SampleConfig,
    body: BodyRule,
    shard: Shard,
    starts: Option<&StartsByScene>,
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
    type Sampled = (SceneEpisodes, Vec<String>);
    let results: Vec<(String, Result<Sampled, SceneSkipped>)> = mine
        .par_iter()
        .map(|(id, split)| {
            let r = data
                .read_grid(&SceneRef::parse(id))
                .map_err(SceneSkipped::Grid)
                .and_then(|grid| {
                    body.check(&grid.params.body).map_err(SceneSkipped::Body)?;
                    let categories = grid
                        .objects
                        .iter()
                        .map(|o| o.category.to_ascii_lowercase())
                        .collect();
                    let given = starts.map(|m| m.get(id).map(Vec::as_slice).unwrap_or(&[]));
                    Ok((sample_scene_from(&grid, id, split, cfg, given), categories))
                });
            progress.advance(1);
            (id.clone(), r)
        })
        .collect();
    let mut batch = EpisodeBatch::default();
    for (id, r) in results {
        let mut stats = SceneStats::default();
        match r {
            Ok((s, categories)) => {
                batch.object_categories.extend(categories);
                stats.episodes = s.episodes.len();
                for (why, n) in &s.rejected {
                    *batch.rejected.entry(why.to_string()).or_insert(0) += n;
                    stats.rejected.insert(why.to_string(), *n);
                }
                let given = starts.map(|m| m.get(&id).map_or(0, Vec::len).min(cfg.per_scene));
                let wanted = given.unwrap_or(cfg.per_scene);
                stats.problem = s.unusable.or_else(|| {
                    (s.episodes.len() < wanted).then(|| match given {
                        Some(_) => format!(
                            "only {} of {wanted} given starts got an episode",
                            s.episodes.len()
                        ),
                        None => format!(
                            "only {} of {wanted} episodes after all attempts",
                            s.episodes.len()
                        ),
                    })
                });
                batch.episodes.extend(s.episodes);
            }
            Err(e) => stats.problem = Some(crate::escape::error_line(&e)),
        }
        batch.scenes.insert(id, stats);
    }
    batch.shard = shard.to_string();
    batch.summarise();
    batch
}

/// Why a scene was left out of an episodes job (the rest go on).
#[derive(Debug, thiserror::Error)]
enum SceneSkipped {
    /// Its grid is missing or unreadable.
    #[error(transparent)]
    Grid(crate::store::StoreError),
    /// Its grid was baked for another body.
    #[error(transparent)]
    Body(crate::body::BodyMismatch),
}

/// Length and difficulty statistics of VLN routes and instructions.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct VlnStats {
    /// Routes.
    pub routes: usize,
    /// Instructions (routes × instructions per route).
    pub instructions: usize,
    /// Words per instruction (R2R's tokens without punctuation): mean, min, max.
    pub words: Summary,
    /// Words per instruction by its place in the route's list (0: full detail, 1: medium,
    /// 2: brief, …): means.
    pub words_by_detail: Vec<f64>,
    /// Distinct words over all instructions.
    pub vocabulary: usize,
    /// Reference path length (m).
    pub path_length: Summary,
    /// Corners of the reference path (turns of the geodesic path).
    pub corners: Summary,
    /// Rooms passed.
    pub rooms: Summary,
    /// Doorways passed through.
    pub doors: Summary,
    /// Landmarks named (over the route's instructions).
    pub landmarks: Summary,
    /// Routes whose stop description names an object.
    pub stop_at_object: usize,
    /// Routes that change level (and name the stairs).
    pub multi_level: usize,
}

/// Mean, smallest and largest of a quantity.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Mean.
    pub mean: f64,
    /// Smallest.
    pub min: f64,
    /// Largest.
    pub max: f64,
}

impl Summary {
    /// The summary of `values` (zeros when empty).
    pub fn of(values: impl IntoIterator<Item = f64>) -> Summary {
        let (mut n, mut sum, mut min, mut max) = (0usize, 0.0, f64::INFINITY, f64::NEG_INFINITY);
        for v in values {
            n += 1;
            sum += v;
            min = min.min(v);
            max = max.max(v);
        }
        if n == 0 {
            return Summary::default();
        }
        Summary {
            mean: sum / n as f64,
            min,
            max,
        }
    }
}

impl VlnStats {
    /// The statistics of the episodes' routes (`None` when none has one).
    pub fn of(episodes: &[Episode]) -> Option<VlnStats> {
        let routes: Vec<&crate::episode::vln::Route> =
            episodes.iter().filter_map(|e| e.route.as_deref()).collect();
        if routes.is_empty() {
            return None;
        }
        let words = |t: &str| {
            crate::episode::vln::tokens::tokenize(t)
                .into_iter()
                .filter(|w| w.chars().any(|c| c.is_alphanumeric()))
                .collect::<Vec<_>>()
        };
        let mut vocabulary = std::collections::BTreeSet::new();
        let mut counts: Vec<f64> = Vec::new();
        let mut by_detail: Vec<(f64, usize)> = Vec::new();
        for r in &routes {
            for (k, t) in r.instructions.iter().enumerate() {
                let w = words(t);
                counts.push(w.len() as f64);
                if by_detail.len() <= k {
                    by_detail.resize(k + 1, (0.0, 0));
                }
                by_detail[k].0 += w.len() as f64;
                by_detail[k].1 += 1;
                vocabulary.extend(w);
            }
        }
        let length = |r: &crate::episode::vln::Route| {
            r.path
                .windows(2)
                .map(|w| {
                    let d: f32 = (0..3).map(|a| (w[1][a] - w[0][a]).powi(2)).sum();
                    f64::from(d.sqrt())
                })
                .sum::<f64>()
        };
        Some(VlnStats {
            routes: routes.len(),
            instructions: counts.len(),
            words: Summary::of(counts.iter().copied()),
            words_by_detail: by_detail
                .iter()
                .map(|(s, n)| if *n > 0 { s / *n as f64 } else { 0.0 })
                .collect(),
            vocabulary: vocabulary.len(),
            path_length: Summary::of(routes.iter().map(|r| length(r))),
            corners: Summary::of(routes.iter().map(|r| r.path.len().saturating_sub(2) as f64)),
            rooms: Summary::of(routes.iter().map(|r| r.rooms.len() as f64)),
            doors: Summary::of(routes.iter().map(|r| r.doors.len() as f64)),
            landmarks: Summary::of(routes.iter().map(|r| r.landmarks.len() as f64)),
            stop_at_object: routes.iter().filter(|r| r.goal_object.is_some()).count(),
            multi_level: routes.iter().filter(|r| r.levels.len() > 1).count(),
        })
    }
}

impl EpisodeBatch {
    /// The episodes grouped by the split names exports use — `train`, `val`, `test`, and
    /// `all` for episodes of no split (sampled without `--split`) —, each group in episode
    /// order, empty groups left out.
    pub fn export_splits(&self) -> Vec<(&'static str, Vec<Episode>)> {
        [
            ("train", "train"),
            ("val", "val"),
            ("test", "test"),
            ("", "all"),
        ]
        .into_iter()
        .filter_map(|(subset, name)| {
            let eps: Vec<Episode> = self
                .episodes
                .iter()
                .filter(|e| e.split == subset)
                .cloned()
                .collect();
            (!eps.is_empty()).then_some((name, eps))
        })
        .collect()
    }

    /// Sets the totals, means and distributions from the episodes (in their order, so the
    /// same episodes always give the same figures).
    pub fn summarise(&mut self) {
        let batch = self;
        batch.difficulty.clear();
        batch.levels_crossed.clear();
        batch.categories.clear();
        for e in &batch.episodes {
            *batch
                .difficulty
                .entry(e.difficulty.name().to_string())
                .or_default() += 1;
            *batch
                .levels_crossed
                .entry(e.levels_crossed.to_string())
                .or_default() += 1;
            if let crate::episode::Goal::Object { category, .. } = &e.goal {
                *batch.categories.entry(category.clone()).or_default() += 1;
            }
        }
        batch.vln = VlnStats::of(&batch.episodes);
        batch.total = batch.episodes.len();
        batch.mean_geodesic = 0.0;
        batch.mean_euclidean = 0.0;
        batch.mean_ratio = 0.0;
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
    }

    /// Writes the episode file `out` and its statistics `<out>.stats.json` (each atomically,
    /// after removing what a killed writer left beside them); returns the statistics' path.
    pub fn write(&self, out: &Path) -> Result<PathBuf, BatchWriteError> {
        let stats_path = PathBuf::from(format!("{}.stats.json", out.display()));
        for path in [out, stats_path.as_path()] {
            sweep_stale_of(path)
                .map_err(|source| BatchWriteError::Io(FileError::new(path, source)))?;
        }
        write_episodes(out, &self.episodes)?;
        let stats = serde_json::to_vec_pretty(self).map_err(|e| {
            BatchWriteError::Io(FileError {
                path: stats_path.clone(),
                source: std::io::Error::other(e),
            })
        })?;
        write_bytes_atomic(&stats_path, &stats)
            .map_err(|source| BatchWriteError::Io(FileError::new(stats_path.clone(), source)))?;
        Ok(stats_path)
    }
}

/// Why an episode batch could not be written.
#[derive(Debug, thiserror::Error)]
pub enum BatchWriteError {
    /// The episode file.
    #[error(transparent)]
    Episodes(#[from] EpisodeFileError),
    /// The statistics file, or sweeping stale temporaries.
    #[error(transparent)]
    Io(#[from] FileError),
}
