//! Scenes: the canonical model (`model`, `mesh`, `geometry`), the taxonomies, and one loader
//! per dataset format (`formats`). The model knows no file format; loaders know no later stage.

pub mod formats;
pub mod geometry;
mod labels;
pub mod mesh;
pub mod model;
pub mod room_colors;
pub mod scene_ref;
pub mod taxonomy;
pub mod variants;

pub use geometry::Aabb;
pub use labels::Taxonomy;
pub use mesh::{Material, Mesh, WorldMesh};
pub use model::{
    Categories, Dataset, Level, MaterialOverride, MeshId, Object, ObjectFlags, Room, Scene,
    Surface, SurfaceKind,
};
pub use scene_ref::SceneRef;
pub use taxonomy::RoomClass;
