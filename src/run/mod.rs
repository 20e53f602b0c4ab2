//! Runs: agents rolling out episodes in simulators (`agents`, `oracle`), rewards and metrics
//! (`metrics`), and the Parquet tables they write (`tables`); `rollout` ties them together
//! with resumable, per-episode part files.

pub mod agents;
pub mod external;
pub mod lerobot;
pub mod metrics;
pub mod oracle;
pub mod rollout;
pub mod tables;
