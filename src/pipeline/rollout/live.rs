//! A run fed one episode at a time by its caller: an interactive session (`minos serve`)
//! plays the episodes a person chooses, with an agent that waits for that person's actions.
//! Each episode is rolled out exactly as [`rollout_with`](super::rollout_with) rolls it out (the
//! same simulator set-up, episode loop and part files). A finished episode costs only its
//! own files: its parts in `DIR/.parts/` (`<index>.traj.parquet`, `<index>.obs.parquet`,
//! the episode itself as `<index>.episode.parquet`, and `<index>.json`, its metrics, last —
//! the mark that it finished), each written under a temporary name and renamed, so nothing
//! grows with the episodes already played. When the run ends (the source has no more), the
//! run's tables, `metrics.json` and `manifest.json` are written once from the finished parts,
//! in episode-id order, then the finished episodes in the order played as an episode file,
//! `DIR/played.parquet` ([`RunDir::played`]): the `--episodes` of `minos run --agent
//! replay:DIR/trajectories.parquet`, which gives the same tables. A run killed mid-session
//! leaves its finished episodes in `DIR/.parts/` and no table; [`finish_live`] (which `minos
//! serve` calls on its output folder at start-up) writes the outputs from them — the same
//! bytes as if the session had ended normally after its last finished episode — and removes
//! the parts.

use std::collections::BTreeSet;
use std::path::Path;
use std::sync::Arc;

use super::episode::run_episode;
use super::parts::read_done;
use super::scene::{self, SceneRun};
use super::{
    finish, io_error, preflight, EpisodeFailure, Failed, RolloutError, RunConfig, RunReport,
};
use crate::atomic::{remove_dir_atomic, sweep_stale};
use crate::episode::format::{read_episodes, write_episodes};
use crate::episode::Episode;
use crate::io::run_dir::{PartFile, RunDir};
use crate::lock::{DirLock, LockMode};
use crate::navmesh::geodesic::Geodesic;
use crate::run::agents::Agent;
use crate::run::metrics::EpisodeMetrics;

/// Where the episodes of a live run come from, and who hears how they ended.
pub trait EpisodeSource {
    /// The next episode to play (it may block while a person chooses); `None` ends the run.
    fn next(&mut self) -> Option<Episode>;
    /// An episode ended: its metrics once its part files are complete (the run's outputs
    /// will include it, even if the process dies now: see [`finish_live`]), or why it did not
    /// finish (its scene cannot run, it was played already, the agent gave up).
    fn finished(&mut self, episode: &Episode, outcome: Result<&EpisodeMetrics, &EpisodeFailure>);
}

/// Plays the episodes `source` hands out with `agent` into `cfg.out` (holding its writer
/// lock, taken as `mode` says), each into its own part files; when `source` has no more,
/// writes the run's outputs from them. `cfg.agent`, `cfg.shard`, `cfg.resume` and
/// `cfg.rerun` are not used: the agent is `agent`, and every episode is played once (an
/// episode id played already is refused). An episode that fails is reported to `source`
/// and left out of the outputs; only a file that cannot be written stops the run. Finished
/// episodes that a killed earlier run left in `cfg.out` are first made into that run's
/// outputs ([`finish_live`]), which this run's then replace (`minos serve` gives every
/// session a folder of its own, so this does not happen there).
pub fn run_live(
    cfg: &RunConfig,
    source: &mut dyn EpisodeSource,
    agent: Box<dyn Agent>,
    mode: LockMode,
) -> Result<RunReport, RolloutError> {
    let _lock = DirLock::acquire(&cfg.out, "serve", mode)?;
    let parts = RunDir::new(&cfg.out).parts();
    for dir in [cfg.out.as_path(), parts.as_path()] {
        sweep_stale(dir).map_err(io_error(dir))?;
    }
    if parts.exists() {
        finish_parts(cfg, &parts)?;
    }
    std::fs::create_dir_all(&parts).map_err(io_error(&parts))?;
    write_command(&parts, &cfg.provenance.command)?;
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
            source.finished(&first, Err(&problem));
            pending = source.next();
            continue;
        }
        let (sim, assets) = match scene::load(cfg, &first.scene_id) {
            Ok(loaded) => loaded,
            Err(e) => {
                source.finished(&first, Err(&e.into()));
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
                Err(Failed::Episode(problem)) => source.finished(&e, Err(&problem)),
            }
            match source.next() {
                Some(n) if n.scene_id == e.scene_id => match live.playable(&n) {
                    Ok(()) => ep = Some(n),
                    Err(problem) => {
                        source.finished(&n, Err(&problem));
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
    live.write_outputs()?;
    if live.report.failures.is_empty() {
        let _ = remove_dir_atomic(&parts);
    }
    Ok(live.report)
}

/// Writes the outputs of a live run that was killed: the finished episodes in
/// `cfg.out/.parts/` (those whose metrics and episode parts exist, in the order played)
/// become the run's tables, `metrics.json`, `manifest.json` and `played.parquet` — the bytes
/// the run would have written had it ended after its last finished episode — and the parts,
/// and whatever a killed writer left under temporary names, are removed. `None` when
/// `cfg.out` holds no parts (nothing to do); `Some` with an empty report when none of its
/// episodes finished (the folder is then left without tables, as such a run leaves it).
/// Takes the folder's writer lock (fails at once while a live process holds it).
pub fn finish_live(cfg: &RunConfig) -> Result<Option<RunReport>, RolloutError> {
    let parts = RunDir::new(&cfg.out).parts();
    if !parts.is_dir() {
        return Ok(None);
    }
    let _lock = DirLock::acquire(&cfg.out, "serve", LockMode::Fail)?;
    for dir in [cfg.out.as_path(), parts.as_path()] {
        sweep_stale(dir).map_err(io_error(dir))?;
    }
    finish_parts(cfg, &parts).map(Some)
}

/// [`finish_live`] with the lock held and the temporaries swept.
fn finish_parts(cfg: &RunConfig, parts: &Path) -> Result<RunReport, RolloutError> {
    let mut indices: Vec<usize> = Vec::new();
    for entry in std::fs::read_dir(parts).map_err(io_error(parts))? {
        let name = entry.map_err(io_error(parts))?.file_name();
        let name = name.to_string_lossy();
        if let Some(stem) = name.strip_suffix(".json") {
            if !stem.is_empty() && stem.bytes().all(|b| b.is_ascii_digit()) {
                if let Ok(i) = stem.parse() {
                    indices.push(i);
                }
            }
        }
    }
    indices.sort_unstable();
    // The manifest names the command that played the episodes, not the one finishing them.
    let mut original = cfg.clone();
    if let Some(command) = read_command(parts) {
        original.provenance.command = command;
    }
    let cfg = &original;
    let mut live = Live {
        cfg,
        parts,
        played: Vec::new(),
        report: RunReport::default(),
    };
    for i in indices {
        let episode_part = PartFile::Episode.of(parts, i);
        let episode = match read_episodes(&episode_part) {
            Ok(mut e) if e.len() == 1 => e.remove(0),
            Ok(e) => {
                tracing::warn!(
                    "{}: {} episodes, not one: left out",
                    episode_part.display(),
                    e.len()
                );
                continue;
            }
            Err(e) => {
                tracing::warn!("{}: episode left out", crate::escape::error_line(&e));
                continue;
            }
        };
        let metrics = match read_done(parts, i) {
            Ok(m) => m,
            Err(e) => {
                tracing::warn!("{}: episode left out", crate::escape::error_line(&e));
                continue;
            }
        };
        live.played.push((i, episode, metrics));
    }
    live.write_outputs()?;
    remove_dir_atomic(parts).map_err(io_error(parts))?;
    Ok(live.report)
}

/// The file in a live run's parts folder that keeps the run's command line, for the manifest
/// a later [`finish_live`] writes (whoever finishes the run, the command is the one that
/// played its episodes).
const COMMAND_PART: &str = "command.json";

/// Keeps `command` in the parts folder `parts` (atomically).
fn write_command(parts: &Path, command: &[String]) -> Result<(), RolloutError> {
    let path = parts.join(COMMAND_PART);
    // A list of strings always serialises.
    let text = serde_json::to_vec(command).unwrap_or_default();
    crate::atomic::write_bytes_atomic(&path, &text).map_err(io_error(&path))
}

/// The command line kept in `parts`; `None` when there is none or it is unreadable (the
/// finishing command is recorded then).
fn read_command(parts: &Path) -> Option<Vec<String>> {
    let path = parts.join(COMMAND_PART);
    let bytes = std::fs::read(&path).ok()?;
    match serde_json::from_slice(&bytes) {
        Ok(c) => Some(c),
        Err(e) => {
            tracing::warn!("{}: {e}: the finishing command is recorded", path.display());
            None
        }
    }
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
    fn playable(&self, ep: &Episode) -> Result<(), EpisodeFailure> {
        if self
            .played
            .iter()
            .any(|(_, e, _)| e.episode_id == ep.episode_id)
        {
            return Err(EpisodeFailure::PlayedAlready(ep.episode_id.clone()));
        }
        preflight::check(self.cfg, &[(0, ep.clone())])
            .map_err(|e| EpisodeFailure::NotReady(Arc::new(e)))
    }

    /// Plays `ep` into its part files: the episode record first, its metrics last.
    fn play(&mut self, run: &mut SceneRun<'_>, ep: &Episode) -> Result<EpisodeMetrics, Failed> {
        let index = self.played.len();
        write_episodes(
            &PartFile::Episode.of(self.parts, index),
            std::slice::from_ref(ep),
        )
        .map_err(|e| Failed::Write(EpisodeFailure::Record(Arc::new(e))))?;
        let m = run_episode(run, ep, self.cfg, self.parts, index, false).map_err(Failed::of)?;
        self.played.push((index, ep.clone(), m));
        Ok(m)
    }

    /// Writes the outputs of `rollout_with` over the finished episodes (in episode-id order),
    /// then the finished episodes in the order played. Nothing when none finished.
    fn write_outputs(&mut self) -> Result<(), RolloutError> {
        if self.played.is_empty() {
            return Ok(());
        }
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
        )?;
        let played: Vec<Episode> = self.played.iter().map(|(_, e, _)| e.clone()).collect();
        write_episodes(&RunDir::new(&self.cfg.out).played(), &played).map_err(RolloutError::Played)
    }
}
