//! A recorded demonstration played again by the simulator (not a video): the session's
//! recorded decisions for one episode — from its `trajectories.parquet`, or from the part
//! files while the session is still live — are stepped on a fresh simulator with the
//! server's agent, sensors and reward, and each frame is handed to the caller. The operator
//! page shows flagged demonstrations this way, and the replay's outcome is checked against
//! the demonstration's quality record (a replay gives the same path, so any difference is
//! a fault worth seeing).

use std::path::Path;

use super::session::{run_config, Shared};
use crate::episode::Episode;
use crate::io::run_dir::{PartFile, RunDir};
use crate::io::tables::{read_replay, TableError};
use crate::pipeline::rollout::{load_simulator, SceneLoadError};
use crate::run::agents::Decision;
use crate::run::metrics::EpisodeMetrics;
use crate::run::stepper::{EpisodeStepper, StepError, StepperConfig};
use crate::sim::{Observation, Simulator};

/// Why a demonstration could not be replayed (one line).
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The session recorded no decisions for the episode.
    #[error("session {session}: no recorded steps of episode `{episode_id}`")]
    NoSteps {
        /// The session.
        session: String,
        /// The episode.
        episode_id: String,
    },
    /// A trajectory table could not be read.
    #[error(transparent)]
    Table(TableError),
    /// The scene could not be set up.
    #[error(transparent)]
    Scene(#[from] SceneLoadError),
    /// The simulator failed.
    #[error(transparent)]
    Step(#[from] StepError),
}

/// The decisions session folder `dir` recorded for `episode_id`, in step order: from its
/// trajectory table once the session has ended, otherwise from the episode's part file.
pub fn recorded_decisions(dir: &Path, episode_id: &str) -> Result<Vec<Decision>, ReplayError> {
    let run = RunDir::new(dir);
    let mut files = vec![run.trajectories()];
    if let Ok(entries) = std::fs::read_dir(run.parts()) {
        let mut parts: Vec<_> = entries
            .filter_map(Result::ok)
            .map(|e| e.path())
            .filter(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| PartFile::Trajectory.index_of(n).is_some())
            })
            .collect();
        parts.sort();
        files.extend(parts);
    }
    for file in files.iter().filter(|f| f.is_file()) {
        let mut by_episode = read_replay(file).map_err(ReplayError::Table)?;
        if let Some(d) = by_episode.remove(episode_id) {
            return Ok(d);
        }
    }
    Err(ReplayError::NoSteps {
        session: dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        episode_id: episode_id.to_string(),
    })
}

/// One frame of a replay.
pub struct ReplayFrame<'a> {
    /// The decision that led here (`None` for the episode's start).
    pub decision: Option<Decision>,
    /// Its reward (0 at the start).
    pub reward: f32,
    /// The body hit something during it.
    pub collision: bool,
    /// The episode ended with it.
    pub done: bool,
    /// It ended the episode as a success.
    pub success: bool,
    /// Actions applied since the start.
    pub steps: u32,
    /// What the sensors saw after it.
    pub obs: &'a Observation,
    /// The simulator after it (the agent's pose).
    pub sim: &'a Simulator,
}

/// Replays `decisions` of `episode`, recorded in session `session` of `shared`'s server:
/// calls `visit` with the start and after every decision until the episode ends (or
/// `visit` returns false: the viewer left) and returns the replay's metrics.
pub fn replay(
    shared: &Shared,
    session: &str,
    episode: &Episode,
    decisions: &[Decision],
    visit: &mut dyn FnMut(ReplayFrame<'_>) -> bool,
) -> Result<EpisodeMetrics, ReplayError> {
    let cfg = run_config(shared, session);
    let (sim, _) = load_simulator(&cfg, &episode.scene_id)?;
    let mut stepper = EpisodeStepper::new(
        sim,
        StepperConfig {
            reward: shared.reward,
            max_steps: None,
            // A person stops explicitly, as the recording did.
            require_stop: true,
        },
    );
    stepper.reset(episode)?;
    let mut frame = ReplayFrame {
        decision: None,
        reward: 0.0,
        collision: false,
        done: false,
        success: false,
        steps: 0,
        obs: stepper.observation(),
        sim: stepper.sim(),
    };
    if !visit(frame) {
        return Ok(stepper.metrics()?);
    }
    for &d in decisions {
        let o = stepper.step(d)?;
        let (reward, collision, done, success, steps) =
            (o.reward, o.collision, o.done(), o.success, o.steps);
        frame = ReplayFrame {
            decision: Some(d),
            reward,
            collision,
            done,
            success,
            steps,
            obs: stepper.observation(),
            sim: stepper.sim(),
        };
        if !visit(frame) || done {
            break;
        }
    }
    Ok(stepper.metrics()?)
}
