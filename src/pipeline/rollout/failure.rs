//! Why an episode of a run has no result.

use std::sync::Arc;

use crate::episode::format::EpisodeFileError;
use crate::run::agents::AgentError;

use super::episode::EpisodeError;
use super::parts::PartError;
use super::scene::SceneLoadError;
use super::RolloutError;

/// Why an episode of a run has no result (the run goes on with the others, unless a part
/// file could not be written: [`RolloutError::Write`]). Cheap to clone: the causes are
/// shared, so a scene that cannot load is every one of its episodes' reason.
#[derive(Debug, Clone, thiserror::Error)]
pub enum EpisodeFailure {
    /// Its scene could not be loaded.
    #[error(transparent)]
    Scene(Arc<SceneLoadError>),
    /// Its agent could not be made.
    #[error(transparent)]
    Agent(Arc<AgentError>),
    /// It failed while running (its agent, a step), or one of its part files could not be
    /// written.
    #[error(transparent)]
    Run(Arc<EpisodeError>),
    /// A live run could not write its record into the part files.
    #[error(transparent)]
    Record(Arc<EpisodeFileError>),
    /// It finished in an earlier run, but its metrics part cannot be read back.
    #[error(transparent)]
    Kept(Arc<PartError>),
    /// A live run cannot play it: its id was played already in this run.
    #[error("episode {0} was played already")]
    PlayedAlready(String),
    /// A live run cannot play it: its scene cannot run.
    #[error(transparent)]
    NotReady(Arc<RolloutError>),
    /// It was not started: a part file of another episode could not be written, which stops
    /// the run.
    #[error("not run: a write failed")]
    StoppedByWrite,
    /// It was not run (no outcome came back for it).
    #[error("not run")]
    NotRun,
}

impl From<EpisodeError> for EpisodeFailure {
    fn from(e: EpisodeError) -> Self {
        EpisodeFailure::Run(Arc::new(e))
    }
}

impl From<SceneLoadError> for EpisodeFailure {
    fn from(e: SceneLoadError) -> Self {
        EpisodeFailure::Scene(Arc::new(e))
    }
}

impl From<AgentError> for EpisodeFailure {
    fn from(e: AgentError) -> Self {
        EpisodeFailure::Agent(Arc::new(e))
    }
}
