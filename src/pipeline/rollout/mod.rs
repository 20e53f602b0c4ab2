//! Rolling out episodes: one simulator per scene (scenes in parallel), episodes in order,
//! each writing its own part files (`DIR/.parts/<index>.*`), the metrics file last. Run again
//! as it was (`.parts/run.json` records what it is), an interrupted run skips episodes whose
//! metrics exist; the final tables are merged from the parts in episode order, so it ends
//! with the same bytes as an uninterrupted one.
//!
//! With [`RunConfig::rerun`], the first episodes of the shard are also recorded for the
//! rerun viewer while they roll out (`DIR/.parts/<index>.rrd`, finished before the metrics
//! file) and joined into one `.rrd` at the end; recording never changes the tables.

mod agent_kind;
mod batched;
mod episode;
mod failure;
mod live;
internal! {
    pub mod manifest;
}
mod parts;
mod preflight;
mod scene;
mod setup;

use crate::file_error::FileError;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

use rayon::prelude::*;

use crate::atomic::{remove_dir_atomic, sweep_stale, write_bytes_atomic};
use crate::body::{AgentPreset, BodyMismatch};
use crate::episode::Episode;
use crate::io::image_codec::ImageEncoding;
use crate::io::lerobot::video::VideoSettings;
use crate::io::lerobot::DatasetOptions;
use crate::io::rrd::RecordingError;
use crate::io::run_dir::{PartFile, RunDir, RunManifest, RunManifestError};
use crate::io::tables::{merge, observation_schema, trajectory_schema};
use crate::lock::{DirLock, LockError, LockMode};
use crate::navmesh::geodesic::Geodesic;
use crate::pipeline::vector_env::VectorEnvError;
use crate::progress::Progress;
use crate::render::Renderer;
use crate::run::metrics::{aggregate, Aggregate, EpisodeMetrics, MetricRow, Reward};
use crate::shard::Shard;
use crate::sim::SimError;
use crate::sim::{AgentConfig, SensorSuite};
use crate::store::DataDir;

use crate::render::RendererChoice;
pub use agent_kind::{AgentKind, AgentNameError, AGENT_NAMES};
pub use episode::EpisodeError;
pub use failure::EpisodeFailure;
pub use live::{finish_live, run_live, EpisodeSource};
pub use parts::{PartDone, PartError};
use scene::SceneRun;
pub use scene::{load as load_simulator, load_assets as load_scene_assets, SceneLoadError};
pub use setup::{episodes_on_variant, run_episodes_of, RunEpisodesError};

/// What a run does.
#[derive(Debug, Clone)]
pub struct RunConfig {
    /// DATA folder (ingested, baked).
    pub data: DataDir,
    /// Output folder.
    pub out: PathBuf,
    /// The agent.
    pub agent: AgentKind,
    /// Body and motion.
    pub agent_config: AgentConfig,
    /// Sensors.
    pub sensors: SensorSuite,
    /// Renderer.
    pub renderer: RendererChoice,
    /// Step limit overriding the episodes' own.
    pub max_steps: Option<u32>,
    /// Seed (random agents, sensor noise).
    pub seed: u64,
    /// Shard of the episode list.
    pub shard: Shard,
    /// Also keep finished episodes of an interrupted run that left no record of what it was
    /// (parts written before minos recorded `.parts/run.json`). A run with a record is
    /// continued whenever it is run again as it was, whatever this says.
    pub resume: bool,
    /// Reward function.
    pub reward: Reward,
    /// Image storage.
    pub encoding: ImageEncoding,
    /// Also write the run as a LeRobot v3.0 dataset in `out/lerobot/`.
    pub lerobot: bool,
    /// In that dataset, colour cameras as H.264 video features encoded so (`--video`,
    /// `--video-qp`); `None`: as lossless image files.
    pub lerobot_video: Option<VideoSettings>,
    /// Also record episodes for the rerun viewer.
    pub rerun: Option<RerunOutput>,
    /// Run on grids baked for another body than `body` (recorded in the manifest).
    pub allow_body_mismatch: bool,
    /// Where the run came from, for `manifest.json`.
    pub provenance: Provenance,
    /// Environments stepped in lockstep per scene, every step's observations rendered in one
    /// call (`Some(1)`: one simulator per thread, each stepping alone). `None`: lockstep
    /// batches of [`GPU_BATCH`] on a GPU renderer, one simulator per thread otherwise. The
    /// outputs are the same bytes either way.
    pub batch: Option<usize>,
}

/// What a run writes besides its Parquet tables (`--format`, `format=`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RunFormat {
    /// minos's Parquet tables only.
    #[default]
    Parquet,
    /// The Parquet tables and a LeRobot v3.0 dataset in `OUT/lerobot`.
    Lerobot,
}

impl RunFormat {
    /// Whether the run also writes a LeRobot dataset ([`RunConfig::lerobot`]).
    pub fn writes_lerobot(self) -> bool {
        self == RunFormat::Lerobot
    }
}

impl crate::vocab::Vocabulary for RunFormat {
    const WHAT: &'static str = "format";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: RunFormat::Parquet,
            name: "parquet",
            aliases: &[],
            help: "minos's Parquet tables",
        },
        crate::vocab::Term {
            value: RunFormat::Lerobot,
            name: "lerobot",
            aliases: &[],
            help: "the Parquet tables and a LeRobot v3.0 dataset in DIR/lerobot",
        },
    ];
}

crate::vocab::name_traits!(RunFormat);

/// Environments per scene stepped together on a GPU renderer when the run does not say.
pub const GPU_BATCH: usize = 256;

/// Where a run came from, recorded in its `manifest.json` beside the configuration.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Provenance {
    /// The command line (empty for library callers).
    pub command: Vec<String>,
    /// The episode file read.
    pub episodes_file: Option<PathBuf>,
    /// The variant every episode was moved to.
    pub variant: Option<String>,
    /// The agent as the user named it (`oracle`, `replay:FILE`, …).
    pub agent: String,
    /// The agent preset the body came from, if any.
    pub preset: Option<AgentPreset>,
}

/// Why a run stopped as a whole (an episode's failure is only reported, see
/// [`RunReport::failures`]).
#[derive(Debug, thiserror::Error)]
pub enum RolloutError {
    /// Another process writes the output folder, or its lock cannot be taken.
    #[error("the run folder's lock")]
    Lock(#[from] LockError),
    /// A file or folder of the output could not be written.
    #[error(transparent)]
    Io(#[from] FileError),
    /// A merged table could not be written (the message names the file).
    #[error(transparent)]
    Table(crate::io::tables::TableError),
    /// An episode's part file could not be written (the message names it); the run stopped
    /// before merging, so no final table was written.
    #[error(transparent)]
    Write(EpisodeFailure),
    /// The checksums of the run folder's files could not be computed.
    #[error("checksums of the run's files")]
    Checksums(#[source] crate::file_error::FileError),
    /// A live run's file of played episodes could not be written.
    #[error("the played episodes")]
    Played(#[source] crate::episode::format::EpisodeFileError),
    /// The joined recording could not be written.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// Video features were asked for without the LeRobot copy they belong to.
    #[error("colour cameras as video are a feature of the LeRobot copy: ask for it too")]
    VideoWithoutLerobot,
    /// The LeRobot copy could not be written.
    #[error("lerobot")]
    Lerobot(#[from] crate::io::lerobot::LerobotError),
    /// The run's manifest lacks what its LeRobot copy needs.
    #[error(transparent)]
    Manifest(#[from] RunManifestError),
    /// The output folder holds finished episodes of an interrupted run that is not this one
    /// (another configuration or other episodes), or that left no record of what it was and
    /// the run was not asked to resume: starting over would silently discard them.
    #[error(
        "{} holds {finished} finished episodes of an interrupted run{}: {}, or delete {} to \
         start over",
        out.display(),
        differs.as_ref().map(|k| format!(" with another `{k}`")).unwrap_or_default(),
        if differs.is_some() { "run it as it was to finish it" } else { "resume the run to keep them" },
        parts.display()
    )]
    Interrupted {
        /// The output folder.
        out: PathBuf,
        /// Its part files.
        parts: PathBuf,
        /// Episodes finished there.
        finished: usize,
        /// The first field of the run's record that differs (None: the parts have no record).
        differs: Option<String>,
    },
    /// Scenes of the episodes cannot run (not ingested, not baked, baked for another body);
    /// found before anything is written.
    #[error(
        "{scenes} of the {total} scenes of the episodes cannot run, so nothing was written: \
         {problems}"
    )]
    NotReady {
        /// Scenes that cannot run.
        scenes: usize,
        /// Scenes the episodes name.
        total: usize,
        /// Each problem with the scenes that have it.
        problems: String,
        /// The first grid baked for another body, when that is one of the problems (the
        /// front doors say how to rebake).
        body: Option<BodyMismatch>,
    },
}

/// The grid-body mismatch behind `e` (itself or one of its causes: a simulator's or a
/// scene's set-up, or the scenes a run found not ready), so that a front door can say how to
/// rebake in its own words.
pub fn body_mismatch_of(e: &(dyn std::error::Error + 'static)) -> Option<BodyMismatch> {
    let of_sim = |s: &SimError| match s {
        SimError::Body(b) => Some(*b),
        _ => None,
    };
    let of_load = |l: &SceneLoadError| match l {
        SceneLoadError::Assets(s) => of_sim(s),
        _ => None,
    };
    std::iter::successors(Some(e), |e| e.source()).find_map(|c| {
        c.downcast_ref::<BodyMismatch>()
            .copied()
            .or_else(|| c.downcast_ref::<SimError>().and_then(of_sim))
            .or_else(|| c.downcast_ref::<SceneLoadError>().and_then(of_load))
            .or_else(|| match c.downcast_ref::<RolloutError>() {
                Some(RolloutError::NotReady { body, .. }) => *body,
                _ => None,
            })
            .or_else(|| match c.downcast_ref::<VectorEnvError>() {
                Some(VectorEnvError::NotReady { first, .. }) => of_load(first),
                _ => None,
            })
    })
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> RolloutError + '_ {
    move |source| RolloutError::Io(FileError::new(path, source))
}

/// Which episodes a run records for the rerun viewer, and where.
#[derive(Debug, Clone, PartialEq)]
pub struct RerunOutput {
    /// The `.rrd` file (one recording per episode, in episode-id order).
    pub path: PathBuf,
    /// How many episodes to record: the first of this shard in episode-id order.
    pub episodes: usize,
}

/// What a run produced.
#[derive(Debug, Default)]
pub struct RunReport {
    /// Episodes run (or kept from an earlier run) with their metrics, in episode order.
    pub episodes: Vec<(Episode, EpisodeMetrics)>,
    /// Aggregates by group.
    pub groups: BTreeMap<String, Aggregate>,
    /// Episodes kept from an interrupted run.
    pub resumed: usize,
    /// Episodes that failed (their ids), with the reason.
    pub failures: Vec<(String, EpisodeFailure)>,
    /// Episodes in the rerun recording.
    pub recorded: usize,
}

/// The episodes of this shard, in episode-id order, with their global index.
pub fn select(episodes: &[Episode], shard: Shard) -> Vec<(usize, Episode)> {
    let mut sorted: Vec<&Episode> = episodes.iter().collect();
    sorted.sort_by(|a, b| a.episode_id.cmp(&b.episode_id));
    sorted
        .into_iter()
        .enumerate()
        .filter(|(i, _)| shard.keeps(*i))
        .map(|(i, e)| (i, e.clone()))
        .collect()
}

/// An episode's index and its metrics (and whether they were kept from an earlier run).
type Outcome = (usize, Result<(EpisodeMetrics, bool), Failed>);

/// Why an episode has no metrics.
#[derive(Debug, Clone)]
enum Failed {
    /// The episode's own problem (its scene, its agent): the run goes on without it.
    Episode(EpisodeFailure),
    /// One of its part files could not be written (the error names it): the output
    /// folder's problem, which stops the run before anything is merged.
    Write(EpisodeFailure),
}

impl Failed {
    fn of(e: episode::EpisodeError) -> Failed {
        use episode::EpisodeError as E;
        let write = matches!(
            e,
            E::Table(_) | E::Part(_) | E::Recording(_) | E::OutOfOrder(_)
        );
        if write {
            Failed::Write(e.into())
        } else {
            Failed::Episode(e.into())
        }
    }
}

/// Runs the episodes, writes the tables, `metrics.json` and `manifest.json` into `cfg.out`.
/// The scenes of this shard's episodes are checked first ([`RolloutError::NotReady`], with
/// nothing written).
/// Fails at once when another process writes `cfg.out` ([`rollout_with`] can wait instead).
pub fn rollout(
    cfg: &RunConfig,
    episodes: &[Episode],
    progress: &dyn Progress,
) -> Result<RunReport, RolloutError> {
    rollout_with(cfg, episodes, LockMode::Fail, progress)
}

/// [`rollout`], holding the output folder's writer lock (`OUT/.minos.lock`, taken as `mode` says)
/// from the end of the preflight on, and removing first what a killed run left in `OUT/`, in
/// `OUT/.parts/` and beside the recording.
pub fn rollout_with(
    cfg: &RunConfig,
    episodes: &[Episode],
    mode: LockMode,
    progress: &dyn Progress,
) -> Result<RunReport, RolloutError> {
    if cfg.lerobot_video.is_some() && !cfg.lerobot {
        return Err(RolloutError::VideoWithoutLerobot);
    }
    let mine = select(episodes, cfg.shard);
    preflight::check(cfg, &mine)?;
    let _lock = DirLock::acquire(&cfg.out, "run", mode)?;
    let run_dir = RunDir::new(&cfg.out);
    let parts = run_dir.parts();
    let recording_dir = cfg.rerun.as_ref().and_then(|r| r.path.parent());
    for dir in [
        Some(cfg.out.as_path()),
        Some(parts.as_path()),
        recording_dir,
    ]
    .into_iter()
    .flatten()
    {
        sweep_stale(dir).map_err(io_error(dir))?;
    }
    let record = manifest::unfinished_record(cfg, &mine);
    keep_or_clear_parts(cfg, &parts, &record)?;
    std::fs::create_dir_all(&parts).map_err(io_error(&parts))?;
    let record_path = run_dir.unfinished_record();
    // A JSON value always serialises.
    let record_bytes = serde_json::to_vec_pretty(&record).unwrap_or_default();
    write_bytes_atomic(&record_path, &record_bytes).map_err(io_error(&record_path))?;
    progress.set_total(mine.len() as u64);
    // The episodes recorded for rerun: the first of the shard, in episode-id order.
    let recorded: BTreeSet<usize> = mine
        .iter()
        .take(cfg.rerun.as_ref().map_or(0, |r| r.episodes))
        .map(|(i, _)| *i)
        .collect();
    let mut by_scene: BTreeMap<String, Vec<(usize, Episode)>> = BTreeMap::new();
    for (i, e) in &mine {
        by_scene
            .entry(e.scene_id.clone())
            .or_default()
            .push((*i, e.clone()));
    }
    let scenes: Vec<(String, Vec<(usize, Episode)>)> = by_scene.into_iter().collect();
    // Set by the first part that cannot be written: no episode starts after it.
    let stop = AtomicBool::new(false);
    let results: Vec<Vec<Outcome>> = scenes
        .par_iter()
        .map(|(scene_id, eps)| run_scene(cfg, scene_id, eps, &parts, &recorded, &stop, progress))
        .collect();
    let mut by_index: BTreeMap<usize, Result<(EpisodeMetrics, bool), Failed>> =
        results.into_iter().flatten().collect();
    // A part that could not be written stops the run: the first, in episode order.
    if let Some(e) = by_index.values().find_map(|r| match r {
        Err(Failed::Write(e)) => Some(e.clone()),
        _ => None,
    }) {
        return Err(RolloutError::Write(e));
    }
    let mut report = RunReport::default();
    for (i, ep) in &mine {
        match by_index.remove(i) {
            Some(Ok((m, resumed))) => {
                report.resumed += usize::from(resumed);
                report.episodes.push((ep.clone(), m));
            }
            Some(Err(Failed::Episode(e) | Failed::Write(e))) => {
                report.failures.push((ep.episode_id.clone(), e))
            }
            None => report
                .failures
                .push((ep.episode_id.clone(), EpisodeFailure::NotRun)),
        }
    }
    finish(cfg, &mine, &parts, &recorded, &mut report)?;
    if report.failures.is_empty() {
        let _ = remove_dir_atomic(&parts);
    }
    Ok(report)
}

/// What an earlier, unfinished run left in `parts` is kept when it is this run (its record
/// equal to `record`; or, without a record, when `cfg.resume` says so) and removed when none
/// of its episodes finished; finished episodes of another run are never silently removed.
fn keep_or_clear_parts(
    cfg: &RunConfig,
    parts: &Path,
    record: &serde_json::Value,
) -> Result<(), RolloutError> {
    if !parts.exists() {
        return Ok(());
    }
    let finished = parts::finished_count(parts).map_err(io_error(parts))?;
    if finished == 0 {
        return remove_dir_atomic(parts).map_err(io_error(parts));
    }
    let run_dir = RunDir::new(&cfg.out);
    let earlier = std::fs::read(run_dir.unfinished_record())
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok());
    let interrupted = |differs: Option<String>| RolloutError::Interrupted {
        out: cfg.out.clone(),
        parts: parts.to_path_buf(),
        finished,
        differs,
    };
    // A run that finished (its manifest written last) with failed episodes keeps its parts,
    // to retry those; another run over it replaces it, as over any finished run.
    let finished_run = run_dir.manifest().is_file();
    match earlier {
        Some(earlier) => match manifest::first_difference(&earlier, record) {
            None => Ok(()),
            Some(_) if finished_run => remove_dir_atomic(parts).map_err(io_error(parts)),
            Some(key) => Err(interrupted(Some(key))),
        },
        None if cfg.resume => Ok(()),
        None => Err(interrupted(None)),
    }
}

/// Runs the episodes of one scene (keeping those an earlier run finished), claimed in
/// episode order by one worker per thread.
fn run_scene(
    cfg: &RunConfig,
    scene_id: &str,
    eps: &[(usize, Episode)],
    parts: &Path,
    recorded: &BTreeSet<usize>,
    stop: &AtomicBool,
    progress: &dyn Progress,
) -> Vec<Outcome> {
    // Finished earlier (parts are kept only when they are this run's): metrics written and,
    // when recorded, the recording too.
    let done = |i: usize| {
        PartFile::Metrics.of(parts, i).is_file()
            && (!recorded.contains(&i) || PartFile::Recording.of(parts, i).is_file())
    };
    let mut out: Vec<Outcome> = Vec::new();
    for (i, _) in eps.iter().filter(|(i, _)| done(*i)) {
        let kept = parts::read_done(parts, *i)
            .map_err(|e| Failed::Episode(EpisodeFailure::Kept(Arc::new(e))));
        out.push((*i, kept.map(|m| (m, true))));
        progress.advance(1);
    }
    let pending: Vec<&(usize, Episode)> = eps.iter().filter(|(i, _)| !done(*i)).collect();
    if pending.is_empty() {
        return out;
    }
    let setup = scene::load(cfg, scene_id)
        .map_err(EpisodeFailure::from)
        .and_then(|(sim, assets)| {
            let agent = scene::make_agent(&cfg.agent, cfg.seed)?;
            Ok((sim, assets, agent))
        });
    match setup {
        Err(e) => {
            for (i, _) in pending {
                out.push((*i, Err(Failed::Episode(e.clone()))));
                progress.advance(1);
            }
        }
        Ok((sim, assets, agent)) => {
            let shared = Workers {
                cfg,
                parts,
                recorded,
                stop,
                progress,
            };
            let batch = cfg.batch.unwrap_or(match **sim.renderer() {
                Renderer::Gpu(_) => GPU_BATCH,
                Renderer::Cpu => 1,
            });
            if batch > 1 && !matches!(cfg.agent, AgentKind::External(_)) {
                let next = AtomicUsize::new(0);
                let queue = Queue {
                    episodes: &pending,
                    next: &next,
                };
                let envs = batch.min(pending.len());
                out.extend(batched::run_batched(
                    sim, agent, &assets, envs, queue, shared,
                ));
                return out;
            }
            // One worker per thread (a scan-sized scene is often the only one), each with its
            // own simulator and agent on the shared assets, taking the next unclaimed episode
            // until none is left, so episodes of uneven lengths keep every thread busy to the
            // end. Every episode is seeded from its own id and the simulator and agent are
            // reset for each, so which worker runs it changes no output. External agents stay
            // one process per scene.
            let threads = if matches!(cfg.agent, AgentKind::External(_)) {
                1
            } else {
                rayon::current_num_threads()
            };
            let mut workers = vec![(sim, agent)];
            for _ in 1..threads.clamp(1, pending.len()) {
                match scene::make_agent(&cfg.agent, cfg.seed) {
                    Ok(agent) => workers.push((workers[0].0.sibling(), agent)),
                    // The workers made so far run every episode.
                    Err(e) => tracing::warn!(
                        "{scene_id}: one worker fewer: {}",
                        crate::escape::error_line(&e)
                    ),
                }
            }
            let next = AtomicUsize::new(0);
            let done: Vec<Vec<Outcome>> = workers
                .into_par_iter()
                .map(|(sim, agent)| {
                    let mut run = SceneRun::new(sim, agent, cfg, Geodesic::new(&assets.grid));
                    let queue = Queue {
                        episodes: &pending,
                        next: &next,
                    };
                    run_queue(&mut run, queue, shared)
                })
                .collect();
            out.extend(done.into_iter().flatten());
        }
    }
    out
}

/// A scene's pending episodes, shared by its workers: each claims the next one.
#[derive(Clone, Copy)]
struct Queue<'a> {
    episodes: &'a [&'a (usize, Episode)],
    /// Index of the next unclaimed episode.
    next: &'a AtomicUsize,
}

impl<'a> Queue<'a> {
    /// Claims the next episode, if any is left.
    fn claim(&self) -> Option<&'a (usize, Episode)> {
        let k = self.next.fetch_add(1, Ordering::Relaxed);
        self.episodes.get(k).copied()
    }
}

/// What every worker of a scene shares: the run, where parts go, which episodes are
/// recorded, the stop flag set by the first part that cannot be written, the progress.
#[derive(Clone, Copy)]
struct Workers<'a> {
    cfg: &'a RunConfig,
    parts: &'a Path,
    recorded: &'a BTreeSet<usize>,
    stop: &'a AtomicBool,
    progress: &'a dyn Progress,
}

impl<'a> Workers<'a> {
    /// The next episode of `queue` to run; once a write has failed, the claimed episodes
    /// are reported as not run instead (into `out`).
    fn next(&self, queue: Queue<'a>, out: &mut Vec<Outcome>) -> Option<&'a (usize, Episode)> {
        loop {
            let claimed = queue.claim()?;
            if !self.stop.load(Ordering::Relaxed) {
                return Some(claimed);
            }
            out.push((
                claimed.0,
                Err(Failed::Episode(EpisodeFailure::StoppedByWrite)),
            ));
            self.progress.advance(1);
        }
    }

    /// Records an episode's outcome; a part that could not be written stops the run: no
    /// episode starts after it.
    fn done(&self, outcome: Outcome, out: &mut Vec<Outcome>) {
        if matches!(outcome.1, Err(Failed::Write(_))) {
            self.stop.store(true, Ordering::Relaxed);
        }
        out.push(outcome);
        self.progress.advance(1);
    }
}

/// Runs episodes claimed from `queue` on one simulator and agent until none is left.
fn run_queue(run: &mut SceneRun<'_>, queue: Queue<'_>, w: Workers<'_>) -> Vec<Outcome> {
    let mut out = Vec::new();
    while let Some((i, ep)) = w.next(queue, &mut out) {
        let record = w.recorded.contains(i);
        let r = episode::run_episode(run, ep, w.cfg, w.parts, *i, record).map_err(Failed::of);
        w.done((*i, r.map(|m| (m, false))), &mut out);
    }
    out
}

/// Merges the finished episodes' parts into the final tables and writes `metrics.json`,
/// `manifest.json`, the joined recording and the LeRobot copy (made from the merged tables).
fn finish(
    cfg: &RunConfig,
    mine: &[(usize, Episode)],
    parts: &Path,
    recorded: &BTreeSet<usize>,
    report: &mut RunReport,
) -> Result<(), RolloutError> {
    let finished: BTreeSet<&str> = report
        .episodes
        .iter()
        .map(|(e, _)| e.episode_id.as_str())
        .collect();
    let kept: Vec<&(usize, Episode)> = mine
        .iter()
        .filter(|(_, e)| finished.contains(e.episode_id.as_str()))
        .collect();
    let traj_parts: Vec<PathBuf> = kept
        .iter()
        .map(|(i, _)| PartFile::Trajectory.of(parts, *i))
        .collect();
    let obs_parts: Vec<PathBuf> = kept
        .iter()
        .map(|(i, _)| PartFile::Observations.of(parts, *i))
        .collect();
    let run_dir = RunDir::new(&cfg.out);
    merge(&traj_parts, trajectory_schema(), &run_dir.trajectories())
        .map_err(RolloutError::Table)?;
    merge(
        &obs_parts,
        observation_schema(&cfg.sensors.cameras, cfg.encoding),
        &run_dir.observations(),
    )
    .map_err(RolloutError::Table)?;
    // Every episode of the shard, in episode order: failed ones count as failures.
    let ran: BTreeMap<&str, EpisodeMetrics> = report
        .episodes
        .iter()
        .map(|(e, m)| (e.episode_id.as_str(), *m))
        .collect();
    let rows: Vec<MetricRow> = mine
        .iter()
        .map(|(_, e)| {
            (
                e.task.name().to_string(),
                e.split.clone(),
                e.difficulty.name().to_string(),
                ran.get(e.episode_id.as_str()).copied(),
            )
        })
        .collect();
    report.groups = aggregate(&rows);
    let by_id: BTreeMap<&str, &Episode> = mine
        .iter()
        .map(|(_, e)| (e.episode_id.as_str(), e))
        .collect();
    let failures: Vec<FailedEpisode> = report
        .failures
        .iter()
        .map(|(id, error)| {
            FailedEpisode::new(
                id,
                &crate::escape::error_line(error),
                by_id.get(id.as_str()).copied(),
            )
        })
        .collect();
    crate::io::tables::write_episode_table(&run_dir.episodes(), &report.episodes)
        .map_err(RolloutError::Table)?;
    let metrics: Vec<(&str, EpisodeMetrics)> = report
        .episodes
        .iter()
        .map(|(e, m)| (e.episode_id.as_str(), *m))
        .collect();
    write_metrics(&cfg.out, &report.groups, &metrics, &failures)?;
    if let Some(rerun) = &cfg.rerun {
        let recordings: Vec<PathBuf> = kept
            .iter()
            .filter(|(i, _)| recorded.contains(i))
            .map(|(i, _)| PartFile::Recording.of(parts, *i))
            .collect();
        crate::io::rrd::concat(&recordings, &rerun.path)?;
        report.recorded = recordings.len();
    }
    let manifest = RunManifest::new(
        run_dir.manifest(),
        manifest::value(cfg, mine.iter().map(|(_, e)| e.scene_id.as_str())),
    );
    if cfg.lerobot {
        write_lerobot(&run_dir, &manifest, cfg.lerobot_video)?;
    }
    manifest::write(cfg, manifest)
}

/// An episode that failed with an error, as `metrics.json` lists it: with its task, split
/// and difficulty, so that `minos merge` counts it in the same groups.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FailedEpisode {
    /// The episode.
    pub episode_id: String,
    /// Why it failed.
    pub error: String,
    /// Its task (empty when unknown).
    pub task: String,
    /// Its split (empty when unknown).
    pub split: String,
    /// Its difficulty (empty when unknown).
    pub difficulty: String,
}

impl FailedEpisode {
    /// Episode `id` failed with `error`; its groups come from `episode` when known.
    pub fn new(id: &str, error: &str, episode: Option<&Episode>) -> Self {
        FailedEpisode {
            episode_id: id.to_string(),
            error: error.to_string(),
            task: episode.map_or(String::new(), |e| e.task.name().to_string()),
            split: episode.map_or(String::new(), |e| e.split.clone()),
            difficulty: episode.map_or(String::new(), |e| e.difficulty.name().to_string()),
        }
    }

    /// Its row for [`aggregate`]: no metrics.
    pub fn metric_row(&self) -> MetricRow {
        (
            self.task.clone(),
            self.split.clone(),
            self.difficulty.clone(),
            None,
        )
    }
}

/// Writes `out/metrics.json`: the groups' aggregates (failed episodes counted as failures),
/// each finished episode's metrics and each failure, in episode order (what [`rollout`] and
/// `minos merge` write).
pub fn write_metrics(
    out: &Path,
    groups: &BTreeMap<String, Aggregate>,
    episodes: &[(&str, EpisodeMetrics)],
    failures: &[FailedEpisode],
) -> Result<(), RolloutError> {
    let metrics = serde_json::json!({
        "groups": groups,
        "episodes": episodes.iter().map(|(id, m)| serde_json::json!({"episode_id": id, "metrics": m})).collect::<Vec<_>>(),
        "failures": failures,
    });
    let path = RunDir::new(out).metrics();
    // A JSON value always serialises.
    let bytes = serde_json::to_vec_pretty(&metrics).unwrap_or_default();
    write_bytes_atomic(&path, &bytes).map_err(io_error(&path))
}

/// Writes the LeRobot copy of the tables of the run folder `run` into `RUN/lerobot`, as
/// the run's `manifest` says (its frame rate from the agent's step, its configuration
/// recorded in the copy's provenance: [`DatasetOptions::of_manifest`]); with `video`, colour
/// cameras as video features encoded so.
pub fn write_lerobot(
    run: &RunDir,
    manifest: &RunManifest,
    video: Option<VideoSettings>,
) -> Result<(), RolloutError> {
    let options = DatasetOptions::of_manifest(manifest, None, video)?;
    crate::io::lerobot::write_dataset(
        &crate::io::lerobot::source::RunTables::in_dir(run.root()),
        &run.lerobot(),
        &options,
        &crate::progress::NoProgress,
    )?;
    Ok(())
}
