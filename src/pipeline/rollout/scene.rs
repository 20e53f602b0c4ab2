//! One scene of a run: load the scene and the grid that serves it, check the grid's body
//! against the agent's, build the simulator and the agent that every episode of the scene
//! shares.

use std::sync::Arc;

use super::{AgentKind, RunConfig};
use crate::navmesh::geodesic::Geodesic;
use crate::render::Renderer;
use crate::run::agents::{Agent, AgentError, ForwardAgent, RandomAgent, ReplayAgent};
use crate::run::external::ExternalAgent;
use crate::run::oracle::OracleAgent;
use crate::scene::SceneRef;
use crate::sim::{SceneAssets, Simulator};

/// What the episodes of one scene share: the simulator, the agent, and one line-of-sight
/// index and set of search records for every episode's goal field.
pub struct SceneRun<'a> {
    /// The simulator.
    pub sim: Simulator,
    /// The agent.
    pub agent: Box<dyn Agent>,
    /// Geodesic queries on the scene's grid.
    pub geo: Geodesic<'a>,
}

/// Loads scene `scene_id` and builds its simulator; the error is one line for every episode
/// of the scene.
pub fn load(cfg: &RunConfig, scene_id: &str) -> Result<(Simulator, Arc<SceneAssets>), String> {
    let scene_ref = SceneRef::parse(scene_id);
    let (scene, _) = cfg
        .data
        .load_scene(&scene_ref)
        .map_err(|e| format!("{e} (run `minos ingest`)"))?;
    let grid = cfg.data.read_grid(&scene_ref).map_err(|e| e.to_string())?;
    let assets = if cfg.allow_body_mismatch {
        SceneAssets::new_allowing_body_mismatch(&scene, grid, &cfg.body)
    } else {
        SceneAssets::new(&scene, grid, &cfg.body)
    };
    let assets = Arc::new(assets.map_err(|e| e.to_string())?);
    let renderer =
        Arc::new(Renderer::new(cfg.renderer, &assets.render).map_err(|e| e.to_string())?);
    let sim = Simulator::new(
        assets.clone(),
        renderer,
        cfg.body,
        cfg.sensors.clone(),
        cfg.max_steps.unwrap_or(500),
        cfg.seed,
    );
    Ok((sim, assets))
}

/// The agent `kind` (one per scene thread).
pub fn make_agent(kind: &AgentKind, seed: u64) -> Result<Box<dyn Agent>, AgentError> {
    Ok(match kind {
        AgentKind::Random => Box::new(RandomAgent::new(seed)),
        AgentKind::Forward => Box::new(ForwardAgent::new(seed)),
        AgentKind::Oracle => Box::new(OracleAgent::new()),
        AgentKind::Replay(m) => Box::new(ReplayAgent::new(m.clone())),
        AgentKind::External(cmd) => Box::new(ExternalAgent::spawn(cmd)?),
    })
}
