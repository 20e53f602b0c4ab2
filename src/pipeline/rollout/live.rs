//! A run fed one episode at a time by its caller: an interactive session (`minos serve`)
//! plays the episodes a person chooses, with an agent that waits for that person's actions.
//! Each episode is rolled out exactly as [`run_with`](super::run_with) rolls it out (the
//! same simulator set-up, episode loop and part files), and after each finished episode the
//! run's tables, `metrics.json` and `manifest.json` are rewritten from the finished parts
//! (each file under a temporary name, then renamed), so the output folder always holds a
//! complete run of the episodes finished so far, in episode-id order: a session killed
//! mid-episode leaves exactly the episodes it finished, and `minos run --agent
//! replay:DIR/trajectories.parquet` over them gives the same tables. The finished episodes
//! themselves are written last, as an episode file, `DIR/played.parquet` ([`PLAYED`]): the
//! `--episodes` of that replay.

use std::collections::BTreeSet;
use std::path::Path;

use super::episode::run_episode;
use super::scene::{self, SceneRun};
use super::{finish, io_error, preflight, Failed, RolloutError, RunConfig, RunReport};
use crate::atomic::sweep_stale;
use crate::episode::Episode;
use crate::lock::{DirLock, LockMode};
use crate::navmesh::geodesic::Geodesic;
use crate::run::agents::Agent;
use crate::run::metrics::EpisodeMetrics;

/// The episode file of a live run's finished episodes (in the order played), written after
/// its tables.
pub const PLAYED: &str = "played.parquet";

/// Where the episodes of a live run come from, and who hears how they ended.
pub trait EpisodeSource {
    /// The next episode to play (it may block while a person chooses); `None` ends the run.
    fn next(&mut self) -> Option<Episode>;
    /// An episode ended: its metrics once the run's outputs include it, or why it did not
    /// finish (its scene cannot run, it was played already, the agent gave up).
    fn finished(&mut self, episode: &Episode, outcome: Result<&EpisodeMetrics, String>);
}

/// Plays the episodes `source` hands out with `agent` into `cfg.out` (holding its writer
/// lock, taken as `mode` says), rewriting the run's outputs after every finished episode;
/// returns when `source` has no more. `cfg.agent`, `cfg.shard`, `cfg.resume` and
/// `cfg.rerun` are not used: the agent is `agent`, and every episode is played once (an
/// episode id played already is refused). An episode that fails is reported to `source`
/// and left out of the outputs; only a file that cannot be written stops the run.
pub fn run_live(
    cfg: &RunConfig,
    source: &mut dyn EpisodeSource,
    agent: Box<dyn Agent>,
    mode: LockMode,
) -> Result<RunReport, RolloutError> {
    let _lock = DirLock::acquire(&cfg.out, "serve", mode)?;
    let parts = cfg.out.join(".parts");
    for dir in [cfg.out.as_path(), parts.as_path()] {
        sweep_stale(dir).map_err(io_error(dir))?;
    }
    if parts.exists() {
        std::fs::remove_dir_all(&parts).map_err(io_error(&parts))?;
    }
    std::fs::create_dir_all(&parts).map_err(io_error(&parts))?;
    let mut live = Live {
        cfg,
        parts: &parts,
        played: Vec::new(),
        report: RunReport::default(),
    };
    let mut agent = Some(agent);
    let mut pending = source.next();
    while let Some(first) = pending.take() {
        if let Err(problem) = live.playable(&first) {
            source.finished(&first, Err(problem));
            pending = source.next();
            continue;
        }
        let (sim, assets) = match scene::load(cfg, &first.scene_id) {
            Ok(loaded) => loaded,
            Err(e) => {
                source.finished(&first, Err(e));
                pending = source.next();
                continue;
            }
        };
        let Some(a) = agent.take() else { break };
        let mut run = SceneRun::new(sim, a, cfg, Geodesic::new(&assets.grid));
        // Every episode of this scene, until the source moves to another scene or ends.
        let mut ep = Some(first);
        while let Some(e) = ep.take() {
            match live.play(&mut run, &e) {
                Ok(m) => source.finished(&e, Ok(&m)),
                Err(Failed::Write(w)) => return Err(RolloutError::Write(w)),
                Err(Failed::Episode(problem)) => source.finished(&e, Err(problem)),
            }
            match source.next() {
                Some(n) if n.scene_id == e.scene_id => match live.playable(&n) {
                    Ok(()) => ep = Some(n),
                    Err(problem) => {
                        source.finished(&n, Err(problem));
                        pending = source.next();
                        break;
                    }
                },
                other => {
                    pending = other;
                    break;
                }
            }
        }
        agent = Some(run.agent);
        // A pending episode of the same scene (after a refused one) reloads it: rare.
    }
    if live.report.failures.is_empty() {
        let _ = std::fs::remove_dir_all(&parts);
    }
    Ok(live.report)
}

/// The state of a live run: the finished episodes (with the index of their part files).
struct Live<'c> {
    cfg: &'c RunConfig,
    parts: &'c Path,
    /// Finished episodes with their part index, in the order played.
    played: Vec<(usize, Episode, EpisodeMetrics)>,
    report: RunReport,
}

impl Live<'_> {
    /// Whether `ep` can be played: not played yet, its scene ingested and baked for the body.
    fn playable(&self, ep: &Episode) -> Result<(), String> {
        if self
            .played
            .iter()
            .any(|(_, e, _)| e.episode_id == ep.episode_id)
        {
            return Err(format!("episode {} was played already", ep.episode_id));
        }
        preflight::check(self.cfg, &[(0, ep.clone())]).map_err(|e| e.to_string())
    }

    /// Plays `ep` into its part files, then rewrites the run's outputs with it.
    fn play(&mut self, run: &mut SceneRun<'_>, ep: &Episode) -> Result<EpisodeMetrics, Failed> {
        let index = self.played.len();
        let m = run_episode(run, ep, self.cfg, self.parts, index, false).map_err(Failed::of)?;
        self.played.push((index, ep.clone(), m));
        // The outputs of `run_with` over the finished episodes: in episode-id order.
        let mut sorted: Vec<&(usize, Episode, EpisodeMetrics)> = self.played.iter().collect();
        sorted.sort_by(|a, b| a.1.episode_id.cmp(&b.1.episode_id));
        let mine: Vec<(usize, Episode)> = sorted.iter().map(|(i, e, _)| (*i, e.clone())).collect();
        self.report.episodes = sorted.iter().map(|(_, e, m)| (e.clone(), *m)).collect();
        finish(
            self.cfg,
            &mine,
            self.parts,
            &BTreeSet::new(),
            &mut self.report,
        )
        .map_err(|e| Failed::Write(e.to_string()))?;
        let played: Vec<Episode> = self.played.iter().map(|(_, e, _)| e.clone()).collect();
        crate::episode::format::write_episodes(&self.cfg.out.join(PLAYED), &played)
            .map_err(|e| Failed::Write(e.to_string()))?;
        Ok(m)
    }
}
