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

/// Rasterises `tris` into rows `y0..y1` (buffers hold those rows only).
fn raster(tris: &[ScreenTri], width: u32, y0: u32, y1: u32, ids: &mut [u32], depth: &mut [f32]) {
    for t in tris {
        let mut p = t.p;
        let mut z = t.z;
        let mut area = edge(p[0], p[1], p[2]);
        if area == 0.0 || !area.is_finite() {
            continue;
        }
        if area < 0.0 {
            p.swap(1, 2);
            z.swap(1, 2);
            area = -area;
        }
        let minx = p
            .iter()
            .map(|v| v[0])
            .fold(f32::INFINITY, f32::min)
            .floor()
            .max(0.0) as i64;
        let maxx = (p
            .iter()
            .map(|v| v[0])
            .fold(f32::NEG_INFINITY, f32::max)
            .ceil() as i64)
            .min(width as i64 - 1);
        let miny =
            (p.iter().map(|v| v[1]).fold(f32::INFINITY, f32::min).floor() as i64).max(y0 as i64);
        let maxy = (p
            .iter()
            .map(|v| v[1])
            .fold(f32::NEG_INFINITY, f32::max)
            .ceil() as i64)
            .min(y1 as i64 - 1);
        if minx > maxx || miny > maxy {
            continue;
        }
        let tl = [
            top_left(p[1], p[2]),
            top_left(p[2], p[0]),
            top_left(p[0], p[1]),
        ];
        let inv_area = 1.0 / area;
        for y in miny..=maxy {
            let py = y as f32 + 0.5;
            let row = ((y as u32 - y0) * width) as usize;
            for x in minx..=maxx {
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
