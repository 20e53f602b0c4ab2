//! Agents and how they are scored: the agents that drive a simulator (`agents`: random,
//! forward, replay; `oracle`, the planner; `external`, a policy process over JSON lines),
//! the rewards, success test and metrics of an episode (`metrics`), and the one episode
//! stepper every driver steps episodes through (`stepper`: reset, step, reward, termination,
//! truncation, the action set, batches of environments). The batch driver that
//! rolls agents out over many episodes is `crate::pipeline::rollout`.

pub mod agents;
internal! {
    pub mod external;
}
pub mod metrics;
pub mod oracle;
pub mod qc;
pub mod step_features;
pub mod stepper;
