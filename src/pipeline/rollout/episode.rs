//! One episode: reset the simulator and the agent, step until a stop, success or the step
//! limit, and write the episode's part files (observations, trajectory, recording, metrics
//! last).

use std::path::Path;

use super::parts::{write_done, PartError};
use super::scene::SceneRun;
use super::RunConfig;
use crate::episode::Episode;
use crate::io::rrd::episode::EpisodeRecorder;
use crate::io::rrd::RecordingError;
use crate::io::run_dir::PartFile;
use crate::io::tables::{write_trajectory, ObservationWriter, StepRow, TableError};
use crate::run::agents::AgentError;
use crate::run::agents::Decision;
use crate::run::metrics::EpisodeMetrics;
use crate::run::stepper::{EpisodeStepper, StepError, StepOutcome};

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
    #[error(transparent)]
    Table(TableError),
    /// The metrics part could not be written.
    #[error(transparent)]
    Part(#[from] PartError),
    /// A driver broke the stepping order (a bug): what happened.
    #[error("stepping out of order: {0}")]
    OutOfOrder(String),
}

/// Runs one episode into its part files (and, when `record`, its recording) and returns its
/// metrics. The episode is stepped by the scene's [`EpisodeStepper`](crate::run::stepper::EpisodeStepper)
/// (reward, success, end of episode); this loop asks the agent and writes each step
/// ([`EpisodeParts`]).
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
    let mut written = EpisodeParts::open(stepper, ep, cfg, parts, index, record)?;
    if agent.waits_elsewhere() {
        written.write_behind()?;
    }
    while !stepper.ended() {
        // Shown first, then written: a person's page gets the frame without waiting for the
        // observation part's writes, and a row group's compression (behind, where the agent
        // waits elsewhere) overlaps the person's decision instead of delaying the next step.
        agent.present(stepper.observation(), stepper.sim())?;
        written.observed(stepper)?;
        let decision = agent.decide(stepper.observation(), stepper.sim())?;
        written.decided(stepper, &decision);
        let out = stepper.step(decision)?;
        written.after(&out)?;
    }
    written.finish(stepper)
}

/// One episode's part files being written, a step at a time: the observation part (each
/// observation before its decision), the trajectory rows, the recording; the metrics part
/// last, once the stepper has ended the episode. Used by the per-thread loop
/// ([`run_episode`]) and by the batched one (`super::batched`), so both write the same bytes.
pub struct EpisodeParts {
    parts: std::path::PathBuf,
    index: usize,
    episode_id: String,
    writer: ObservationWriter,
    recorder: Option<EpisodeRecorder>,
    rows: Vec<StepRow>,
    /// The row of the decision being stepped.
    pending: Option<StepRow>,
    stopped: bool,
}

impl EpisodeParts {
    /// Opens the parts of episode `index` (`ep`), whose stepper has just been reset to it.
    pub fn open(
        stepper: &EpisodeStepper,
        ep: &Episode,
        cfg: &RunConfig,
        parts: &Path,
        index: usize,
        record: bool,
    ) -> Result<EpisodeParts, EpisodeError> {
        let recorder = if record {
            let path = PartFile::Recording.of(parts, index);
            Some(EpisodeRecorder::create(
                &path,
                ep,
                stepper.sim().assets(),
                &cfg.sensors.cameras,
                &cfg.agent_config,
            )?)
        } else {
            None
        };
        let writer = ObservationWriter::create(
            &PartFile::Observations.of(parts, index),
            &ep.episode_id,
            &cfg.sensors.cameras,
            cfg.encoding,
        )
        .map_err(EpisodeError::Table)?;
        Ok(EpisodeParts {
            parts: parts.to_path_buf(),
            index,
            episode_id: ep.episode_id.clone(),
            writer,
            recorder,
            rows: Vec::new(),
            pending: None,
            stopped: false,
        })
    }

    /// From now on, compresses and writes the observation part on a thread of its own
    /// ([`ObservationWriter::write_behind`]): the same bytes.
    pub fn write_behind(&mut self) -> Result<(), EpisodeError> {
        self.writer.write_behind().map_err(EpisodeError::Table)
    }

    /// Writes the observation the agent decided `decision` on (the stepper's latest) and
    /// what it was given with it: [`EpisodeParts::observed`] then
    /// [`EpisodeParts::decided`].
    pub fn before(
        &mut self,
        stepper: &EpisodeStepper,
        decision: &Decision,
    ) -> Result<(), EpisodeError> {
        self.observed(stepper)?;
        self.decided(stepper, decision);
        Ok(())
    }

    /// Writes the stepper's latest observation (the one the next decision is taken on) to the
    /// observation part and the recording.
    pub fn observed(&mut self, stepper: &EpisodeStepper) -> Result<(), EpisodeError> {
        let t = stepper.decisions();
        let obs = stepper.observation();
        self.writer
            .push(t, &obs.images)
            .map_err(EpisodeError::Table)?;
        if let Some(r) = self.recorder.as_mut() {
            r.observe(t, &stepper.sim().state(), &stepper.sim().cameras(), obs)?;
        }
        Ok(())
    }

    /// Starts the trajectory row of `decision`, taken on the observation
    /// [`EpisodeParts::observed`] wrote (its outcome completes it: [`EpisodeParts::after`]).
    pub fn decided(&mut self, stepper: &EpisodeStepper, decision: &Decision) {
        let t = stepper.decisions();
        let state = stepper.sim().state();
        self.pending = Some(StepRow {
            step: t,
            pose: [
                state.position[0],
                state.position[1],
                state.position[2],
                state.yaw,
                state.tilt,
            ],
            action: decision.name(),
            strengths: decision.strengths(),
            reward: 0.0,
            collision: false,
            seen: stepper.features(),
            done: false,
            success: false,
        });
    }

    /// Completes the row of the decision [`EpisodeParts::before`] wrote with what the step
    /// gave.
    pub fn after(&mut self, out: &StepOutcome<'_>) -> Result<(), EpisodeError> {
        let Some(mut row) = self.pending.take() else {
            return Err(EpisodeError::OutOfOrder(format!(
                "episode {}: a step's outcome without its decision",
                self.episode_id
            )));
        };
        row.reward = out.reward;
        row.collision = out.collision;
        row.done = out.done();
        row.success = out.success;
        self.stopped = out.stopped;
        record_act(&mut self.recorder, &row)?;
        self.rows.push(row);
        Ok(())
    }

    /// Writes the rest of the parts once `stepper` has ended the episode (the metrics part
    /// last) and returns its metrics.
    pub fn finish(self, stepper: &EpisodeStepper) -> Result<EpisodeMetrics, EpisodeError> {
        let EpisodeParts {
            parts,
            index,
            episode_id,
            writer,
            recorder,
            rows,
            stopped,
            ..
        } = self;
        writer.finish().map_err(EpisodeError::Table)?;
        write_trajectory(&PartFile::Trajectory.of(&parts, index), &episode_id, &rows)
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
        write_done(&parts, index, &episode_id, &m)?;
        Ok(m)
    }
}

/// Logs a step's action, reward and collision to the recording, if any.
fn record_act(recorder: &mut Option<EpisodeRecorder>, row: &StepRow) -> Result<(), EpisodeError> {
    match recorder {
        Some(r) => Ok(r.act(row.step, &row.action, row.reward, row.collision)?),
        None => Ok(()),
    }
}
