//! Scenes: the canonical model (`model`, `mesh`, `geometry`), the taxonomies, and one loader
//! per dataset format (`formats`). The model knows no file format; loaders know no later stage.

pub mod formats;
mod geometry;
mod labels;
mod mesh;
mod model;
internal! {
    pub mod room_colors;
}
mod scene_ref;
mod taxonomy;
pub mod variants;

pub use geometry::{box_corner, Aabb, BOX_FACES};
pub use labels::Taxonomy;
pub use mesh::{Material, Mesh, WorldMesh};
pub use model::{
    Dataset, Level, MaterialOverride, MeshId, Object, Room, Scene, Surface, SurfaceKind,
};
pub use scene_ref::SceneRef;
pub use taxonomy::{Categories, FlagTable, ModelCategories, ObjectFlags, RoomClass, RoomTypeTable};
