//! Navigation: walkable space as a multi-layer 2.5D grid of floor spans, islands, geodesic
//! distance fields and shortest paths.
//!
//! Split by job: `params` (agent and grid), `grid` (the data structure), `build` (voxelising a
//! scene into spans, erosion, rooms, objects), `islands`, `los` (line of sight over spans),
//! `geodesic` (any-angle distance fields), `path` (shortest paths with rooms and doors),
//! `query` (snapping, sampling), `file` (the `.nav` format) and `preview` (PNG images).

internal! {
    pub mod build;
}
mod check;
pub mod file;
pub mod geodesic;
mod grid;
internal! {
    pub mod islands;
}
internal! {
    pub mod los;
}
mod params;
pub mod path;
internal! {
    pub mod preview;
}
pub mod query;
internal! {
    pub mod raster;
}
pub mod route;
#[cfg(test)]
pub(crate) mod testmaps;

pub use build::BuildError;
pub use grid::{
    Baked, Island, NavGrid, NavObject, NavRoom, Span, SparseEdges, SparseLabels, DIRS, NONE,
    SPARSE_GATE, SPARSE_LANDMARKS,
};
pub use params::{params_from_toml, NavParams};
