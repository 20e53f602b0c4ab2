//! Baking a scene into a [`NavGrid`]: voxelise triangles into solid intervals, find the floor
//! spans where the agent's cylinder fits, link neighbouring spans within the climb limit,
//! erode by the agent radius, then label rooms, objects above spans and islands.
//!
//! Room surfaces and ground are rasterised triangle by triangle (they are surfaces); object
//! meshes are filled as solids column by column (the inside of a wardrobe is not floor), so
//! the space under a table stays free and is walkable only if the agent fits under it.

use glam::Vec3;

use crate::scene::{Scene, SurfaceKind, WorldMesh};

use super::grid::{NavGrid, NavObject, NavRoom, Span, DIRS, NONE};
use super::islands::label_islands;
use super::params::NavParams;
use super::raster::{is_floor, RasterGrid, Solid};

/// A bake failure.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// The parameters are unusable.
    #[error("navigation parameters: {0}")]
    Params(crate::invalid::Invalid),
    /// The scene has no geometry, or a grid of that size is unreasonable.
    #[error("scene {scene}: {message}")]
    Scene {
        /// Scene id.
        scene: String,
        /// What is wrong.
        message: String,
    },
}

/// Largest grid accepted (columns), to fail clearly instead of exhausting memory.
const MAX_COLUMNS: u64 = 200_000_000;
/// Heights closer than this are one surface.
const MERGE_EPS: f32 = 1e-3;
/// Tops within this distance merge their floor flags.
const FLAG_MERGE: f32 = 0.01;

/// Bakes the navigation grid of `scene`.
pub fn build(scene: &Scene, params: &NavParams) -> Result<NavGrid, BuildError> {
    params.validate().map_err(BuildError::Params)?;
    let bbox = scene.bbox();
    if bbox.is_empty() || !bbox.is_finite() {
        return Err(BuildError::Scene {
            scene: scene.id.clone(),
            message: "no geometry to bake".into(),
        });
    }
    let cell = params.cell_size;
    let x0 = bbox.min.x - cell;
    let z0 = bbox.min.z - cell;
    let nx = ((bbox.max.x + cell - x0) / cell).ceil() as u64;
    let nz = ((bbox.max.z + cell - z0) / cell).ceil() as u64;
    if nx * nz > MAX_COLUMNS {
        return Err(BuildError::Scene {
            scene: scene.id.clone(),
            message: format!("{nx}x{nz} cells at {cell} m is too large"),
        });
    }
    let raster = RasterGrid {
        x0,
        z0,
        cell,
        nx: nx as u32,
        nz: nz as u32,
    };
    let (solids, object_solids) = rasterise(scene, &raster, params);
    let columns = (nx * nz) as usize;
    let (column_start, mut spans) = open_spans(solids, columns, params);
    link(&raster, &column_start, &mut spans, params, false);
    erode(&column_start, &mut spans, params, &raster);
    link(&raster, &column_start, &mut spans, params, true);
    let mut grid = NavGrid {
        scene: scene.id.clone(),
        params: *params,
        x0,
        z0,
        nx: raster.nx,
        nz: raster.nz,
        column_start,
        spans,
        rooms: Vec::new(),
        objects: Vec::new(),
        span_objects: Vec::new(),
        islands: Vec::new(),
        level_heights: scene
            .levels
            .iter()
            .map(|l| l.floor_heights.first().copied().unwrap_or(l.bbox.min.y))
            .collect(),
        baked: Default::default(),
    };
    assign_rooms(scene, &raster, &mut grid);
    assign_objects(scene, &object_solids, &mut grid);
    label_islands(&mut grid);
    Ok(grid)
}

/// Solid intervals of every triangle of the scene, and per object (by index in
/// `scene.objects()`) the solid intervals it occupies.
///
/// Furniture tops are not floors (the agent does not climb onto tables); stairs and objects
/// no thicker than the climb limit (rugs, mats) are.
fn rasterise(
    scene: &Scene,
    raster: &RasterGrid,
    params: &NavParams,
) -> (Vec<Solid>, Vec<(Solid, u32)>) {
    let cos_slope = params.max_slope_deg.to_radians().cos();
    let mut out = Vec::new();
    let surface = |mesh: &WorldMesh, may_be_floor: bool, out: &mut Vec<Solid>| {
        for t in mesh.indices.chunks_exact(3) {
            let tri = [
                mesh.positions[t[0] as usize],
                mesh.positions[t[1] as usize],
                mesh.positions[t[2] as usize],
            ];
            let floor = may_be_floor && is_floor(tri, cos_slope);
            raster.triangle(tri, |column, ymin, ymax| {
                out.push(Solid {
                    column,
                    ymin,
                    ymax,
                    floor,
                })
            });
        }
    };
    for level in &scene.levels {
        for room in &level.rooms {
            for s in &room.surfaces {
                // Only floors are floors: the top of a ceiling slab or of a wall is not.
                surface(
                    &scene.surface_world_mesh(s.mesh),
                    s.kind == SurfaceKind::Floor,
                    &mut out,
                );
            }
        }
        for &g in &level.ground {
            surface(&scene.surface_world_mesh(g), true, &mut out);
        }
    }
    // Objects: one solid interval per column, from the lowest to the highest point of the
    // object in that column; its top is a floor when the highest triangle there is.
    let mut pieces: Vec<Solid> = Vec::new();
    let mut by_object = Vec::new();
    let placed = scene.levels.iter().flat_map(|level| {
        level.objects.iter().map(move |o| {
            let base = o
                .rooms
                .first()
                .and_then(|&r| level.rooms.get(r as usize))
                .map(|r| r.floor_height)
                .or_else(|| level.floor_heights.first().copied())
                .unwrap_or(level.bbox.min.y);
            (o, base)
        })
    });
    for (index, (object, base)) in placed.enumerate() {
        let Some(mesh) = scene.object_world_mesh(object) else {
            continue;
        };
        // Stairs are walked on; so are objects lying on the floor no higher than a step.
        let walk_on = object.flags.stairs || object.bbox.max.y <= base + params.body.max_climb;
        pieces.clear();
        for t in mesh.indices.chunks_exact(3) {
            let tri = [
                mesh.positions[t[0] as usize],
                mesh.positions[t[1] as usize],
                mesh.positions[t[2] as usize],
            ];
            let floor = is_floor(tri, cos_slope);
            raster.triangle(tri, |column, ymin, ymax| {
                pieces.push(Solid {
                    column,
                    ymin,
                    ymax,
                    floor,
                })
            });
        }
        pieces.sort_by(|a, b| a.column.cmp(&b.column).then(a.ymax.total_cmp(&b.ymax)));
        let mut i = 0;
        while i < pieces.len() {
            let c = pieces[i].column;
            let mut j = i;
            let mut ymin = f32::INFINITY;
            while j < pieces.len() && pieces[j].column == c {
                ymin = ymin.min(pieces[j].ymin);
                j += 1;
            }
            let top = pieces[j - 1];
            // Several triangles may share the top (a box's top face and its sides' edges).
            let floor = walk_on
                && pieces[i..j]
                    .iter()
                    .any(|p| p.floor && (top.ymax - p.ymax).abs() <= FLAG_MERGE);
            let solid = Solid {
                column: c,
                ymin,
                ymax: top.ymax,
                floor,
            };
            out.push(solid);
            by_object.push((solid, index as u32));
            i = j;
        }
    }
    (out, by_object)
}

/// Merges the solids of each column and returns the open spans above floor tops with room
/// for the agent, in compressed column order.
fn open_spans(mut solids: Vec<Solid>, columns: usize, params: &NavParams) -> (Vec<u32>, Vec<Span>) {
    // Counting sort by column, then by bottom within each column.
    let mut start = vec![0u32; columns + 1];
    for s in &solids {
        start[s.column as usize + 1] += 1;
    }
    for c in 0..columns {
        start[c + 1] += start[c];
    }
    let mut sorted = vec![
        Solid {
            column: 0,
            ymin: 0.0,
            ymax: 0.0,
            floor: false
        };
        solids.len()
    ];
    let mut next = start.clone();
    for s in solids.drain(..) {
        let k = &mut next[s.column as usize];
        sorted[*k as usize] = s;
        *k += 1;
    }
    let mut column_start = Vec::with_capacity(columns + 1);
    let mut spans = Vec::new();
    let mut merged: Vec<Solid> = Vec::new();
    for c in 0..columns {
        column_start.push(spans.len() as u32);
        let list = &mut sorted[start[c] as usize..start[c + 1] as usize];
        if list.is_empty() {
            continue;
        }
        list.sort_by(|a, b| a.ymin.total_cmp(&b.ymin).then(a.ymax.total_cmp(&b.ymax)));
        merged.clear();
        for s in list.iter() {
            match merged.last_mut() {
                Some(m) if s.ymin <= m.ymax + MERGE_EPS => {
                    if s.ymax > m.ymax + FLAG_MERGE {
                        m.floor = s.floor;
                    } else if (s.ymax - m.ymax).abs() <= FLAG_MERGE {
                        m.floor |= s.floor;
                    }
                    m.ymax = m.ymax.max(s.ymax);
                }
                _ => merged.push(*s),
            }
        }
        for (k, m) in merged.iter().enumerate() {
            if !m.floor {
                continue;
            }
            let ceiling = merged.get(k + 1).map_or(f32::INFINITY, |n| n.ymin);
            let headroom = ceiling - m.ymax;
            if headroom >= params.body.height {
                spans.push(Span {
                    y: m.ymax,
                    headroom,
                    clearance: 0.0,
                    links: [NONE; 8],
                    walkable: true,
                    room: NONE,
                    island: NONE,
                    level: 0,
                });
            }
        }
    }
    column_start.push(spans.len() as u32);
    (column_start, spans)
}

/// The span of column `c` the agent can step to from a floor at `y` with `top` above it.
fn step_target(
    column_start: &[u32],
    spans: &[Span],
    c: usize,
    y: f32,
    top: f32,
    params: &NavParams,
    walkable_only: bool,
) -> u32 {
    let mut best = NONE;
    let mut best_dy = f32::INFINITY;
    let range = column_start[c] as usize..column_start[c + 1] as usize;
    for (t, s) in spans[range.clone()]
        .iter()
        .enumerate()
        .map(|(k, s)| (range.start + k, s))
    {
        if walkable_only && !s.walkable {
            continue;
        }
        let dy = (s.y - y).abs();
        let overlap = (s.y + s.headroom).min(top) - s.y.max(y);
        if dy <= params.body.max_climb + 1e-4 && overlap >= params.body.height && dy < best_dy {
            best = t as u32;
            best_dy = dy;
        }
    }
    best
}

/// Links every span to its neighbours (axis directions, then diagonals without corner
/// cutting). With `walkable_only`, links join walkable spans only.
fn link(
    raster: &RasterGrid,
    column_start: &[u32],
    spans: &mut [Span],
    params: &NavParams,
    walkable_only: bool,
) {
    let (nx, nz) = (raster.nx as i64, raster.nz as i64);
    for c in 0..(nx * nz) as usize {
        let (ix, iz) = ((c as i64) % nx, (c as i64) / nx);
        for s in column_start[c] as usize..column_start[c + 1] as usize {
            let mut links = [NONE; 8];
            if !walkable_only || spans[s].walkable {
                let (y, top) = (spans[s].y, spans[s].y + spans[s].headroom);
                for (d, (dx, dz)) in DIRS.iter().enumerate().take(4) {
                    let (jx, jz) = (ix + *dx as i64, iz + *dz as i64);
                    if jx >= 0 && jz >= 0 && jx < nx && jz < nz {
                        links[d] = step_target(
                            column_start,
                            spans,
                            (jz * nx + jx) as usize,
                            y,
                            top,
                            params,
                            walkable_only,
                        );
                    }
                }
            }
            spans[s].links = links;
        }
    }
    // Diagonals: s → a → t and s → b → t must both exist and reach the same span t.
    for s in 0..spans.len() {
        for (d, &(dx, dz)) in DIRS.iter().enumerate().skip(4) {
            let ax = DIRS.iter().position(|&v| v == (dx, 0)).unwrap_or(0);
            let az = DIRS.iter().position(|&v| v == (0, dz)).unwrap_or(1);
            let (a, b) = (spans[s].links[ax], spans[s].links[az]);
            let t = if a != NONE && b != NONE {
                let (t1, t2) = (spans[a as usize].links[az], spans[b as usize].links[ax]);
                if t1 == t2
                    && t1 != NONE
                    && (spans[t1 as usize].y - spans[s].y).abs() <= params.body.max_climb + 1e-4
                {
                    t1
                } else {
                    NONE
                }
            } else {
                NONE
            };
            spans[s].links[d] = t;
        }
    }
}

/// Distance from each span centre to the nearest edge of the standable area (a missing axis
/// link), by Dijkstra over links; spans closer than the agent radius are not walkable.
fn erode(_column_start: &[u32], spans: &mut [Span], params: &NavParams, raster: &RasterGrid) {
    use std::cmp::Reverse;
    use std::collections::BinaryHeap;
    let cell = raster.cell;
    let mut dist = vec![f32::INFINITY; spans.len()];
    let mut heap = BinaryHeap::new();
    for (i, s) in spans.iter().enumerate() {
        if s.links[..4].contains(&NONE) {
            dist[i] = 0.5 * cell;
            heap.push(Reverse((ordered(dist[i]), i as u32)));
        }
    }
    while let Some(Reverse((d, i))) = heap.pop() {
        let d = f32::from_bits(d);
        if d > dist[i as usize] {
            continue;
        }
        for (k, &n) in spans[i as usize].links.iter().enumerate() {
            if n == NONE {
                continue;
            }
            let step = if k < 4 {
                cell
            } else {
                cell * std::f32::consts::SQRT_2
            };
            let nd = d + step;
            if nd < dist[n as usize] {
                dist[n as usize] = nd;
                heap.push(Reverse((ordered(nd), n)));
            }
        }
    }
    for (s, d) in spans.iter_mut().zip(dist) {
        s.clearance = d;
        s.walkable = d + 1e-4 >= params.body.radius;
    }
}

/// Non-negative floats order like their bit patterns.
fn ordered(v: f32) -> u32 {
    v.max(0.0).to_bits()
}

/// Labels each span with the room whose floor region contains it: among rooms whose floor
/// covers the cell centre at or below the span, the one with the highest floor, and of those
/// the smallest (MINOS's rule).
fn assign_rooms(scene: &Scene, raster: &RasterGrid, grid: &mut NavGrid) {
    // (column, room index, floor height, area) for every cell centre a room floor covers.
    let mut cover: Vec<(u32, u32, f32, f32)> = Vec::new();
    for (li, level) in scene.levels.iter().enumerate() {
        for room in &level.rooms {
            let index = grid.rooms.len() as u32;
            grid.rooms.push(NavRoom {
                id: room.id.clone(),
                class: room.class.index(),
                level: li as u16,
            });
            let floors: Vec<WorldMesh> = room
                .surfaces
                .iter()
                .filter(|s| s.kind == SurfaceKind::Floor)
                .map(|s| scene.surface_world_mesh(s.mesh))
                .collect();
            if floors.is_empty() {
                // No floor mesh: the room's box stands for its floor.
                let (cx0, cz0) = cell_range_start(raster, room.bbox.min.x, room.bbox.min.z);
                let (cx1, cz1) = cell_range_start(raster, room.bbox.max.x, room.bbox.max.z);
                for iz in cz0..=cz1 {
                    for ix in cx0..=cx1 {
                        cover.push((iz * raster.nx + ix, index, room.floor_height, room.area));
                    }
                }
            }
            for mesh in floors {
                for t in mesh.indices.chunks_exact(3) {
                    let tri = [
                        mesh.positions[t[0] as usize],
                        mesh.positions[t[1] as usize],
                        mesh.positions[t[2] as usize],
                    ];
                    cover_centres(raster, tri, |column| {
                        cover.push((column, index, room.floor_height, room.area))
                    });
                }
            }
        }
    }
    cover.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.cmp(&b.1)));
    cover.dedup_by(|a, b| a.0 == b.0 && a.1 == b.1);
    let climb = grid.params.body.max_climb;
    let mut k = 0;
    for c in 0..(grid.nx * grid.nz) as usize {
        while k < cover.len() && (cover[k].0 as usize) < c {
            k += 1;
        }
        let mut end = k;
        while end < cover.len() && cover[end].0 as usize == c {
            end += 1;
        }
        for s in grid.column_spans(c) {
            let y = grid.spans[s].y;
            let best = cover[k..end]
                .iter()
                .filter(|(_, _, fh, _)| *fh <= y + climb)
                .max_by(|a, b| {
                    a.2.total_cmp(&b.2)
                        .then(b.3.total_cmp(&a.3))
                        .then(b.1.cmp(&a.1))
                });
            let span = &mut grid.spans[s];
            match best {
                Some(&(_, room, _, _)) => {
                    span.room = room;
                    span.level = grid.rooms[room as usize].level;
                }
                None => {
                    span.level = grid
                        .level_heights
                        .iter()
                        .rposition(|&h| h <= y + climb)
                        .unwrap_or(0) as u16;
                }
            }
        }
    }
}

fn cell_range_start(raster: &RasterGrid, x: f32, z: f32) -> (u32, u32) {
    let ix = ((x - raster.x0) / raster.cell)
        .floor()
        .clamp(0.0, (raster.nx - 1) as f32) as u32;
    let iz = ((z - raster.z0) / raster.cell)
        .floor()
        .clamp(0.0, (raster.nz - 1) as f32) as u32;
    (ix, iz)
}

/// Calls `f` for every column whose cell centre lies inside the triangle (in XZ).
fn cover_centres(raster: &RasterGrid, tri: [Vec3; 3], mut f: impl FnMut(u32)) {
    let (min, max) = (
        tri[0].min(tri[1]).min(tri[2]),
        tri[0].max(tri[1]).max(tri[2]),
    );
    let (cx0, cz0) = cell_range_start(raster, min.x, min.z);
    let (cx1, cz1) = cell_range_start(raster, max.x, max.z);
    let edge = |a: Vec3, b: Vec3, x: f32, z: f32| (b.x - a.x) * (z - a.z) - (b.z - a.z) * (x - a.x);
    let area = edge(tri[0], tri[1], tri[2].x, tri[2].z);
    if area == 0.0 {
        return;
    }
    for iz in cz0..=cz1 {
        let z = raster.z0 + (iz as f32 + 0.5) * raster.cell;
        for ix in cx0..=cx1 {
            let x = raster.x0 + (ix as f32 + 0.5) * raster.cell;
            let w = [
                edge(tri[0], tri[1], x, z),
                edge(tri[1], tri[2], x, z),
                edge(tri[2], tri[0], x, z),
            ];
            let inside = if area > 0.0 {
                w.iter().all(|v| *v >= 0.0)
            } else {
                w.iter().all(|v| *v <= 0.0)
            };
            if inside {
                f(iz * raster.nx + ix);
            }
        }
    }
}

/// Records every object, and the walkable spans each one's geometry lies directly above
/// (between the span's floor and the solid that bounds its headroom): a door's header marks
/// its doorway, a lamp hanging over the floor marks the floor under it.
fn assign_objects(scene: &Scene, object_solids: &[(Solid, u32)], grid: &mut NavGrid) {
    for object in scene.objects() {
        grid.objects.push(NavObject {
            id: object.id.clone(),
            category: object.categories.best().to_string(),
            door: object.flags.door,
            arch: object.flags.arch,
            min: object.bbox.min.to_array(),
            max: object.bbox.max.to_array(),
        });
    }
    let eps = 1e-3;
    for (solid, object) in object_solids {
        for s in grid.column_spans(solid.column as usize) {
            let span = &grid.spans[s];
            if span.walkable
                && solid.ymin >= span.y - eps
                && solid.ymin <= span.y + span.headroom + eps
            {
                grid.span_objects.push((s as u32, *object));
            }
        }
    }
    grid.span_objects.sort_unstable();
    grid.span_objects.dedup();
}
