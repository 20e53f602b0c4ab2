//! A run's episodes set up as `minos run` and Python's `run` both set them up: read from
//! their file, moved onto the variant asked for (which the DATA folder must define), and
//! checked against the agent (a replay must have steps for every episode the shard runs).

use std::path::Path;

use super::{AgentKind, AgentNameError};
use crate::episode::format::{read_episodes, EpisodeFileError};
use crate::episode::Episode;
use crate::shard::Shard;
use crate::store::{DataDir, StoreError};

/// Why a run's episodes could not be set up. The message names the file or the variant;
/// the front doors add their flag or keyword.
#[derive(Debug, thiserror::Error)]
pub enum RunEpisodesError {
    /// The episode file could not be read (the message names it).
    #[error("{0}")]
    Episodes(#[from] EpisodeFileError),
    /// The variant is not defined, or its description cannot be read.
    #[error("{0}")]
    Variant(#[source] StoreError),
    /// The agent cannot run these episodes (a replay without steps for some of them).
    #[error("{0}")]
    Agent(#[source] AgentNameError),
}

/// Moves `episodes` onto variant `name` of their scenes after checking that the DATA folder
/// defines it (`None`: the episodes as they are).
pub fn episodes_on_variant(
    data: &DataDir,
    name: Option<&str>,
    episodes: Vec<Episode>,
) -> Result<Vec<Episode>, StoreError> {
    let Some(name) = name else {
        return Ok(episodes);
    };
    data.read_variant(name)?;
    Ok(episodes.into_iter().map(|e| e.on_variant(name)).collect())
}

/// The episodes of `file` as a run of `agent` (named `agent_name` as given, e.g.
/// `replay:FILE`) over this `shard` steps them: on `variant` when given
/// ([`episodes_on_variant`]), and covered by the agent ([`AgentKind::check_covers`]).
pub fn run_episodes_of(
    data: &DataDir,
    file: &Path,
    variant: Option<&str>,
    agent: &AgentKind,
    agent_name: &str,
    shard: Shard,
) -> Result<Vec<Episode>, RunEpisodesError> {
    let episodes = episodes_on_variant(data, variant, read_episodes(file)?)
        .map_err(RunEpisodesError::Variant)?;
    agent
        .check_covers(agent_name, &episodes, shard)
        .map_err(RunEpisodesError::Agent)?;
    Ok(episodes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode::format::write_episodes;
    use crate::episode::{Difficulty, Goal, Task};

    fn episode(id: &str) -> Episode {
        Episode {
            episode_id: format!("s:pointgoal:{id}"),
            scene_id: "s".into(),
            split: String::new(),
            task: Task::PointGoal,
            seed: 0,
            start_position: [1.0, 0.0, 2.0],
            start_yaw: 0.0,
            goal: Goal::Point {
                position: [3.0, 0.0, 2.0],
            },
            euclidean_distance: 2.0,
            geodesic_distance: 2.0,
            path_num_doors: 0,
            path_num_rooms: 1,
            difficulty: Difficulty::Easy,
            success_radius: 0.2,
            max_steps: 500,
            levels_crossed: 0,
            route: None,
        }
    }

    #[test]
    fn episodes_are_read_moved_onto_the_variant_and_checked_against_a_replay() {
        let dir = tempfile::tempdir().expect("tempdir");
        let data = DataDir::new(dir.path().join("data"));
        let file = dir.path().join("e.parquet");
        let of = |variant: Option<&str>, agent: &AgentKind| {
            run_episodes_of(&data, &file, variant, agent, "replay:t.parquet", Shard::ALL)
        };
        let e = of(None, &AgentKind::Oracle).expect_err("no file");
        assert!(matches!(e, RunEpisodesError::Episodes(_)), "{e}");
        write_episodes(&file, &[episode("0"), episode("1")]).expect("write");
        let plain = of(None, &AgentKind::Oracle).expect("read");
        assert_eq!(plain, [episode("0"), episode("1")]);
        // A variant the DATA folder does not define is refused, naming it.
        let e = of(Some("tidy"), &AgentKind::Oracle).expect_err("undefined variant");
        assert!(
            matches!(&e, RunEpisodesError::Variant(StoreError::NoVariant { name, .. }) if name == "tidy"),
            "{e}"
        );
        std::fs::create_dir_all(data.variants_dir()).expect("mkdir");
        std::fs::write(data.variant_path("tidy"), "").expect("write");
        let moved = of(Some("tidy"), &AgentKind::Oracle).expect("defined variant");
        assert_eq!(moved[0].scene_id, "s@tidy");
        assert_eq!(moved[0].episode_id, "s@tidy:pointgoal:0");
        // A replay without the steps of every episode is refused.
        let steps = std::collections::HashMap::from([("s:pointgoal:0".to_string(), Vec::new())]);
        let e = of(None, &AgentKind::Replay(steps)).expect_err("episode 1 missing");
        assert!(
            matches!(&e, RunEpisodesError::Agent(AgentNameError::ReplayMissing { missing: 1, total: 2, first, .. }) if first == "s:pointgoal:1"),
            "{e}"
        );
    }
}
