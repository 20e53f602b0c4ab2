//! The scene as renderers see it: a world-space triangle soup with per-triangle attributes
//! (normal, colour, texture, object, room, semantic classes) and per-corner texture
//! coordinates, grouped into spatial clusters for frustum culling. Built once per scene (its
//! textures are loaded then, see [`super::texture_library`]); every modality of a frame is
//! read from the triangle id a pixel shows, so one rasterisation pass serves colour, depth,
//! normals and labels.

use std::sync::OnceLock;

use glam::Vec3;
use rayon::prelude::*;

use crate::scene::{Aabb, MaterialOverride, Mesh, Scene, SurfaceKind, WorldMesh};

use super::bvh::Bvh;
use super::texture::Texture;
use super::texture_library::TextureLibrary;
use crate::scene::Taxonomy;

/// No object / no room.
pub const NO_ID: u32 = 0;
/// Triangle without a texture.
pub const NO_TEXTURE: u32 = u32::MAX;

/// Attributes of one triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriInfo {
    /// Unit world normal (from the winding).
    pub normal: [f32; 3],
    /// Diffuse colour (sRGB, 0–1); multiplies the texture where there is one.
    pub color: [f32; 3],
    /// Index in [`RenderScene::textures`], or [`NO_TEXTURE`].
    pub texture: u32,
    /// Object index + 1 in `scene.objects()` order (0 for architecture).
    pub object: u32,
    /// Room index + 1 over all levels (0 outside rooms).
    pub room: u32,
    /// MINOS room class of that room (0 when none).
    pub room_class: u8,
    /// NYU-40 class.
    pub nyu40: u16,
    /// mpcat40 class.
    pub mpcat40: u16,
    /// Coarse class.
    pub coarse: u16,
}

/// Triangles `start..end` and their box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cluster {
    /// Box of the cluster's triangles.
    pub bbox: Aabb,
    /// First triangle.
    pub start: u32,
    /// One past the last triangle.
    pub end: u32,
}

/// The renderable scene.
#[derive(Debug, Clone, Default)]
pub struct RenderScene {
    /// Three world positions per triangle.
    pub positions: Vec<Vec3>,
    /// Texture coordinates of each triangle corner (parallel to `positions`; zero for
    /// untextured triangles).
    pub uvs: Vec<[f32; 2]>,
    /// Attributes per triangle.
    pub tris: Vec<TriInfo>,
    /// Textures the triangles refer to.
    pub textures: Vec<Texture>,
    /// Per triangle: world point → texture coordinates (meaningful for textured triangles).
    pub uv_maps: Vec<UvMap>,
    /// Spatial clusters covering all triangles.
    pub clusters: Vec<Cluster>,
    /// The ray caster's hierarchy over `positions`, built on first use and kept with the
    /// scene (so `positions` must not change after the first ray-cast frame).
    bvh: OnceLock<Bvh>,
}

/// The affine map from points of a triangle's plane to its texture coordinates, so a pixel's
/// coordinates follow exactly (perspective-correct) from the ray through it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct UvMap {
    /// The first corner (world).
    pub origin: Vec3,
    /// Texture coordinates at the first corner.
    pub uv0: [f32; 2],
    /// Gradient of u along the plane (per metre).
    pub du: Vec3,
    /// Gradient of v along the plane (per metre).
    pub dv: Vec3,
}

impl UvMap {
    /// The map of a triangle with corners `p` and corner coordinates `uv`.
    pub fn new(p: [Vec3; 3], uv: [[f32; 2]; 3]) -> UvMap {
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let (g11, g12, g22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let det = g11 * g22 - g12 * g12;
        // The gradient g lies in the plane, g = a·e1 + b·e2, with g·e1 and g·e2 the
        // coordinate differences along the edges.
        let grad = |d1: f32, d2: f32| {
            if det <= 0.0 || !det.is_finite() {
                return Vec3::ZERO;
            }
            let a = (g22 * d1 - g12 * d2) / det;
            let b = (g11 * d2 - g12 * d1) / det;
            e1 * a + e2 * b
        };
        UvMap {
            origin: p[0],
            uv0: uv[0],
            du: grad(uv[1][0] - uv[0][0], uv[2][0] - uv[0][0]),
            dv: grad(uv[1][1] - uv[0][1], uv[2][1] - uv[0][1]),
        }
    }

    /// Texture coordinates where the ray `eye + s·dir` meets the plane with unit `normal`
    /// (the first corner's coordinates when the ray runs along the plane).
    #[inline]
    pub fn at(&self, eye: Vec3, dir: Vec3, normal: Vec3) -> [f32; 2] {
        let w = eye - self.origin;
        let nd = normal.dot(dir);
        let q = if nd.abs() > 1e-12 {
            w - dir * (normal.dot(w) / nd)
        } else {
            Vec3::ZERO
        };
        [self.uv0[0] + self.du.dot(q), self.uv0[1] + self.dv.dot(q)]
    }
}

/// Edge of the cells triangles are clustered by (m).
const CLUSTER_CELL: f32 = 2.0;
/// Materials more transparent than this are not drawn (window glass).
const MIN_ALPHA: f32 = 0.5;

/// One triangle before clustering: corners, corner texture coordinates, attributes.
type SoupTri = ([Vec3; 3], [[f32; 2]; 3], TriInfo);

/// A material slot as drawn: colour (RGBA) and texture.
#[derive(Clone, Copy)]
struct Slot {
    diffuse: [f32; 4],
    texture: u32,
}

impl RenderScene {
    /// Flattens a scene and loads the textures its materials name. Textures that cannot be
    /// found or decoded are reported in one warning per scene and drawn in their flat
    /// material colour.
    pub fn new(scene: &Scene) -> Self {
        let mut library = TextureLibrary::new();
        let out = RenderScene::build(scene, &mut library);
        let missing: Vec<String> = library
            .missing()
            .map(|(name, why)| format!("{name} ({why})"))
            .collect();
        if !missing.is_empty() {
            tracing::warn!(
                "scene {}: {} texture(s) not used, flat colours drawn instead: {}",
                scene.id,
                missing.len(),
                missing.join("; ")
            );
        }
        out
    }

    /// Flattens a scene, resolving textures through `library`.
    pub fn build(scene: &Scene, library: &mut TextureLibrary) -> Self {
        let mut soup: Vec<SoupTri> = Vec::new();
        let mut room_base = 0u32;
        let mut object_index = 0u32;
        let surface_info = |kind: SurfaceKind, room: u32, room_class: u8| TriInfo {
            normal: [0.0; 3],
            color: [0.0; 3],
            texture: NO_TEXTURE,
            object: NO_ID,
            room,
            room_class,
            nyu40: Taxonomy::Nyu40.surface_class(kind),
            mpcat40: Taxonomy::Mpcat40.surface_class(kind),
            coarse: Taxonomy::Coarse.surface_class(kind),
        };
        for level in &scene.levels {
            for (ri, room) in level.rooms.iter().enumerate() {
                for s in &room.surfaces {
                    let mesh = &scene.meshes[s.mesh as usize];
                    let info = surface_info(s.kind, room_base + ri as u32 + 1, room.class.index());
                    let slots = slots(mesh, &[], library);
                    push_mesh(
                        &mut soup,
                        mesh,
                        &scene.surface_world_mesh(s.mesh),
                        info,
                        &slots,
                    );
                }
            }
            for &g in &level.ground {
                let mesh = &scene.meshes[g as usize];
                let info = surface_info(SurfaceKind::Floor, NO_ID, 0);
                let slots = slots(mesh, &[], library);
                push_mesh(&mut soup, mesh, &scene.surface_world_mesh(g), info, &slots);
            }
            for object in &level.objects {
                object_index += 1;
                let Some(world) = scene.object_world_mesh(object) else {
                    continue;
                };
                let Some(mesh) = object.mesh.map(|m| &scene.meshes[m as usize]) else {
                    continue;
                };
                let room = object.rooms.first().map_or(NO_ID, |&r| room_base + r + 1);
                let info = TriInfo {
                    normal: [0.0; 3],
                    color: [0.0; 3],
                    texture: NO_TEXTURE,
                    object: object_index,
                    room,
                    room_class: object
                        .rooms
                        .first()
                        .and_then(|&r| level.rooms.get(r as usize))
                        .map_or(0, |r| r.class.index()),
                    nyu40: Taxonomy::Nyu40.object_class(&object.categories),
                    mpcat40: Taxonomy::Mpcat40.object_class(&object.categories),
                    coarse: Taxonomy::Coarse.object_class(&object.categories),
                };
                let slots = slots(mesh, &object.materials, library);
                push_mesh(&mut soup, mesh, &world, info, &slots);
            }
            room_base += level.rooms.len() as u32;
        }
        // Cluster by the cell of each triangle's centroid; a stable sort keeps the order
        // within a cell, so the result is deterministic (keys computed once per triangle,
        // sorted on the rayon pool).
        let key = |t: &[Vec3; 3]| {
            let c = (t[0] + t[1] + t[2]) / 3.0;
            let cell = |v: f32| (v / CLUSTER_CELL).floor() as i64;
            (cell(c.y), cell(c.z), cell(c.x))
        };
        soup.par_sort_by_cached_key(|(t, _, _)| key(t));
        let mut out = RenderScene::default();
        let mut i = 0;
        while i < soup.len() {
            let k = key(&soup[i].0);
            let start = out.tris.len() as u32;
            let mut bbox = Aabb::EMPTY;
            while i < soup.len() && key(&soup[i].0) == k {
                for p in soup[i].0 {
                    bbox.grow(p);
                    out.positions.push(p);
                }
                out.uvs.extend(soup[i].1);
                out.uv_maps.push(if soup[i].2.texture == NO_TEXTURE {
                    UvMap::default()
                } else {
                    UvMap::new(soup[i].0, soup[i].1)
                });
                out.tris.push(soup[i].2);
                i += 1;
            }
            out.clusters.push(Cluster {
                bbox,
                start,
                end: out.tris.len() as u32,
            });
        }
        out.textures = std::mem::take(&mut library.textures);
        out
    }

    internal! {
        /// The BVH over the triangles (built on the first call, then cached).
        pub fn bvh(&self) -> &Bvh {
            self.bvh.get_or_init(|| Bvh::new(&self.positions))
        }
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// The triangle's three world positions.
    pub fn triangle(&self, t: usize) -> [Vec3; 3] {
        [
            self.positions[3 * t],
            self.positions[3 * t + 1],
            self.positions[3 * t + 2],
        ]
    }
}

/// The drawn material of each slot of `mesh`: the mesh's material with the instance's
/// overrides applied (a given colour replaces the colour, a given texture the texture; an
/// empty texture name removes it).
fn slots(mesh: &Mesh, overrides: &[MaterialOverride], library: &mut TextureLibrary) -> Vec<Slot> {
    let count = mesh.materials.len().max(
        mesh.face_materials
            .iter()
            .map(|&m| m as usize + 1)
            .max()
            .unwrap_or(0),
    );
    (0..count)
        .map(|slot| {
            let base = mesh.materials.get(slot);
            let o = overrides.iter().find(|o| o.slot as usize == slot);
            let diffuse = o
                .and_then(|o| o.diffuse)
                .or(base.map(|m| m.diffuse))
                .unwrap_or([0.7, 0.7, 0.7, 1.0]);
            let texture = o
                .and_then(|o| o.texture.as_deref())
                .or(base.and_then(|m| m.texture.as_deref()))
                .filter(|name| !name.is_empty() && !mesh.uvs.is_empty())
                .and_then(|name| library.resolve(name, &mesh.name))
                .unwrap_or(NO_TEXTURE);
            Slot { diffuse, texture }
        })
        .collect()
}

fn push_mesh(
    soup: &mut Vec<SoupTri>,
    mesh: &Mesh,
    world: &WorldMesh,
    info: TriInfo,
    slots: &[Slot],
) {
    let default = Slot {
        diffuse: [0.7, 0.7, 0.7, 1.0],
        texture: NO_TEXTURE,
    };
    for (t, idx) in world.indices.chunks_exact(3).enumerate() {
        let slot = world.face_materials.get(t).copied().unwrap_or(0) as usize;
        let Slot { diffuse, texture } = slots.get(slot).copied().unwrap_or(default);
        if diffuse[3] < MIN_ALPHA {
            continue;
        }
        let p = [
            world.positions[idx[0] as usize],
            world.positions[idx[1] as usize],
            world.positions[idx[2] as usize],
        ];
        let Some(n) = (p[1] - p[0]).cross(p[2] - p[0]).try_normalize() else {
            continue;
        };
        let uv = |k: usize| mesh.uvs.get(idx[k] as usize).copied();
        let (uvs, texture) = match (texture, uv(0), uv(1), uv(2)) {
            (t, Some(a), Some(b), Some(c)) if t != NO_TEXTURE => ([a, b, c], t),
            _ => ([[0.0; 2]; 3], NO_TEXTURE),
        };
        soup.push((
            p,
            uvs,
            TriInfo {
                normal: n.to_array(),
                color: [diffuse[0], diffuse[1], diffuse[2]],
                texture,
                ..info
            },
        ));
    }
}
