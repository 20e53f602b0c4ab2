//! The CPU renderer: a z-buffer rasteriser with the same camera model, clipping and fill
//! rule (pixel centres, top-left) as the GPU path, and the choice between it and the ray
//! caster ([`super::raycast`]), which produce the same frames. The rasteriser's cost grows
//! with the triangles in the frustum, the ray caster's with the pixels (and only the
//! logarithm of the triangles), so [`render`] casts rays when the scene has at least
//! [`RAYCAST_TRIANGLES_PER_PIXEL`] triangles per pixel and rasterises otherwise. Clusters
//! outside the frustum are culled; large images are split into row bands rendered in parallel
//! (rayon), and batches of cameras render in parallel too.

use glam::{Vec3, Vec4};
use rayon::prelude::*;

use super::camera::Camera;
use super::frame::Frame;
use super::raycast;
use super::scene::RenderScene;

/// Scenes with at least this many triangles per pixel of the image are ray cast, smaller
/// ones rasterised: at or above where the two cost the same on one core at 84² (`cargo
/// bench --bench render`, "Rendering at scale" in docs/PERFORMANCE.md: the ray caster is
/// ahead from 0.5 triangles per pixel on the dense multi-room house and from between 1.1
/// and 4.5 in the single dense room). The generated houses (3.6k triangles) stay
/// rasterised from 30² up.
pub const RAYCAST_TRIANGLES_PER_PIXEL: f32 = 4.0;

/// Images at least this many pixels are split into bands rendered in parallel.
const PARALLEL_PIXELS: u32 = 256 * 256;
/// Rows per band.
const BAND: u32 = 32;

/// A triangle in screen space: pixel coordinates and depth-buffer values.
#[derive(Clone, Copy)]
struct ScreenTri {
    p: [[f32; 2]; 3],
    z: [f32; 3],
    id: u32,
}

/// Which CPU method renders `camera` on `scene`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// The z-buffer rasteriser.
    Rasterise,
    /// The BVH ray caster.
    RayCast,
}

impl Method {
    /// The faster method for this scene and image size.
    pub fn choose(scene: &RenderScene, camera: &Camera) -> Method {
        Method::for_size(scene.triangle_count(), camera.width, camera.height)
    }

    /// The faster method for a scene of `triangles` at `width` × `height` pixels.
    pub fn for_size(triangles: usize, width: u32, height: u32) -> Method {
        let pixels = width as f32 * height as f32;
        if triangles as f32 >= RAYCAST_TRIANGLES_PER_PIXEL * pixels {
            Method::RayCast
        } else {
            Method::Rasterise
        }
    }
}

/// Renders one camera with the faster method (see [`Method::choose`]); both give the same
/// frame up to edge pixels and rounding.
pub fn render(scene: &RenderScene, camera: &Camera) -> Frame {
    match Method::choose(scene, camera) {
        Method::Rasterise => rasterise(scene, camera),
        Method::RayCast => raycast::render(scene, camera),
    }
}

/// Renders one camera with the rasteriser.
pub fn rasterise(scene: &RenderScene, camera: &Camera) -> Frame {
    let tris = project(scene, camera);
    let mut frame = Frame::new(camera.width, camera.height);
    let (w, h) = (camera.width, camera.height);
    if w * h >= PARALLEL_PIXELS {
        let width = w as usize;
        frame
            .tri
            .par_chunks_mut(width * BAND as usize)
            .zip(frame.depth.par_chunks_mut(width * BAND as usize))
            .enumerate()
            .for_each(|(band, (ids, depth))| {
                let y0 = band as u32 * BAND;
                raster(&tris, w, y0, (y0 + BAND).min(h), ids, depth);
            });
    } else {
        let (ids, depth) = (&mut frame.tri, &mut frame.depth);
        raster(&tris, w, 0, h, ids, depth);
    }
    frame
}

/// Renders several cameras in parallel.
#[cfg(feature = "internals")]
pub fn render_batch(scene: &RenderScene, cameras: &[Camera]) -> Vec<Frame> {
    cameras.par_iter().map(|c| render(scene, c)).collect()
}

/// Culls, transforms, clips against the near plane and maps to pixels.
fn project(scene: &RenderScene, camera: &Camera) -> Vec<ScreenTri> {
    let vp = camera.view_projection();
    let planes = camera.frustum_planes();
    let (w, h) = (camera.width as f32, camera.height as f32);
    let mut out = Vec::new();
    for cluster in &scene.clusters {
        let b = cluster.bbox;
        let outside = planes.iter().any(|p| {
            (0..8).all(|i| {
                let c = Vec3::new(
                    if i & 1 == 0 { b.min.x } else { b.max.x },
                    if i & 2 == 0 { b.min.y } else { b.max.y },
                    if i & 4 == 0 { b.min.z } else { b.max.z },
                );
                p.dot(c.extend(1.0)) < 0.0
            })
        });
        if outside {
            continue;
        }
        for t in cluster.start..cluster.end {
            let [a, b, c] = scene.triangle(t as usize);
            let clip = [vp * a.extend(1.0), vp * b.extend(1.0), vp * c.extend(1.0)];
            // Trivially outside one of the side planes?
            if clip.iter().all(|v| v.x < -v.w)
                || clip.iter().all(|v| v.x > v.w)
                || clip.iter().all(|v| v.y < -v.w)
                || clip.iter().all(|v| v.y > v.w)
                || clip.iter().all(|v| v.z > v.w)
            {
                continue;
            }
            let mut poly: [Vec4; 4] = [Vec4::ZERO; 4];
            let n = clip_near(&clip, &mut poly);
            let to_screen = |v: Vec4| {
                let inv = 1.0 / v.w;
                (
                    [(v.x * inv + 1.0) * 0.5 * w, (1.0 - v.y * inv) * 0.5 * h],
                    v.z * inv,
                )
            };
            for k in 1..n.saturating_sub(1) {
                let (p0, z0) = to_screen(poly[0]);
                let (p1, z1) = to_screen(poly[k]);
                let (p2, z2) = to_screen(poly[k + 1]);
                out.push(ScreenTri {
                    p: [p0, p1, p2],
                    z: [z0, z1, z2],
                    id: t,
                });
            }
        }
    }
    out
}

/// Clips a clip-space triangle against z ≥ 0 (the near plane); returns the vertex count.
fn clip_near(tri: &[Vec4; 3], out: &mut [Vec4; 4]) -> usize {
    let mut n = 0;
    for i in 0..3 {
        let (a, b) = (tri[i], tri[(i + 1) % 3]);
        let (da, db) = (a.z, b.z);
        if da >= 0.0 {
            out[n] = a;
            n += 1;
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            out[n] = a + (b - a) * t;
            n += 1;
        }
    }
    n
}

/// Edge function: twice the signed area of (a, b, p).
#[inline]
fn edge(a: [f32; 2], b: [f32; 2], p: [f32; 2]) -> f32 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// Top-left rule for an edge a→b of a triangle with positive area in this (y-down) space.
#[inline]
fn top_left(a: [f32; 2], b: [f32; 2]) -> bool {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    (dy == 0.0 && dx < 0.0) || dy > 0.0
}

/// Bounding boxes narrower than this (pixels) are tested whole: solving a row's span
/// ([`RowSpans`]) costs about as much as the tests it would save.
const SPAN_MIN_WIDTH: i64 = 12;

/// Where a triangle `p` (positive area) can cover pixels along a row: per edge, its start
/// `a`, direction `(dx, dy)` and how far the box `minx..=maxx` reaches from `a.x` — what
/// [`RowSpans::at`] needs on every row, worked out once per triangle.
struct RowSpans {
    edges: [([f32; 2], f32, f32, f32); 3],
    minx: i64,
    maxx: i64,
}

impl RowSpans {
    fn new(p: &[[f32; 2]; 3], minx: i64, maxx: i64) -> Self {
        let edge = |a: [f32; 2], b: [f32; 2]| {
            let reach = (minx as f32 + 0.5 - a[0])
                .abs()
                .max((maxx as f32 + 0.5 - a[0]).abs());
            (a, b[0] - a[0], b[1] - a[1], reach)
        };
        RowSpans {
            edges: [edge(p[1], p[2]), edge(p[2], p[0]), edge(p[0], p[1])],
            minx,
            maxx,
        }
    }

    /// The pixels `xs..=xe` of the row whose centres lie at `py` that may be inside the
    /// triangle — `minx..=maxx` narrowed to where every edge function can be ≥ 0 —, or
    /// `None` when no pixel can be. The exact per-pixel test still decides each pixel: the
    /// span is widened by one pixel and by a bound on the rounding of both the test and this
    /// solution, so it never leaves out a pixel the test would keep, and frames are the same
    /// bits as testing the whole bounding box (for about half the tests on a typical
    /// triangle).
    fn at(&self, py: f32) -> Option<(i64, i64)> {
        let (mut lo, mut hi) = (self.minx as f32, self.maxx as f32);
        for &(a, dx, dy, reach) in &self.edges {
            // edge(a, b, q) = dx (py − a.y) − dy (q.x − a.x): its sign along the row changes
            // where q.x = a.x + c / dy.
            let c = dx * (py - a[1]);
            if dy == 0.0 {
                // Constant along the row (the test computes exactly `c`).
                if c < 0.0 {
                    return None;
                }
                continue;
            }
            let cross = a[0] + c / dy;
            let slack = 1.0 + 8.0 * f32::EPSILON * ((c / dy).abs() + a[0].abs() + reach);
            // Pixel x's centre is x + 0.5.
            if dy > 0.0 {
                hi = hi.min(cross - 0.5 + slack);
            } else {
                lo = lo.max(cross - 0.5 - slack);
            }
        }
        let (xs, xe) = (
            lo.floor().max(self.minx as f32),
            hi.ceil().min(self.maxx as f32),
        );
        // NaN bounds (from infinite coordinates) compare false: the whole box then.
        if xs > xe {
            return None;
        }
        Some((xs as i64, xe as i64))
    }
}

/// A triangle ready to rasterise into rows `y0..y1` of an image `width` wide: its vertices
/// and depths in counter-clockwise order (positive `area`, twice the signed area) and its
/// pixel bounding box, clipped to the rows and the image.
struct Setup {
    p: [[f32; 2]; 3],
    z: [f32; 3],
    area: f32,
    minx: i64,
    maxx: i64,
    miny: i64,
    maxy: i64,
}

impl Setup {
    /// `None` for a degenerate triangle or one outside the rows.
    fn of(t: &ScreenTri, width: u32, y0: u32, y1: u32) -> Option<Setup> {
        let (mut p, mut z) = (t.p, t.z);
        let mut area = edge(p[0], p[1], p[2]);
        if area == 0.0 || !area.is_finite() {
            return None;
        }
        if area < 0.0 {
            p.swap(1, 2);
            z.swap(1, 2);
            area = -area;
        }
        let lo = |k: usize| p.iter().map(|v| v[k]).fold(f32::INFINITY, f32::min).floor();
        let hi = |k: usize| {
            p.iter()
                .map(|v| v[k])
                .fold(f32::NEG_INFINITY, f32::max)
                .ceil()
        };
        let (minx, maxx) = (lo(0).max(0.0) as i64, (hi(0) as i64).min(width as i64 - 1));
        let (miny, maxy) = (
            (lo(1) as i64).max(y0 as i64),
            (hi(1) as i64).min(y1 as i64 - 1),
        );
        (minx <= maxx && miny <= maxy).then_some(Setup {
            p,
            z,
            area,
            minx,
            maxx,
            miny,
            maxy,
        })
    }
}

/// Rasterises `tris` into rows `y0..y1` (buffers hold those rows only).
fn raster(tris: &[ScreenTri], width: u32, y0: u32, y1: u32, ids: &mut [u32], depth: &mut [f32]) {
    for t in tris {
        let Some(Setup {
            p,
            z,
            area,
            minx,
            maxx,
            miny,
            maxy,
        }) = Setup::of(t, width, y0, y1)
        else {
            continue;
        };
        let tl = [
            top_left(p[1], p[2]),
            top_left(p[2], p[0]),
            top_left(p[0], p[1]),
        ];
        let inv_area = 1.0 / area;
        let spans = (maxx - minx >= SPAN_MIN_WIDTH).then(|| RowSpans::new(&p, minx, maxx));
        for y in miny..=maxy {
            let py = y as f32 + 0.5;
            let (xs, xe) = match &spans {
                None => (minx, maxx),
                Some(spans) => match spans.at(py) {
                    Some(span) => span,
                    None => continue,
                },
            };
            let row = ((y as u32 - y0) * width) as usize;
            for x in xs..=xe {
                let q = [x as f32 + 0.5, py];
                let w0 = edge(p[1], p[2], q);
                let w1 = edge(p[2], p[0], q);
                let w2 = edge(p[0], p[1], q);
                let inside = (w0 > 0.0 || (w0 == 0.0 && tl[0]))
                    && (w1 > 0.0 || (w1 == 0.0 && tl[1]))
                    && (w2 > 0.0 || (w2 == 0.0 && tl[2]));
                if !inside {
                    continue;
                }
                let d = (w0 * z[0] + w1 * z[1] + w2 * z[2]) * inv_area;
                let i = row + x as usize;
                if (0.0..=1.0).contains(&d) && d < depth[i] {
                    depth[i] = d;
                    ids[i] = t.id;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seed::Rng;

    /// The rasteriser before row spans: every pixel of the bounding box tested (the same
    /// triangle set-up).
    fn raster_box(
        tris: &[ScreenTri],
        width: u32,
        y0: u32,
        y1: u32,
        ids: &mut [u32],
        depth: &mut [f32],
    ) {
        for t in tris {
            let Some(s) = Setup::of(t, width, y0, y1) else {
                continue;
            };
            let (p, z) = (s.p, s.z);
            let tl = [(1, 2), (2, 0), (0, 1)].map(|(a, b)| top_left(p[a], p[b]));
            for y in s.miny..=s.maxy {
                for x in s.minx..=s.maxx {
                    let q = [x as f32 + 0.5, y as f32 + 0.5];
                    let w = [
                        edge(p[1], p[2], q),
                        edge(p[2], p[0], q),
                        edge(p[0], p[1], q),
                    ];
                    if !(0..3).all(|k| w[k] > 0.0 || (w[k] == 0.0 && tl[k])) {
                        continue;
                    }
                    let d = (w[0] * z[0] + w[1] * z[1] + w[2] * z[2]) * (1.0 / s.area);
                    let i = ((y as u32 - y0) * width) as usize + x as usize;
                    if (0.0..=1.0).contains(&d) && d < depth[i] {
                        depth[i] = d;
                        ids[i] = t.id;
                    }
                }
            }
        }
    }

    /// A random screen-space triangle of one of the shapes that stress the row spans.
    fn triangle(rng: &mut Rng, id: u32) -> ScreenTri {
        let mut f = |lo: f32, hi: f32| rng.range_f64(f64::from(lo), f64::from(hi)) as f32;
        let kind = id % 6;
        let mut p = [[0.0f32; 2]; 3];
        for v in &mut p {
            *v = match kind {
                // On screen, anywhere.
                0 | 1 => [f(-8.0, 72.0), f(-8.0, 72.0)],
                // Far off screen (a vertex behind a near-plane clip projects far away).
                2 => [f(-1.0e6, 1.0e6), f(-1.0e6, 1.0e6)],
                // Pixel-centre and pixel-edge coordinates: ties on the fill rule.
                3 => [
                    (f(0.0, 64.0) as i32) as f32 + 0.5 * (id % 2) as f32,
                    (f(0.0, 64.0) as i32) as f32 + 0.5,
                ],
                _ => [f(-200.0, 264.0), f(-200.0, 264.0)],
            };
        }
        if kind == 4 {
            // Nearly horizontal edges: one vertex a hair off another's row.
            p[1][1] = p[0][1] + f(-1.0e-3, 1.0e-3);
        }
        if kind == 5 {
            p[1][1] = p[0][1];
        }
        let z = [f(0.0, 1.0), f(0.0, 1.0), f(0.0, 1.0)];
        ScreenTri { p, z, id }
    }

    #[test]
    fn row_spans_give_the_bounding_box_tests_bits() {
        let mut rng = Rng::new(7);
        let (w, h) = (64u32, 64u32);
        for round in 0..200 {
            let tris: Vec<ScreenTri> = (0..40)
                .map(|k| triangle(&mut rng, round * 40 + k))
                .collect();
            let (mut ids_a, mut depth_a) = (
                vec![u32::MAX; (w * h) as usize],
                vec![f32::INFINITY; (w * h) as usize],
            );
            let (mut ids_b, mut depth_b) = (ids_a.clone(), depth_a.clone());
            raster(&tris, w, 0, h, &mut ids_a, &mut depth_a);
            raster_box(&tris, w, 0, h, &mut ids_b, &mut depth_b);
            assert_eq!(ids_a, ids_b, "round {round}: ids differ");
            let bits = |d: &[f32]| d.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(&depth_a),
                bits(&depth_b),
                "round {round}: depth differs"
            );
            // The rounds draw something: the test compares frames, not two empty buffers.
            if round == 0 {
                assert!(ids_a.iter().filter(|&&i| i != u32::MAX).count() > 100);
            }
        }
    }
}
