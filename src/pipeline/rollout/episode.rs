//! One episode: reset the simulator and the agent, step until a stop, success or the step
//! limit, and write the episode's part files (observations, trajectory, recording, metrics
//! last).

use std::path::Path;

use glam::Vec3;

use super::parts::{part, write_done};
use super::scene::SceneRun;
use super::RunConfig;
use crate::episode::Episode;
use crate::io::rrd::episode::EpisodeRecorder;
use crate::io::rrd::RecordingError;
use crate::io::tables::{write_trajectory, ObservationWriter, StepRow, TableError};
use crate::render::gpu::GpuError;
use crate::run::agents::{AgentError, Decision};
use crate::run::metrics::{reached, EpisodeMetrics};

/// Why an episode failed (the run goes on with the others).
#[derive(Debug, thiserror::Error)]
pub enum EpisodeError {
    /// The agent failed.
    #[error(transparent)]
    Agent(#[from] AgentError),
    /// Rendering failed.
    #[error(transparent)]
    Render(#[from] GpuError),
    /// The recording could not be written.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// A table part could not be written.
    #[error("{0}")]
    Table(TableError),
    /// The metrics part could not be written.
    #[error("{0}")]
    Part(String),
}

/// Runs one episode into its part files (and, when `record`, its recording) and returns its
/// metrics.
pub fn run_episode(
    scene: &mut SceneRun<'_>,
    ep: &Episode,
    cfg: &RunConfig,
    parts: &Path,
    index: usize,
    record: bool,
) -> Result<EpisodeMetrics, EpisodeError> {
    let SceneRun { sim, agent, geo } = scene;
    let agent = agent.as_mut();
    sim.reset_episode_in(ep, Some(&*geo));
    agent.reset(ep, sim)?;
    let mut recorder = if record {
        let path = part(parts, index, "rrd");
        Some(EpisodeRecorder::create(
            &path,
            ep,
            sim.assets(),
            &cfg.sensors.cameras,
            &cfg.body,
        )?)
    } else {
        None
    };
    let max_steps = cfg.max_steps.unwrap_or(ep.max_steps).max(1);
    let mut obs = sim.observe()?;
    let mut writer = ObservationWriter::create(
        &part(parts, index, "obs.parquet"),
        &ep.episode_id,
        &cfg.sensors.cameras,
        cfg.encoding,
    )
    .map_err(EpisodeError::Table)?;
    let mut rows: Vec<StepRow> = Vec::new();
    let (mut path_length, mut collisions, mut success) = (0.0f32, 0u32, false);
    let mut stopped = false;
    for t in 0..max_steps {
        writer.push(t, &obs.images).map_err(EpisodeError::Table)?;
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
            r.observe(t, &state, &sim.cameras(), &obs)?;
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
                obs = sim.step(actions)?;
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
    writer.finish().map_err(EpisodeError::Table)?;
    write_trajectory(&part(parts, index, "traj.parquet"), &ep.episode_id, &rows)
        .map_err(EpisodeError::Table)?;
    if let Some(mut r) = recorder {
        // Where the last action left the agent (a stop leaves it where it was).
        if !stopped {
            r.observe(rows.len() as u32, &sim.state(), &sim.cameras(), &obs)?;
        }
        r.finish()?;
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
    write_done(parts, index, &ep.episode_id, &m).map_err(EpisodeError::Part)?;
    Ok(m)
}

/// Logs a step's action, reward and collision to the recording, if any.
fn record_act(recorder: &mut Option<EpisodeRecorder>, row: &StepRow) -> Result<(), EpisodeError> {
    match recorder {
        Some(r) => Ok(r.act(row.step, &row.action, row.reward, row.collision)?),
        None => Ok(()),
    }
}
