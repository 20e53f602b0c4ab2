//! What a run checks before it writes anything: every scene its episodes name is compiled
//! (and its variant defined) and has a navigation grid baked for the agent's body (unless
//! the mismatch is allowed). The problems come back as one error that lists the scenes of
//! each problem, so a wrong DATA folder or preset is one line, not one line per episode.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

use super::{RolloutError, RunConfig};
use crate::body::BodyMismatch;
use crate::episode::Episode;
use crate::scene::SceneRef;
use crate::store::scene_file::read_header;
use crate::store::scene_file::SceneFileError;
use crate::store::StoreError;

/// Scenes named per problem in the error, at most.
const LISTED: usize = 5;

/// Checks the scene of every episode of `episodes` (see the module documentation).
pub fn check(cfg: &RunConfig, episodes: &[(usize, Episode)]) -> Result<(), RolloutError> {
    let scenes: BTreeSet<&str> = episodes.iter().map(|(_, e)| e.scene_id.as_str()).collect();
    let mut problems: BTreeMap<String, Vec<&str>> = BTreeMap::new();
    let mut body = None;
    for id in &scenes {
        if let Err(problem) = scene_problem(cfg, &SceneRef::parse(id)) {
            if let SceneProblem::Body(b) = &problem {
                body.get_or_insert(*b);
            }
            problems
                .entry(crate::escape::error_line(&problem))
                .or_default()
                .push(id);
        }
    }
    if problems.is_empty() {
        return Ok(());
    }
    let listed: Vec<String> = problems
        .iter()
        .map(|(problem, ids)| {
            let mut names = ids[..ids.len().min(LISTED)].join(", ");
            if ids.len() > LISTED {
                names = format!("{names} and {} more", ids.len() - LISTED);
            }
            let s = if ids.len() == 1 { "" } else { "s" };
            format!("{problem} (scene{s} {names})")
        })
        .collect();
    Err(RolloutError::NotReady {
        scenes: problems.values().map(Vec::len).sum(),
        total: scenes.len(),
        problems: listed.join("; "),
        body,
    })
}

/// Why a scene cannot run; scenes with the same problem share its text, by which the error
/// groups them.
#[derive(Debug, thiserror::Error)]
enum SceneProblem {
    /// No compiled scene.
    #[error("not ingested: no compiled scene in {} (ingest it first)", .0.display())]
    NotIngested(PathBuf),
    /// The compiled scene cannot be read.
    #[error("{} (ingest it again)", crate::escape::error_line(.0))]
    Unreadable(SceneFileError),
    /// The scene's variant is missing or unreadable.
    #[error("variant {name}: {}", crate::escape::error_line(.error))]
    Variant {
        /// The variant's name.
        name: String,
        /// Why it cannot be read.
        error: StoreError,
    },
    /// No grid for the scene (or its variant).
    #[error(
        "not baked: no navigation grid in {}{} (bake it first)",
        dir.display(),
        variant.as_deref().map(|v| format!(" for variant {v}")).unwrap_or_default()
    )]
    NotBaked {
        /// The grids' folder.
        dir: PathBuf,
        /// The variant, when the scene is one.
        variant: Option<String>,
    },
    /// The grid's parameters cannot be read.
    #[error(transparent)]
    Grid(StoreError),
    /// The grid was baked for another body.
    #[error(transparent)]
    Body(BodyMismatch),
}

/// Why `scene` cannot run.
fn scene_problem(cfg: &RunConfig, scene: &SceneRef) -> Result<(), SceneProblem> {
    let data = &cfg.data;
    let compiled = data.scene_path(&scene.scene);
    if !compiled.is_file() {
        return Err(SceneProblem::NotIngested(data.scenes_dir()));
    }
    read_header(&compiled).map_err(SceneProblem::Unreadable)?;
    if let Some(name) = scene.variant.as_deref() {
        data.read_variant(name)
            .map_err(|error| SceneProblem::Variant {
                name: name.to_string(),
                error,
            })?;
    }
    if !data.grid_path(scene).is_file() {
        return Err(SceneProblem::NotBaked {
            dir: data.nav_dir(),
            variant: scene.variant.clone(),
        });
    }
    let params = data.read_grid_params(scene).map_err(SceneProblem::Grid)?;
    if !cfg.allow_body_mismatch {
        cfg.agent_config
            .body
            .check_grid(&params.body)
            .map_err(SceneProblem::Body)?;
    }
    Ok(())
}
