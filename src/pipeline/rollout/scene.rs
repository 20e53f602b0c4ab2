//! One scene of a run: load the scene and the grid that serves it, check the grid's body
//! against the agent's, build the simulator and the agent that every episode of the scene
//! shares.

use std::sync::Arc;

use super::{AgentKind, RunConfig};
use crate::episode::interchange::DEFAULT_MAX_STEPS;
use crate::navmesh::geodesic::Geodesic;
use crate::render::gpu::GpuError;
use crate::render::{Renderer, RendererChoice};
use crate::run::agents::{
    Agent, AgentError, ForwardAgent, MinosRandomAgent, RandomAgent, ReplayAgent,
};
use crate::run::external::ExternalAgent;
use crate::run::oracle::OracleAgent;
use crate::run::stepper::{EpisodeStepper, StepperConfig};
use crate::scene::SceneRef;
use crate::sim::SimError;
use crate::sim::{AgentConfig, SceneAssets, Simulator};
use crate::store::{DataDir, StoreError};

/// What the episodes of one scene share: the stepper (with its simulator), the agent, and
/// one line-of-sight index and set of search records for every episode's goal field.
pub struct SceneRun<'a> {
    /// The episode stepper, on the scene's simulator.
    pub stepper: EpisodeStepper,
    /// The agent.
    pub agent: Box<dyn Agent>,
    /// Geodesic queries on the scene's grid.
    pub geo: Geodesic<'a>,
}

impl<'a> SceneRun<'a> {
    /// The run of `agent` on `sim` with the reward and step limit of `cfg`.
    pub fn new(sim: Simulator, agent: Box<dyn Agent>, cfg: &RunConfig, geo: Geodesic<'a>) -> Self {
        let stepper = EpisodeStepper::new(
            sim,
            StepperConfig {
                reward: cfg.reward,
                max_steps: cfg.max_steps,
                require_stop: agent.stops(),
            },
        );
        SceneRun {
            stepper,
            agent,
            geo,
        }
    }
}

/// Why a scene of a run could not be set up; one line, recorded for every episode of the
/// scene (a batch goes on with the other scenes).
#[derive(Debug, thiserror::Error)]
pub enum SceneLoadError {
    /// The compiled scene is missing or unreadable (the scene is not ingested).
    #[error("{0}")]
    Scene(#[source] StoreError),
    /// The scene's navigation grid is missing or unreadable.
    #[error("{0}")]
    Grid(#[source] StoreError),
    /// The simulator's assets could not be built (a body the grid was not baked for, a
    /// scene without geometry).
    #[error(transparent)]
    Assets(SimError),
    /// The renderer could not be created.
    #[error(transparent)]
    Renderer(GpuError),
}

/// Loads scene `scene_id` and the grid that serves it, checks the grid's body against
/// `body` (unless `allow_body_mismatch`) and creates the renderer: the scene set-up of every
/// driver (runs, vector environments, the bindings' simulator). The error is one line.
pub fn load_assets(
    data: &DataDir,
    scene_id: &str,
    body: &AgentConfig,
    renderer: RendererChoice,
    allow_body_mismatch: bool,
) -> Result<(Arc<SceneAssets>, Arc<Renderer>), SceneLoadError> {
    let scene_ref = SceneRef::parse(scene_id);
    let (scene, _) = data.load_scene(&scene_ref).map_err(SceneLoadError::Scene)?;
    let grid = data.read_grid(&scene_ref).map_err(SceneLoadError::Grid)?;
    let assets = if allow_body_mismatch {
        SceneAssets::new_allowing_body_mismatch(&scene, grid, body)
    } else {
        SceneAssets::new(&scene, grid, body)
    };
    let assets = Arc::new(assets.map_err(SceneLoadError::Assets)?);
    let renderer =
        Arc::new(Renderer::new(renderer, &assets.render).map_err(SceneLoadError::Renderer)?);
    Ok((assets, renderer))
}

/// Loads scene `scene_id` and builds its simulator; the error is one line for every episode
/// of the scene.
pub fn load(
    cfg: &RunConfig,
    scene_id: &str,
) -> Result<(Simulator, Arc<SceneAssets>), SceneLoadError> {
    let (assets, renderer) = load_assets(
        &cfg.data,
        scene_id,
        &cfg.agent_config,
        cfg.renderer,
        cfg.allow_body_mismatch,
    )?;
    let sim = Simulator::new(
        assets.clone(),
        renderer,
        cfg.agent_config,
        cfg.sensors.clone(),
        cfg.max_steps.unwrap_or(DEFAULT_MAX_STEPS),
        cfg.seed,
    );
    Ok((sim, assets))
}

/// The agent `kind` (one per scene thread).
pub fn make_agent(kind: &AgentKind, seed: u64) -> Result<Box<dyn Agent>, AgentError> {
    Ok(match kind {
        AgentKind::Random => Box::new(RandomAgent::new(seed)),
        AgentKind::MinosRandom => Box::new(MinosRandomAgent::new(seed)),
        AgentKind::Forward => Box::new(ForwardAgent::new(seed)),
        AgentKind::Oracle => Box::new(OracleAgent::new()),
        AgentKind::Replay(m) => Box::new(ReplayAgent::new(m.clone())),
        AgentKind::External(cmd) => Box::new(ExternalAgent::spawn(cmd)?),
    })
}
