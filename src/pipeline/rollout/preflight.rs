//! What a run checks before it writes anything: every scene its episodes name is compiled
//! (and its variant defined) and has a navigation grid baked for the agent's body (unless
//! the mismatch is allowed). The problems come back as one error that lists the scenes of
//! each problem, so a wrong DATA folder or preset is one line, not one line per episode.

use std::collections::{BTreeMap, BTreeSet};

use super::{RolloutError, RunConfig};
use crate::episode::Episode;
use crate::scene::SceneRef;
use crate::store::scene_file::read_header;

/// Scenes named per problem in the error, at most.
const LISTED: usize = 5;

/// Checks the scene of every episode of `episodes` (see the module documentation).
pub fn check(cfg: &RunConfig, episodes: &[(usize, Episode)]) -> Result<(), RolloutError> {
    let scenes: BTreeSet<&str> = episodes.iter().map(|(_, e)| e.scene_id.as_str()).collect();
    let mut problems: BTreeMap<String, Vec<&str>> = BTreeMap::new();
    for id in &scenes {
        if let Err(problem) = scene_problem(cfg, &SceneRef::parse(id)) {
            problems.entry(problem).or_default().push(id);
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
    })
}

/// Why `scene` cannot run, worded so that scenes with the same problem share the text.
fn scene_problem(cfg: &RunConfig, scene: &SceneRef) -> Result<(), String> {
    let data = &cfg.data;
    let compiled = data.scene_path(&scene.scene);
    if !compiled.is_file() {
        return Err(format!(
            "not ingested: no compiled scene in {} (run `minos ingest`)",
            data.scenes_dir().display()
        ));
    }
    read_header(&compiled).map_err(|e| format!("{e} (run `minos ingest --force`)"))?;
    if let Some(name) = scene.variant.as_deref() {
        data.read_variant(name)
            .map_err(|e| format!("variant {name}: {e}"))?;
    }
    if !data.grid_path(scene).is_file() {
        let bake = match scene.variant.as_deref() {
            Some(name) => format!("minos bake --variant {name}"),
            None => "minos bake".to_string(),
        };
        return Err(format!(
            "not baked: no navigation grid in {} (run `{bake}`)",
            data.nav_dir().display()
        ));
    }
    let params = data.read_grid_params(scene).map_err(|e| e.to_string())?;
    if !cfg.allow_body_mismatch {
        cfg.agent_config
            .body
            .check_grid(&params.body)
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}
