//! Simulation: the agent's body and dynamics (`agent`), collisions with the scene (`collision`),
//! sensors (`sensors`), the [`Simulator`] that steps an agent and observes through a renderer,
//! and many simulators stepped and observed at once (`batch`: one render call per shared
//! renderer).

mod agent;
pub mod batch;
pub mod collision;
mod sensors;
mod simulator;

pub use agent::{intended_motion, ActionSet, Actions, AgentConfig, AgentState, Motion};
pub use sensors::{
    dtype_of, CameraSensor, ContactSensors, DepthEncoding, DepthNoise, SensorSuite, SuiteName,
};
pub use simulator::{
    prepare_render, GoalSpec, Measurements, Observation, SceneAssets, SimError, Simulator,
    Transition,
};
