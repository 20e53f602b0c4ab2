//! The scene as renderers see it: a world-space triangle soup with per-triangle attributes
//! (normal, colour, object, room, semantic classes), grouped into spatial clusters for
//! frustum culling. Built once per scene; every modality of a frame is read from the triangle
//! id a pixel shows, so one rasterisation pass serves colour, depth, normals and labels.

use glam::Vec3;

use crate::scene::{Aabb, Mesh, Scene, SurfaceKind, WorldMesh};

use super::labels::Taxonomy;

/// No object / no room.
pub const NO_ID: u32 = 0;

/// Attributes of one triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriInfo {
    /// Unit world normal (from the winding).
    pub normal: [f32; 3],
    /// Diffuse colour (sRGB, 0–1).
    pub color: [f32; 3],
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
    /// Attributes per triangle.
    pub tris: Vec<TriInfo>,
    /// Spatial clusters covering all triangles.
    pub clusters: Vec<Cluster>,
}

/// Edge of the cells triangles are clustered by (m).
const CLUSTER_CELL: f32 = 2.0;
/// Materials more transparent than this are not drawn (window glass).
const MIN_ALPHA: f32 = 0.5;

impl RenderScene {
    /// Flattens a scene.
    pub fn new(scene: &Scene) -> Self {
        let mut soup: Vec<([Vec3; 3], TriInfo)> = Vec::new();
        let mut room_base = 0u32;
        let mut object_index = 0u32;
        for level in &scene.levels {
            for (ri, room) in level.rooms.iter().enumerate() {
                for s in &room.surfaces {
                    let mesh = &scene.meshes[s.mesh as usize];
                    let info = TriInfo {
                        normal: [0.0; 3],
                        color: [0.0; 3],
                        object: NO_ID,
                        room: room_base + ri as u32 + 1,
                        room_class: room.class.index(),
                        nyu40: Taxonomy::Nyu40.surface_class(s.kind),
                        mpcat40: Taxonomy::Mpcat40.surface_class(s.kind),
                    };
                    push_mesh(
                        &mut soup,
                        mesh,
                        &scene.surface_world_mesh(s.mesh),
                        info,
                        &[],
                    );
                }
            }
            for &g in &level.ground {
                let info = TriInfo {
                    normal: [0.0; 3],
                    color: [0.0; 3],
                    object: NO_ID,
                    room: NO_ID,
                    room_class: 0,
                    nyu40: Taxonomy::Nyu40.surface_class(SurfaceKind::Floor),
                    mpcat40: Taxonomy::Mpcat40.surface_class(SurfaceKind::Floor),
                };
                push_mesh(
                    &mut soup,
                    &scene.meshes[g as usize],
                    &scene.surface_world_mesh(g),
                    info,
                    &[],
                );
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
                    object: object_index,
                    room,
                    room_class: object
                        .rooms
                        .first()
                        .and_then(|&r| level.rooms.get(r as usize))
                        .map_or(0, |r| r.class.index()),
                    nyu40: Taxonomy::Nyu40.object_class(&object.categories),
                    mpcat40: Taxonomy::Mpcat40.object_class(&object.categories),
                };
                let overrides: Vec<(u32, [f32; 4])> = object
                    .materials
                    .iter()
                    .filter_map(|m| m.diffuse.map(|d| (m.slot, d)))
                    .collect();
                push_mesh(&mut soup, mesh, &world, info, &overrides);
            }
            room_base += level.rooms.len() as u32;
        }
        // Cluster by the cell of each triangle's centroid; a stable sort keeps the order
        // within a cell, so the result is deterministic.
        let key = |t: &[Vec3; 3]| {
            let c = (t[0] + t[1] + t[2]) / 3.0;
            let cell = |v: f32| (v / CLUSTER_CELL).floor() as i64;
            (cell(c.y), cell(c.z), cell(c.x))
        };
        soup.sort_by_key(|(t, _)| key(t));
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
                out.tris.push(soup[i].1);
                i += 1;
            }
            out.clusters.push(Cluster {
                bbox,
                start,
                end: out.tris.len() as u32,
            });
        }
        out
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

fn push_mesh(
    soup: &mut Vec<([Vec3; 3], TriInfo)>,
    mesh: &Mesh,
    world: &WorldMesh,
    info: TriInfo,
    overrides: &[(u32, [f32; 4])],
) {
    for (t, idx) in world.indices.chunks_exact(3).enumerate() {
        let slot = world.face_materials.get(t).copied().unwrap_or(0) as u32;
        let mut diffuse = mesh
            .materials
            .get(slot as usize)
            .map_or([0.7, 0.7, 0.7, 1.0], |m| m.diffuse);
        if let Some((_, d)) = overrides.iter().find(|(s, _)| *s == slot) {
            diffuse = *d;
        }
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
        soup.push((
            p,
            TriInfo {
                normal: n.to_array(),
                color: [diffuse[0], diffuse[1], diffuse[2]],
                ..info
            },
        ));
    }
}
