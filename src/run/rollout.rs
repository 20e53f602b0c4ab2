//! Rolling out episodes: one simulator per scene (scenes in parallel), episodes in order,
//! each writing its own part files (`DIR/.parts/<index>.*`), the metrics file last; `--resume`
//! skips episodes whose metrics exist, and the final tables are merged from the parts in
//! episode order, so an interrupted and resumed run ends with the same bytes as an
//! uninterrupted one.
//!
//! With [`RunConfig::rerun`], the first episodes of the shard are also recorded for the
//! rerun viewer while they roll out (`DIR/.parts/<index>.rrd`, finished before the metrics
//! file) and joined into one `.rrd` at the end; recording never changes the tables.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::episode::batch::Shard;
use crate::episode::Episode;
use crate::io::atomic::write_bytes_atomic;
use crate::io::rrd::episode::EpisodeRecorder;
use crate::io::variant_store::{grid_ref, load_scene};
use crate::navmesh::file::{nav_path, read_nav};
use crate::navmesh::geodesic::Geodesic;
use crate::progress::Progress;
use crate::sim::simulator::Renderer;
use crate::sim::{AgentConfig, RendererChoice, SceneAssets, SensorSuite, Simulator};

use super::agents::{Agent, Decision, ForwardAgent, RandomAgent, ReplayAgent};
use super::metrics::{aggregate, Aggregate, EpisodeMetrics, Reward};
use super::oracle::{reached, OracleAgent};
use super::tables::{
    merge, observation_schema, trajectory_schema, write_trajectory, ImageEncoding,
    ObservationWriter, StepRow,
};

/// Which agent drives.
#[derive(Debug, Clone, PartialEq)]
pub enum AgentKind {
    /// Uniform over the action set.
    Random,
    /// Forward, turning on collision.
    Forward,
    /// Plans over reachable states and stops at the goal.
    Oracle,
    /// Decisions from a trajectory table, per episode.
    Replay(std::collections::HashMap<String, Vec<Decision>>),
    /// A process speaking JSON lines (one per scene thread).
    External(String),
}

/// What a run does.
#[derive(Debug, Clone)]
pub struct RunConfig {
    /// DATA folder (ingested, baked).
    pub data: PathBuf,
    /// Output folder.
    pub out: PathBuf,
    /// The agent.
    pub agent: AgentKind,
    /// Body and motion.
    pub body: AgentConfig,
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
    /// Keep finished episodes of an interrupted run.
    pub resume: bool,
    /// Reward function.
    pub reward: Reward,
    /// Image storage.
    pub encoding: ImageEncoding,
    /// Also lay the dataset out LeRobot-style in `out/lerobot/`.
    pub lerobot: bool,
    /// Also record episodes for the rerun viewer.
    pub rerun: Option<RerunOutput>,
}

/// Which episodes a run records for the rerun viewer, and where.
#[derive(Debug, Clone, PartialEq)]
pub struct RerunOutput {
    /// The `.rrd` file (one recording per episode, in episode-id order).
    pub path: PathBuf,
    /// How many episodes to record: the first of this shard in episode-id order.
    pub episodes: usize,
}

/// Metrics of a finished episode as stored in its part file.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct PartDone {
    episode_id: String,
    success: bool,
    speed: f32,
    spl: f32,
    soft_spl: f32,
    path_length: f32,
    steps: u32,
    collisions: u32,
    final_geodesic: Option<f32>,
}

impl From<&PartDone> for EpisodeMetrics {
    fn from(p: &PartDone) -> Self {
        EpisodeMetrics {
            success: p.success,
            speed: p.speed,
            spl: p.spl,
            soft_spl: p.soft_spl,
            path_length: p.path_length,
            steps: p.steps,
            collisions: p.collisions,
            final_geodesic: p.final_geodesic.unwrap_or(f32::NAN),
        }
    }
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
    /// Episodes that failed, with the reason.
    pub failures: Vec<(String, String)>,
    /// Episodes in the rerun recording.
    pub recorded: usize,
}

fn part(dir: &Path, index: usize, ext: &str) -> PathBuf {
    dir.join(format!("{index:06}.{ext}"))
}

fn make_agent(kind: &AgentKind, seed: u64) -> Result<Box<dyn Agent>, String> {
    Ok(match kind {
        AgentKind::Random => Box::new(RandomAgent::new(seed)),
        AgentKind::Forward => Box::new(ForwardAgent::new(seed)),
        AgentKind::Oracle => Box::new(OracleAgent::new()),
        AgentKind::Replay(m) => Box::new(ReplayAgent::new(m.clone())),
        AgentKind::External(cmd) => Box::new(super::external::ExternalAgent::spawn(cmd)?),
    })
}

/// Runs one episode into its part files (and, when `record`, its recording) and returns its
/// metrics.
#[allow(clippy::too_many_arguments)]
fn run_episode(
    sim: &mut Simulator,
    geo: &Geodesic<'_>,
    agent: &mut dyn Agent,
    ep: &Episode,
    cfg: &RunConfig,
    parts: &Path,
    index: usize,
    record: bool,
) -> Result<EpisodeMetrics, String> {
    sim.reset_episode_in(ep, Some(geo));
    agent.reset(ep, sim)?;
    let mut recorder = if record {
        let path = part(parts, index, "rrd");
        Some(
            EpisodeRecorder::create(&path, ep, sim.assets(), &cfg.sensors.cameras, &cfg.body)
                .map_err(|e| e.to_string())?,
        )
    } else {
        None
    };
    let max_steps = cfg.max_steps.unwrap_or(ep.max_steps).max(1);
    let mut obs = sim.observe().map_err(|e| e.to_string())?;
    let mut writer = ObservationWriter::create(
        &part(parts, index, "obs.parquet"),
        &ep.episode_id,
        &cfg.sensors.cameras,
        cfg.encoding,
    )?;
    let mut rows: Vec<StepRow> = Vec::new();
    let (mut path_length, mut collisions, mut success) = (0.0f32, 0u32, false);
    let mut stopped = false;
    for t in 0..max_steps {
        writer.push(t, &obs.images)?;
        let m = &obs.measurements;
        let before = (m.goal_euclidean.unwrap_or(f32::NAN), m.goal_geodesic);
        let state = sim.state();
        let pose = [
            state.position[0],
            state.position[1],
            state.position[2],
            state.yaw,
            state.tilt,
        ];
        if let Some(r) = recorder.as_mut() {
            r.observe(t, &state, &sim.cameras(), &obs)
                .map_err(|e| e.to_string())?;
        }
        let decision = agent.decide(&obs, sim)?;
        let mut row = StepRow {
            step: t,
            pose,
            action: decision.name(),
            strengths: decision.strengths(),
            reward: 0.0,
            collision: false,
            contacts: m.contacts.clone(),
            euclidean: m.goal_euclidean,
            geodesic: m.goal_geodesic,
            done: false,
            success: false,
        };
        match decision {
            Decision::Stop => {
                success = reached(sim, ep, &state);
                row.done = true;
                row.success = success;
                row.reward = cfg.reward.of_step(before, before, max_steps, success);
                stopped = true;
                record_act(&mut recorder, &row)?;
                rows.push(row);
                break;
            }
            Decision::Act(actions) => {
                obs = sim.step(actions).map_err(|e| e.to_string())?;
                let after_state = sim.state();
                path_length += Vec3::from_array(state.position)
                    .distance(Vec3::from_array(after_state.position));
                collisions += u32::from(obs.measurements.collision);
                let arrived = !agent.stops() && reached(sim, ep, &after_state);
                let after = (
                    obs.measurements.goal_euclidean.unwrap_or(f32::NAN),
                    obs.measurements.goal_geodesic,
                );
                row.collision = obs.measurements.collision;
                row.contacts = obs.measurements.contacts.clone();
                row.done = arrived || t + 1 == max_steps;
                row.success = arrived;
                row.reward = cfg.reward.of_step(before, after, max_steps, arrived);
                success = arrived;
                record_act(&mut recorder, &row)?;
                rows.push(row);
                if arrived {
                    break;
                }
            }
        }
    }
    writer.finish()?;
    write_trajectory(&part(parts, index, "traj.parquet"), &ep.episode_id, &rows)?;
    if let Some(mut r) = recorder {
        // Where the last action left the agent (a stop leaves it where it was).
        if !stopped {
            r.observe(rows.len() as u32, &sim.state(), &sim.cameras(), &obs)
                .map_err(|e| e.to_string())?;
        }
        r.finish().map_err(|e| e.to_string())?;
    }
    let final_geodesic = obs.measurements.goal_geodesic.unwrap_or(f32::NAN);
    let m = EpisodeMetrics::finish(
        success,
        rows.len() as u32,
        max_steps,
        path_length,
        collisions,
        ep.geodesic_distance,
        final_geodesic,
    );
    let done = PartDone {
        episode_id: ep.episode_id.clone(),
        success: m.success,
        speed: m.speed,
        spl: m.spl,
        soft_spl: m.soft_spl,
        path_length: m.path_length,
        steps: m.steps,
        collisions: m.collisions,
        final_geodesic: final_geodesic.is_finite().then_some(final_geodesic),
    };
    let json = serde_json::to_vec(&done).map_err(|e| e.to_string())?;
    write_bytes_atomic(&part(parts, index, "json"), &json).map_err(|e| e.to_string())?;
    Ok(m)
}

/// Logs a step's action, reward and collision to the recording, if any.
fn record_act(recorder: &mut Option<EpisodeRecorder>, row: &StepRow) -> Result<(), String> {
    match recorder {
        Some(r) => r
            .act(row.step, &row.action, row.reward, row.collision)
            .map_err(|e| e.to_string()),
        None => Ok(()),
    }
}

/// An episode's index and its metrics (and whether they were kept from an earlier run).
type Outcome = (usize, Result<(EpisodeMetrics, bool), String>);

/// The episodes of this shard, in episode-id order, with their global index.
pub fn select(episodes: &[Episode], shard: Shard) -> Vec<(usize, Episode)> {
    let mut sorted: Vec<&Episode> = episodes.iter().collect();
    sorted.sort_by(|a, b| a.episode_id.cmp(&b.episode_id));
    sorted
        .into_iter()
        .enumerate()
        .filter(|(i, _)| i % shard.count == shard.index)
        .map(|(i, e)| (i, e.clone()))
        .collect()
}

/// Runs the episodes and writes the tables into `cfg.out`.
pub fn run(
    cfg: &RunConfig,
    episodes: &[Episode],
    progress: &dyn Progress,
) -> Result<RunReport, String> {
    let parts = cfg.out.join(".parts");
    if !cfg.resume && parts.exists() {
        std::fs::remove_dir_all(&parts).map_err(|e| format!("{}: {e}", parts.display()))?;
    }
    std::fs::create_dir_all(&parts).map_err(|e| format!("{}: {e}", parts.display()))?;
    let mine = select(episodes, cfg.shard);
    progress.set_total(mine.len() as u64);
    // The episodes recorded for rerun: the first of the shard, in episode-id order.
    let recorded: std::collections::BTreeSet<usize> = mine
        .iter()
        .take(cfg.rerun.as_ref().map_or(0, |r| r.episodes))
        .map(|(i, _)| *i)
        .collect();
    // Finished earlier: metrics written and, when recorded, the recording too.
    let done = |i: usize| {
        cfg.resume
            && part(&parts, i, "json").is_file()
            && (!recorded.contains(&i) || part(&parts, i, "rrd").is_file())
    };
    let mut by_scene: BTreeMap<String, Vec<(usize, Episode)>> = BTreeMap::new();
    for (i, e) in &mine {
        by_scene
            .entry(e.scene_id.clone())
            .or_default()
            .push((*i, e.clone()));
    }
    let scenes: Vec<(String, Vec<(usize, Episode)>)> = by_scene.into_iter().collect();
    let results: Vec<Vec<Outcome>> = scenes
        .par_iter()
        .map(|(scene_id, eps)| {
            let pending: Vec<&(usize, Episode)> = eps.iter().filter(|(i, _)| !done(*i)).collect();
            let mut out: Vec<Outcome> = Vec::new();
            for (i, _) in eps.iter().filter(|(i, _)| done(*i)) {
                let kept = std::fs::read(part(&parts, *i, "json"))
                    .map_err(|e| e.to_string())
                    .and_then(|b| serde_json::from_slice::<PartDone>(&b).map_err(|e| e.to_string()))
                    .map(|d| (EpisodeMetrics::from(&d), true));
                out.push((*i, kept));
                progress.advance(1);
            }
            if pending.is_empty() {
                return out;
            }
            let setup = (|| -> Result<(Simulator, Arc<SceneAssets>), String> {
                let (scene, _) = load_scene(&cfg.data, scene_id)
                    .map_err(|e| format!("{e} (run `minos ingest`)"))?;
                let grid = read_nav(&nav_path(&cfg.data, &grid_ref(&cfg.data, scene_id)))
                    .map_err(|e| format!("{e} (run `minos bake`)"))?;
                let assets =
                    Arc::new(SceneAssets::new(&scene, grid, &cfg.body).map_err(|e| e.to_string())?);
                let renderer = Arc::new(
                    Renderer::new(cfg.renderer, &assets.render).map_err(|e| e.to_string())?,
                );
                let sim = Simulator::new(
                    assets.clone(),
                    renderer,
                    cfg.body,
                    cfg.sensors.clone(),
                    cfg.max_steps.unwrap_or(500),
                    cfg.seed,
                );
                Ok((sim, assets))
            })();
            match setup {
                Err(e) => {
                    for (i, _) in pending {
                        out.push((*i, Err(e.clone())));
                        progress.advance(1);
                    }
                }
                Ok((mut sim, assets)) => match make_agent(&cfg.agent, cfg.seed) {
                    Ok(mut agent) => {
                        // One line-of-sight index and set of search records for every
                        // episode's goal field in this scene.
                        let geo = Geodesic::new(&assets.grid);
                        for (i, ep) in pending {
                            out.push((
                                *i,
                                run_episode(
                                    &mut sim,
                                    &geo,
                                    agent.as_mut(),
                                    ep,
                                    cfg,
                                    &parts,
                                    *i,
                                    recorded.contains(i),
                                )
                                .map(|m| (m, false)),
                            ));
                            progress.advance(1);
                        }
                    }
                    Err(e) => {
                        for (i, _) in pending {
                            out.push((*i, Err(e.clone())));
                            progress.advance(1);
                        }
                    }
                },
            }
            out
        })
        .collect();
    let mut by_index: BTreeMap<usize, Result<(EpisodeMetrics, bool), String>> =
        results.into_iter().flatten().collect();
    let mut report = RunReport::default();
    let mut traj_parts = Vec::new();
    let mut obs_parts = Vec::new();
    for (i, ep) in &mine {
        match by_index.remove(i) {
            Some(Ok((m, resumed))) => {
                report.resumed += usize::from(resumed);
                report.episodes.push((ep.clone(), m));
                traj_parts.push(part(&parts, *i, "traj.parquet"));
                obs_parts.push(part(&parts, *i, "obs.parquet"));
            }
            Some(Err(e)) => report.failures.push((ep.episode_id.clone(), e)),
            None => report
                .failures
                .push((ep.episode_id.clone(), "not run".into())),
        }
    }
    merge(
        &traj_parts,
        trajectory_schema(),
        &cfg.out.join("trajectories.parquet"),
    )?;
    merge(
        &obs_parts,
        observation_schema(&cfg.sensors.cameras, cfg.encoding),
        &cfg.out.join("observations.parquet"),
    )?;
    let rows: Vec<(String, String, String, EpisodeMetrics)> = report
        .episodes
        .iter()
        .map(|(e, m)| {
            (
                e.task.name().to_string(),
                e.split.clone(),
                e.difficulty.name().to_string(),
                *m,
            )
        })
        .collect();
    report.groups = aggregate(&rows);
    super::tables::write_episode_table(&cfg.out.join("episodes.parquet"), &report.episodes)?;
    let metrics = serde_json::json!({
        "groups": report.groups,
        "episodes": report.episodes.iter().map(|(e, m)| serde_json::json!({"episode_id": e.episode_id, "metrics": m})).collect::<Vec<_>>(),
        "failures": report.failures.iter().map(|(id, e)| serde_json::json!({"episode_id": id, "error": e})).collect::<Vec<_>>(),
    });
    write_bytes_atomic(
        &cfg.out.join("metrics.json"),
        &serde_json::to_vec_pretty(&metrics).map_err(|e| e.to_string())?,
    )
    .map_err(|e| e.to_string())?;
    if let Some(rerun) = &cfg.rerun {
        let recordings: Vec<PathBuf> = mine
            .iter()
            .filter(|(i, e)| {
                recorded.contains(i)
                    && report
                        .episodes
                        .iter()
                        .any(|(r, _)| r.episode_id == e.episode_id)
            })
            .map(|(i, _)| part(&parts, *i, "rrd"))
            .collect();
        crate::io::rrd::concat(&recordings, &rerun.path).map_err(|e| e.to_string())?;
        report.recorded = recordings.len();
    }
    if cfg.lerobot {
        let sources: Vec<(Episode, PathBuf, PathBuf)> = mine
            .iter()
            .filter(|(_, e)| {
                report
                    .episodes
                    .iter()
                    .any(|(r, _)| r.episode_id == e.episode_id)
            })
            .map(|(i, e)| {
                (
                    e.clone(),
                    part(&parts, *i, "traj.parquet"),
                    part(&parts, *i, "obs.parquet"),
                )
            })
            .collect();
        super::lerobot::write(
            &cfg.out.join("lerobot"),
            &sources,
            &cfg.sensors.cameras,
            1.0 / cfg.body.dt,
        )?;
    }
    if report.failures.is_empty() {
        let _ = std::fs::remove_dir_all(&parts);
    }
    Ok(report)
}
