//! Simulation: the agent's body and dynamics (`agent`), collisions with the scene (`collision`),
//! sensors (`sensors`), the [`Simulator`] that steps an agent and observes through a renderer,
//! and many simulators stepped and observed at once (`batch`: one render call per shared
//! renderer).

pub mod agent;
pub mod batch;
pub mod collision;
pub mod sensors;
pub mod simulator;

pub use agent::{Actions, AgentConfig, AgentState};
pub use sensors::{SensorSuite, SuiteName};
pub use simulator::{GoalSpec, Observation, SceneAssets, Simulator};
