//! Outputs: rerun recordings (`rrd`), scene exports to OBJ/GLB (`export`), the tables of batch
//! navigation queries (`pairs`: the pairs read, the answers written), and the Parquet
//! tables of a run with their LeRobot-style copy (`tables`, `lerobot`). Nothing here reads or
//! writes the DATA folder (that is `crate::store`).

pub mod export;
pub mod lerobot;
pub mod pairs;
pub mod rrd;
pub mod tables;
