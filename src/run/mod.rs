//! Agents and how they are scored: the agents that drive a simulator (`agents`: random,
//! forward, replay; `oracle`, the planner; `external`, a policy process over JSON lines) and
//! the rewards, success test and metrics of an episode (`metrics`). The batch driver that
//! rolls agents out over many episodes is `crate::pipeline::rollout`.

pub mod agents;
pub mod external;
pub mod metrics;
pub mod oracle;
