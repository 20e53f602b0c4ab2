//! The agents a run can be driven by, by name (`random`, `minos-random`, `forward`, `oracle`,
//! `replay:FILE`, `external:CMD`): the one parser the CLI and the Python bindings share, and
//! the check that a replay file covers the episodes to run.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::episode::Episode;
use crate::io::tables::{read_replay, TableError};
use crate::run::agents::Decision;
use crate::shard::Shard;

use super::select;

/// Which agent drives.
#[derive(Debug, Clone, PartialEq)]
pub enum AgentKind {
    /// Uniform over the action set.
    Random,
    /// MINOS's random baseline: each button of the action set pressed independently with
    /// probability ½ per step.
    MinosRandom,
    /// Forward, turning on collision.
    Forward,
    /// Plans over reachable states and stops at the goal.
    Oracle,
    /// Decisions from a trajectory table, per episode.
    Replay(HashMap<String, Vec<Decision>>),
    /// A process speaking JSON lines (one per scene thread).
    External(String),
}

/// The agent names [`AgentKind::from_name`] reads, for help texts and errors.
pub const AGENT_NAMES: &str = "random, minos-random, forward, oracle, replay:FILE, external:CMD";

/// Why an agent name does not name an agent.
#[derive(Debug, thiserror::Error)]
pub enum AgentNameError {
    /// Not one of [`AGENT_NAMES`].
    #[error("unknown agent `{0}` ({AGENT_NAMES})")]
    Unknown(String),
    /// `replay:FILE` whose file cannot be read as a trajectory table.
    #[error("replay:{}", file.display())]
    Replay {
        /// The trajectory file.
        file: PathBuf,
        /// What went wrong reading it (the message names the file again).
        #[source]
        reason: Box<TableError>,
    },
    /// `replay:FILE` whose file has no steps for some episode to run.
    #[error(
        "replay:{}: {} has no steps for {missing} of the {total} episodes to run (first: \
         {first}); replay the trajectories.parquet of a run over the same episodes",
        file.display(),
        file.display()
    )]
    ReplayMissing {
        /// The trajectory file.
        file: PathBuf,
        /// How many episodes it lacks.
        missing: usize,
        /// How many episodes the run has.
        total: usize,
        /// The first episode it lacks.
        first: String,
    },
}

impl AgentKind {
    /// The agent `name` names (reading the file of `replay:FILE`).
    pub fn from_name(name: &str) -> Result<AgentKind, AgentNameError> {
        Ok(match name {
            "random" => AgentKind::Random,
            "minos-random" => AgentKind::MinosRandom,
            "forward" => AgentKind::Forward,
            "oracle" => AgentKind::Oracle,
            other => match (
                other.strip_prefix("replay:"),
                other.strip_prefix("external:"),
            ) {
                (Some(file), _) => {
                    let file = PathBuf::from(file);
                    match read_replay(&file) {
                        Ok(m) => AgentKind::Replay(m),
                        Err(reason) => {
                            return Err(AgentNameError::Replay {
                                file,
                                reason: Box::new(reason),
                            })
                        }
                    }
                }
                (_, Some(cmd)) if !cmd.trim().is_empty() => AgentKind::External(cmd.to_string()),
                _ => return Err(AgentNameError::Unknown(other.to_string())),
            },
        })
    }

    /// Refuses a `replay:FILE` agent (`name` as given) whose file has no steps for some
    /// episode of `episodes` this `shard` runs; any other agent passes.
    pub fn check_covers(
        &self,
        name: &str,
        episodes: &[Episode],
        shard: Shard,
    ) -> Result<(), AgentNameError> {
        let (AgentKind::Replay(by_episode), Some(file)) = (self, name.strip_prefix("replay:"))
        else {
            return Ok(());
        };
        let mine = select(episodes, shard);
        let missing: Vec<&str> = mine
            .iter()
            .map(|(_, e)| e.episode_id.as_str())
            .filter(|id| !by_episode.contains_key(*id))
            .collect();
        match missing.first() {
            None => Ok(()),
            Some(first) => Err(AgentNameError::ReplayMissing {
                file: Path::new(file).to_path_buf(),
                missing: missing.len(),
                total: mine.len(),
                first: first.to_string(),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn agents_are_named_or_refused() {
        assert_eq!(AgentKind::from_name("oracle").unwrap(), AgentKind::Oracle);
        assert_eq!(
            AgentKind::from_name("minos-random").unwrap(),
            AgentKind::MinosRandom
        );
        assert_eq!(
            AgentKind::from_name("external:python3 p.py").unwrap(),
            AgentKind::External("python3 p.py".into())
        );
        assert!(AgentKind::from_name("external: ").is_err());
        let unknown = AgentKind::from_name("greedy").unwrap_err().to_string();
        assert!(
            unknown.contains("`greedy`") && unknown.contains("minos-random"),
            "{unknown}"
        );
        let missing = AgentKind::from_name("replay:/nonexistent/t.parquet").unwrap_err();
        assert!(
            matches!(&missing, AgentNameError::Replay { reason, .. }
                if matches!(**reason, TableError::Parquet(_))),
            "{missing:?}"
        );
        // The line a user reads names the file and why it cannot be read.
        let line = crate::escape::error_line(&missing);
        assert!(
            line.starts_with("replay:/nonexistent/t.parquet: /nonexistent/t.parquet: "),
            "{line}"
        );
    }
}
