//! The canonical scene model: what every loader produces and every later stage consumes.
//!
//! It knows no file format. Coordinates are world metres, right-handed, +Y up
//! (loaders convert). Meshes live once in [`Scene::meshes`] and are referenced by index, so a
//! model placed twice is stored once.

use glam::Mat4;
use serde::{Deserialize, Serialize};

use super::geometry::Aabb;
use super::mesh::{Mesh, WorldMesh};
use super::taxonomy::RoomClass;

use super::taxonomy::{Categories, ObjectFlags};
use crate::invalid::Invalid;

/// Index of a mesh in [`Scene::meshes`].
pub type MeshId = u32;

/// The dataset a scene came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Dataset {
    /// SUNCG `house.json` houses (including minos's generated ones).
    Suncg,
    /// Matterport3D scans.
    Mp3d,
    /// 3D-FRONT scene JSONs.
    ThreeDFront,
    /// glTF / GLB scenes.
    Gltf,
}

impl Dataset {
    /// The name used on the command line and in the manifest.
    pub fn name(self) -> &'static str {
        match self {
            Dataset::Suncg => "suncg",
            Dataset::Mp3d => "mp3d",
            Dataset::ThreeDFront => "3dfront",
            Dataset::Gltf => "gltf",
        }
    }
}

/// A whole scene (a house).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    /// The dataset's own id (SUNCG house id, scan id, file stem).
    pub id: String,
    /// Where it came from.
    pub dataset: Dataset,
    /// Levels (floors) from the bottom up.
    pub levels: Vec<Level>,
    /// Every mesh the scene uses, each stored once.
    pub meshes: Vec<Mesh>,
}

/// One level (storey) of a scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Level {
    /// Position in [`Scene::levels`].
    pub index: u32,
    /// World box of all rooms and objects of the level.
    pub bbox: Aabb,
    /// Distinct floor heights of the level's rooms (metres, ascending).
    pub floor_heights: Vec<f32>,
    /// Rooms.
    pub rooms: Vec<Room>,
    /// Objects (furniture, doors, windows, stairs, …).
    pub objects: Vec<Object>,
    /// Outdoor ground surfaces (world-space meshes), if any.
    pub ground: Vec<MeshId>,
}

/// Which part of a room a room mesh is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum SurfaceKind {
    /// Walkable floor.
    Floor,
    /// Ceiling.
    Ceiling,
    /// Walls (with their door and window openings).
    Wall,
}

/// A room surface: a world-space mesh of a given kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Surface {
    /// Floor, ceiling or walls.
    pub kind: SurfaceKind,
    /// The world-space mesh.
    pub mesh: MeshId,
}

/// A room (SUNCG room, Matterport3D region, 3D-FRONT room).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Room {
    /// The dataset's id for the room (SUNCG node id such as `0_3`).
    pub id: String,
    /// Raw type labels from the dataset (`Living_Room`, `l`, …).
    pub raw_types: Vec<String>,
    /// The MINOS room class.
    pub class: RoomClass,
    /// Floor outline in the XZ plane when the dataset gives one (counter-clockwise).
    pub floor_polygon: Option<Vec<[f32; 2]>>,
    /// Floor, ceiling and wall meshes, in world space.
    pub surfaces: Vec<Surface>,
    /// Floor area in square metres (floor triangles projected on XZ, or the polygon's area).
    pub area: f32,
    /// Height of the floor (metres).
    pub floor_height: f32,
    /// World box of the room's surfaces.
    pub bbox: Aabb,
}

/// A material override an instance applies to its model's material slot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MaterialOverride {
    /// Slot index in the mesh's materials.
    pub slot: u32,
    /// Name the dataset gives the override.
    pub name: String,
    /// Replacement diffuse colour, if given.
    pub diffuse: Option<[f32; 4]>,
    /// Replacement texture name, if given; an empty name removes the model's texture.
    pub texture: Option<String>,
}

/// An object instance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Object {
    /// Stable instance id, unique within the scene (SUNCG node id such as `0_12`).
    pub id: String,
    /// The dataset's model id.
    pub model_id: String,
    /// Category labels.
    pub categories: Categories,
    /// Model-to-world transform.
    pub transform: Mat4,
    /// World box of the placed mesh.
    pub bbox: Aabb,
    /// The model's mesh (in model space), if the object has geometry.
    pub mesh: Option<MeshId>,
    /// Per-instance material overrides.
    pub materials: Vec<MaterialOverride>,
    /// Door / window / arch / stairs flags.
    pub flags: ObjectFlags,
    /// Indices (in the level's rooms) of the rooms the dataset assigns the object to.
    pub rooms: Vec<u32>,
}

impl Scene {
    /// Box of every level.
    pub fn bbox(&self) -> Aabb {
        self.levels
            .iter()
            .fold(Aabb::EMPTY, |acc, l| acc.union(&l.bbox))
    }

    /// All rooms of all levels.
    pub fn rooms(&self) -> impl Iterator<Item = &Room> {
        self.levels.iter().flat_map(|l| l.rooms.iter())
    }

    /// All objects of all levels.
    pub fn objects(&self) -> impl Iterator<Item = &Object> {
        self.levels.iter().flat_map(|l| l.objects.iter())
    }

    /// Total floor area of all rooms, in square metres.
    pub fn floor_area(&self) -> f64 {
        self.rooms().map(|r| f64::from(r.area)).sum()
    }

    /// Triangles of all placed geometry (rooms, ground, object instances).
    pub fn triangle_count(&self) -> u64 {
        let tri = |m: MeshId| self.meshes[m as usize].triangle_count() as u64;
        self.levels
            .iter()
            .map(|l| {
                l.rooms
                    .iter()
                    .flat_map(|r| r.surfaces.iter())
                    .map(|s| tri(s.mesh))
                    .sum::<u64>()
                    + l.ground.iter().map(|&g| tri(g)).sum::<u64>()
                    + l.objects
                        .iter()
                        .filter_map(|o| o.mesh)
                        .map(tri)
                        .sum::<u64>()
            })
            .sum()
    }

    /// The world-space geometry of an object (winding fixed for mirrored transforms).
    pub fn object_world_mesh(&self, object: &Object) -> Option<WorldMesh> {
        object
            .mesh
            .map(|m| WorldMesh::place(&self.meshes[m as usize], &object.transform))
    }

    /// The world-space geometry of a room surface or ground mesh (already in world space).
    pub fn surface_world_mesh(&self, mesh: MeshId) -> WorldMesh {
        WorldMesh::place(&self.meshes[mesh as usize], &Mat4::IDENTITY)
    }

    /// Checks what every later stage indexes or computes with: each mesh's invariants, every
    /// mesh id (room surfaces, ground, objects) and room index in range, level indices equal
    /// to their positions, and finite
    /// numbers (transforms, heights, areas, outlines; boxes free of NaN, as the empty box is
    /// infinite). Returns the first problem, naming the records (`level 0: room 0_3: …`).
    pub fn validate(&self) -> Result<(), Invalid> {
        let nmesh = self.meshes.len();
        let mesh_ok = |m: MeshId| (m as usize) < nmesh;
        for (i, m) in self.meshes.iter().enumerate() {
            m.validate()
                .map_err(Invalid::inside(format!("mesh {i} ({})", m.name)))?;
        }
        for (li, l) in self.levels.iter().enumerate() {
            let level = format!("level {li}");
            let at = |what: String| Invalid::new(what).at(&level);
            if l.index as usize != li {
                return Err(at(format!("says it is level {}", l.index)));
            }
            check_box(&l.bbox).map_err(|e| e.at("box").at(&level))?;
            if !l.floor_heights.iter().all(|h| h.is_finite()) {
                return Err(at("floor heights: not finite".into()));
            }
            if let Some(g) = l.ground.iter().find(|&&g| !mesh_ok(g)) {
                return Err(at(format!(
                    "ground: mesh {g} out of range for {nmesh} meshes"
                )));
            }
            for r in &l.rooms {
                let room = format!("room {}", r.id);
                let at = |what: String| Invalid::new(what).at(&room).at(&level);
                if let Some(s) = r.surfaces.iter().find(|s| !mesh_ok(s.mesh)) {
                    return Err(at(format!(
                        "mesh {} out of range for {nmesh} meshes",
                        s.mesh
                    )));
                }
                if !r.area.is_finite() || !r.floor_height.is_finite() {
                    return Err(at("area or floor height not finite".into()));
                }
                if r.floor_polygon
                    .iter()
                    .flatten()
                    .any(|p| !p.iter().all(|v| v.is_finite()))
                {
                    return Err(at("floor outline not finite".into()));
                }
                check_box(&r.bbox).map_err(|e| e.at("box").at(&room).at(&level))?;
            }
            for o in &l.objects {
                let object = format!("object {}", o.id);
                let at = |what: String| Invalid::new(what).at(&object).at(&level);
                if let Some(m) = o.mesh.filter(|&m| !mesh_ok(m)) {
                    return Err(at(format!("mesh {m} out of range for {nmesh} meshes")));
                }
                if let Some(r) = o.rooms.iter().find(|&&r| r as usize >= l.rooms.len()) {
                    return Err(at(format!(
                        "room {r} out of range for {} rooms",
                        l.rooms.len()
                    )));
                }
                if !o.transform.is_finite() {
                    return Err(at("transform not finite".into()));
                }
                if !o.transform.row(3).abs_diff_eq(glam::Vec4::W, 1e-6) {
                    return Err(at("transform not affine (last row is not 0 0 0 1)".into()));
                }
                check_box(&o.bbox).map_err(|e| e.at("box").at(&object).at(&level))?;
                if o.materials
                    .iter()
                    .flat_map(|m| m.diffuse.iter().flatten())
                    .any(|v| !v.is_finite())
                {
                    return Err(at("material override colour not finite".into()));
                }
            }
        }
        Ok(())
    }
}

/// A box is fine when it holds no NaN (the empty box is infinite).
fn check_box(b: &Aabb) -> Result<(), Invalid> {
    if b.min.is_nan() || b.max.is_nan() {
        return Err(format!("NaN in {:?}..{:?}", b.min, b.max).into());
    }
    Ok(())
}
