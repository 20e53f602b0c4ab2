//! One episode: reset the simulator and the agent, step until a stop, success or the step
//! limit, and write the episode's part files (observations, trajectory, recording, metrics
//! last).

use std::path::Path;

use super::parts::{part, write_done};
use super::scene::SceneRun;
use super::RunConfig;
use crate::episode::Episode;
use crate::io::rrd::episode::EpisodeRecorder;
use crate::io::rrd::RecordingError;
use crate::io::tables::{write_trajectory, ObservationWriter, StepRow, TableError};
use crate::run::agents::AgentError;
use crate::run::metrics::EpisodeMetrics;
use crate::run::stepper::StepError;

/// Why an episode failed (the run goes on with the others).
#[derive(Debug, thiserror::Error)]
pub enum EpisodeError {
    /// The agent failed.
    #[error(transparent)]
    Agent(#[from] AgentError),
    /// The stepper failed (rendering).
    #[error(transparent)]
    Step(#[from] StepError),
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
/// metrics. The episode is stepped by the scene's [`EpisodeStepper`](crate::run::stepper::EpisodeStepper)
/// (reward, success, end of episode); this loop asks the agent, writes each step's rows and
/// records.
pub fn run_episode(
    scene: &mut SceneRun<'_>,
    ep: &Episode,
    cfg: &RunConfig,
    parts: &Path,
    index: usize,
    record: bool,
) -> Result<EpisodeMetrics, EpisodeError> {
    let SceneRun {
        stepper,
        agent,
        geo,
    } = scene;
    let agent = agent.as_mut();
    stepper.set_require_stop(agent.stops());
    stepper.reset_in(ep, Some(&*geo))?;
    agent.reset(ep, stepper.sim())?;
    let mut recorder = if record {
        let path = part(parts, index, "rrd");
        Some(EpisodeRecorder::create(
            &path,
            ep,
            stepper.sim().assets(),
            &cfg.sensors.cameras,
            &cfg.body,
        )?)
    } else {
        None
    };
    let mut writer = ObservationWriter::create(
        &part(parts, index, "obs.parquet"),
        &ep.episode_id,
        &cfg.sensors.cameras,
        cfg.encoding,
    )
    .map_err(EpisodeError::Table)?;
    let mut rows: Vec<StepRow> = Vec::new();
    let mut stopped = false;
    while !stepper.ended() {
        let t = stepper.decisions();
        let obs = stepper.observation();
        writer.push(t, &obs.images).map_err(EpisodeError::Table)?;
        let state = stepper.sim().state();
        let pose = [
            state.position[0],
            state.position[1],
            state.position[2],
            state.yaw,
            state.tilt,
        ];
        if let Some(r) = recorder.as_mut() {
            r.observe(t, &state, &stepper.sim().cameras(), obs)?;
        }
        let seen = stepper.features();
        let decision = agent.decide(obs, stepper.sim())?;
        let mut row = StepRow {
            step: t,
            pose,
            action: decision.name(),
            strengths: decision.strengths(),
            reward: 0.0,
            collision: false,
            seen,
            done: false,
            success: false,
        };
        let out = stepper.step(decision)?;
        row.reward = out.reward;
        row.collision = out.collision;
        row.done = out.done();
        row.success = out.success;
        stopped = out.stopped;
        record_act(&mut recorder, &row)?;
        rows.push(row);
    }
    writer.finish().map_err(EpisodeError::Table)?;
    write_trajectory(&part(parts, index, "traj.parquet"), &ep.episode_id, &rows)
        .map_err(EpisodeError::Table)?;
    if let Some(mut r) = recorder {
        // Where the last action left the agent (a stop leaves it where it was).
        if !stopped {
            let sim = stepper.sim();
            r.observe(
                rows.len() as u32,
                &sim.state(),
                &sim.cameras(),
                stepper.observation(),
            )?;
        }
        r.finish()?;
    }
    let m = stepper.metrics()?;
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
