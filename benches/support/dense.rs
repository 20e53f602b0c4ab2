//! Dense render scenes made from a generated house, for measuring renderers at scan scale
//! until scan-like houses are generated: every triangle split into n² smaller ones (same
//! plane, attributes and texture mapping, so images stay the same) plus random clutter boxes
//! standing on upward-facing surfaces.

use glam::Vec3;
use minos::render::scene::{Cluster, TriInfo, UvMap, NO_TEXTURE};
use minos::render::RenderScene;
use minos::scene::Aabb;
use minos::seed::Rng;

/// Triangles of one clutter box.
const BOX_TRIS: usize = 12;

/// `base` restricted to the triangles of room `room` (its surfaces and objects): a single
/// room to make dense.
pub fn single_room(base: &RenderScene, room: u32) -> RenderScene {
    let keep: Vec<usize> = (0..base.triangle_count())
        .filter(|&t| base.tris[t].room == room)
        .collect();
    let mut out = RenderScene::default();
    out.textures = base.textures.clone();
    let mut bbox = Aabb::EMPTY;
    for &t in &keep {
        for k in 0..3 {
            out.positions.push(base.positions[3 * t + k]);
            out.uvs.push(base.uvs[3 * t + k]);
            bbox.grow(base.positions[3 * t + k]);
        }
        out.tris.push(base.tris[t]);
        out.uv_maps.push(base.uv_maps[t]);
    }
    out.clusters.push(Cluster {
        bbox,
        start: 0,
        end: out.tris.len() as u32,
    });
    out
}

/// `base` with `boxes` clutter boxes added and then every triangle split so that the scene
/// has about `target` triangles (at least `base`'s).
pub fn densify(base: &RenderScene, boxes: usize, target: usize, seed: u64) -> RenderScene {
    let cluttered = clutter(base, boxes, seed);
    let n = ((target as f64 / cluttered.triangle_count().max(1) as f64)
        .sqrt()
        .round() as usize)
        .max(1);
    subdivide(&cluttered, n)
}

/// `base` made dense to about `target` triangles less those of `boxes` clutter boxes, then
/// filled with the boxes (12 triangles each, not split): a room of many small objects, the
/// kind of scene where boxes overlap and a BVH's nodes do too (`densify` splits the boxes
/// with the surfaces, which keeps each node small).
pub fn cluttered(base: &RenderScene, boxes: usize, target: usize, seed: u64) -> RenderScene {
    let surfaces = target.saturating_sub(boxes * BOX_TRIS);
    let n = ((surfaces as f64 / base.triangle_count().max(1) as f64)
        .sqrt()
        .round() as usize)
        .max(1);
    clutter(&subdivide(base, n), boxes, seed)
}

/// Adds `boxes` boxes (10–40 cm) on random upward-facing triangles, each its own object.
fn clutter(base: &RenderScene, boxes: usize, seed: u64) -> RenderScene {
    let mut out = base.clone();
    let up: Vec<usize> = (0..base.triangle_count())
        .filter(|&t| base.tris[t].normal[1] > 0.9)
        .collect();
    if up.is_empty() {
        return out;
    }
    let mut rng = Rng::new(seed);
    let next_object = base.tris.iter().map(|t| t.object).max().unwrap_or(0) + 1;
    for b in 0..boxes {
        let t = up[rng.below(up.len())];
        let [p0, p1, p2] = base.triangle(t);
        let (r1, r2) = (
            rng.range_f64(0.0, 1.0) as f32,
            rng.range_f64(0.0, 1.0) as f32,
        );
        let (r1, r2) = if r1 + r2 > 1.0 {
            (1.0 - r1, 1.0 - r2)
        } else {
            (r1, r2)
        };
        let foot = p0 + (p1 - p0) * r1 + (p2 - p0) * r2;
        let size = Vec3::new(
            rng.range_f64(0.1, 0.4) as f32,
            rng.range_f64(0.1, 0.4) as f32,
            rng.range_f64(0.1, 0.4) as f32,
        );
        let lo = foot - Vec3::new(size.x / 2.0, 0.0, size.z / 2.0);
        let hi = lo + size;
        let info = TriInfo {
            color: [
                rng.range_f64(0.2, 0.9) as f32,
                rng.range_f64(0.2, 0.9) as f32,
                rng.range_f64(0.2, 0.9) as f32,
            ],
            texture: NO_TEXTURE,
            object: next_object + b as u32,
            nyu40: 39,
            mpcat40: 39,
            coarse: base.tris[t].coarse,
            ..base.tris[t]
        };
        let start = out.tris.len() as u32;
        let corner = |i: usize| Vec3::from(minos::scene::box_corner(lo.into(), hi.into(), i));
        for q in minos::scene::BOX_FACES {
            for tri in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
                let p = tri.map(corner);
                let normal = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
                out.positions.extend(p);
                out.uvs.extend([[0.0; 2]; 3]);
                out.uv_maps.push(UvMap::default());
                out.tris.push(TriInfo {
                    normal: normal.to_array(),
                    ..info
                });
            }
        }
        out.clusters.push(Cluster {
            bbox: Aabb { min: lo, max: hi },
            start,
            end: start + BOX_TRIS as u32,
        });
    }
    // A fresh scene (no BVH cached for the old triangles).
    let mut fresh = RenderScene::default();
    fresh.positions = out.positions;
    fresh.uvs = out.uvs;
    fresh.tris = out.tris;
    fresh.textures = out.textures;
    fresh.uv_maps = out.uv_maps;
    fresh.clusters = out.clusters;
    fresh
}

/// Every triangle split into n² (a barycentric grid), in place of the original, so clusters
/// keep their boxes and stay contiguous.
fn subdivide(base: &RenderScene, n: usize) -> RenderScene {
    let mut out = RenderScene::default();
    out.textures = base.textures.clone();
    let per = (n * n) as u32;
    for t in 0..base.triangle_count() {
        let p = base.triangle(t);
        let uv = [base.uvs[3 * t], base.uvs[3 * t + 1], base.uvs[3 * t + 2]];
        // Grid point (i, j): i steps along p0→p1, j along p0→p2, i + j ≤ n.
        let at = |i: usize, j: usize| {
            let (a, b) = (i as f32 / n as f32, j as f32 / n as f32);
            (
                p[0] + (p[1] - p[0]) * a + (p[2] - p[0]) * b,
                [
                    uv[0][0] + (uv[1][0] - uv[0][0]) * a + (uv[2][0] - uv[0][0]) * b,
                    uv[0][1] + (uv[1][1] - uv[0][1]) * a + (uv[2][1] - uv[0][1]) * b,
                ],
            )
        };
        let mut push = |c: [(Vec3, [f32; 2]); 3]| {
            for (pos, uv) in c {
                out.positions.push(pos);
                out.uvs.push(uv);
            }
            out.tris.push(base.tris[t]);
            out.uv_maps.push(base.uv_maps[t]);
        };
        for i in 0..n {
            for j in 0..n - i {
                push([at(i, j), at(i + 1, j), at(i, j + 1)]);
                if i + j + 1 < n {
                    push([at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
                }
            }
        }
    }
    out.clusters = base
        .clusters
        .iter()
        .map(|c| Cluster {
            bbox: c.bbox,
            start: c.start * per,
            end: c.end * per,
        })
        .collect();
    out
}
