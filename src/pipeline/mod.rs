//! Batch drivers: one per long command. Each reads scenes and grids from a DATA folder
//! ([`crate::store::DataDir`]), runs an algorithm per scene in parallel, collects the results
//! in input order and writes outputs, so results never depend on the thread count:
//! `ingest` (dataset → compiled scenes + manifest), `bake` (navigation grids), `episodes`
//! (episode sampling over many scenes), `variants` (material statistics, dry runs),
//! `split` (a DATA folder's train/val/test lists), `rollout` (agents over episodes into
//! datasets), `vector_env` (environments stepped
//! together, for the Gym bindings), `view` (a scene for the rerun viewer) and `render_views`
//! (one pose's images).

pub mod bake;
pub mod bench;
pub mod demo;
pub mod episodes;
pub mod ingest;
pub mod merge;
pub mod render_views;
pub mod rollout;
pub mod split;
pub mod variants;
pub mod vector_env;
pub mod view;
