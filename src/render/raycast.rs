//! The CPU ray caster: one primary ray per pixel centre through the scene's BVH
//! (`bvh`), producing the same [`Frame`] as the rasteriser — the nearest triangle's
//! id and its depth-buffer value — so every image derived from it is shaded, textured and
//! labelled in one place ([`Frame`]'s methods). Its cost grows with the pixels and the
//! logarithm of the triangles, where the rasteriser's grows with every triangle in the
//! frustum, so it is the faster one on large scenes and small images.
//!
//! Same rules as the rasteriser: a pixel shows the triangle nearest along its centre's ray
//! with camera-space depth in `[near, far]` (the ray parameter is that depth, the direction
//! having unit length along the viewing axis), both faces count, and the depth-buffer value
//! is the perspective projection's `z/w` of that depth. Pixels are cast in 4×4 tiles of 2×2
//! packets (four rays traced together, `bvh::Packet`; the answer is each ray's
//! nearest hit, ties to the lowest id, whatever the order or grouping), and large images are
//! split into bands rendered in parallel, so frames are identical for any thread count.

use rayon::prelude::*;

use super::bvh::{Bvh, Packet, PacketStack};
use super::camera::Camera;
use super::frame::{Frame, PixelRays};
use super::scene::RenderScene;

/// Images at least this many pixels are split into bands rendered in parallel.
const PARALLEL_PIXELS: u32 = 256 * 256;
/// Edge of the square tiles pixels are cast in.
const TILE: u32 = 4;
/// Rows per band (a multiple of [`TILE`]).
const BAND: u32 = 32;

/// Renders one camera by ray casting (the scene's BVH is built on first use).
pub fn render(scene: &RenderScene, camera: &Camera) -> Frame {
    let bvh = scene.bvh();
    let (w, h) = (camera.width, camera.height);
    let mut frame = Frame::new(w, h);
    if w == 0 || h == 0 || bvh.triangle_count() == 0 {
        return frame;
    }
    let rays = PixelRays::new(camera, w, h);
    let cast = Cast::new(bvh, &rays, camera);
    if w * h >= PARALLEL_PIXELS {
        let width = w as usize;
        frame
            .tri
            .par_chunks_mut(width * BAND as usize)
            .zip(frame.depth.par_chunks_mut(width * BAND as usize))
            .enumerate()
            .for_each(|(band, (ids, depth))| {
                let y0 = band as u32 * BAND;
                cast.rows(w, y0, (y0 + BAND).min(h), ids, depth);
            });
    } else {
        cast.rows(w, 0, h, &mut frame.tri, &mut frame.depth);
    }
    frame
}

/// Renders several cameras in parallel.
#[cfg(feature = "internals")]
pub fn render_batch(scene: &RenderScene, cameras: &[Camera]) -> Vec<Frame> {
    cameras.par_iter().map(|c| render(scene, c)).collect()
}

/// What every ray of one camera shares.
struct Cast<'a> {
    bvh: &'a Bvh,
    rays: &'a PixelRays,
    camera: &'a Camera,
    /// The projection's depth row: `z_clip = a·z_view + b`, `w_clip = −z_view`.
    a: f32,
    b: f32,
}

impl<'a> Cast<'a> {
    fn new(bvh: &'a Bvh, rays: &'a PixelRays, camera: &'a Camera) -> Self {
        let p = camera.projection();
        Cast {
            bvh,
            rays,
            camera,
            a: p.z_axis.z,
            b: p.w_axis.z,
        }
    }

    /// Casts rows `y0..y1` (buffers hold those rows only): tile by tile, each tile as
    /// 2×2 packets.
    fn rows(&self, width: u32, y0: u32, y1: u32, ids: &mut [u32], depth: &mut [f32]) {
        let (near, far) = (self.camera.near, self.camera.far);
        let mut stack = PacketStack::default();
        for ty in (y0..y1).step_by(TILE as usize) {
            for tx in (0..width).step_by(TILE as usize) {
                for py in (ty..(ty + TILE).min(y1)).step_by(2) {
                    for px in (tx..(tx + TILE).min(width)).step_by(2) {
                        // Lane i is pixel (px + i % 2, py + i / 2); lanes off the image
                        // repeat lane 0 and are not written.
                        let pixel = |i: u32| {
                            let (x, y) = (px + i % 2, py + i / 2);
                            (x < width && y < y1).then_some((x, y))
                        };
                        let dirs = std::array::from_fn(|i| {
                            let (x, y) = pixel(i as u32).unwrap_or((px, py));
                            self.rays.dir(x as usize, y as usize)
                        });
                        let packet = Packet::new(self.camera.position, dirs, near, far);
                        let hits = self.bvh.closest_packet(&packet, &mut stack);
                        for (i, hit) in hits.iter().enumerate() {
                            let (Some(hit), Some((x, y))) = (hit, pixel(i as u32)) else {
                                continue;
                            };
                            let p = ((y - y0) * width + x) as usize;
                            ids[p] = hit.tri;
                            // z/w of the projection at view depth t (view z = −t).
                            depth[p] = ((self.b - self.a * hit.t) / hit.t).clamp(0.0, 1.0);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::render::cpu;
    use crate::render::frame::NO_HIT;
    use crate::render::scene::{Cluster, TriInfo, UvMap, NO_TEXTURE};
    use crate::scene::Aabb;

    /// A render scene of bare triangles (object = triangle index + 1).
    fn soup(triangles: &[[Vec3; 3]]) -> RenderScene {
        let mut s = RenderScene::default();
        let mut bbox = Aabb::EMPTY;
        for (i, t) in triangles.iter().enumerate() {
            for p in t {
                s.positions.push(*p);
                s.uvs.push([0.0; 2]);
                bbox.grow(*p);
            }
            s.uv_maps.push(UvMap::default());
            s.tris.push(TriInfo {
                normal: (t[1] - t[0])
                    .cross(t[2] - t[0])
                    .try_normalize()
                    .unwrap_or(Vec3::Y)
                    .to_array(),
                color: [0.5; 3],
                texture: NO_TEXTURE,
                object: i as u32 + 1,
                room: 1,
                room_class: 0,
                nyu40: 1,
                mpcat40: 1,
                coarse: 1,
            });
        }
        s.clusters.push(Cluster {
            bbox,
            start: 0,
            end: triangles.len() as u32,
        });
        s
    }

    /// The six faces of a box as twelve outward triangles.
    fn cube(lo: Vec3, hi: Vec3) -> Vec<[Vec3; 3]> {
        let c = |i: usize| Vec3::from(crate::scene::box_corner(lo.into(), hi.into(), i));
        crate::scene::BOX_FACES
            .iter()
        .flat_map(|q| [[c(q[0]), c(q[1]), c(q[2])], [c(q[0]), c(q[2]), c(q[3])]])
        .collect()
    }

    fn camera(position: Vec3, size: u32) -> Camera {
        Camera {
            position,
            yaw: 0.4,
            tilt: -0.1,
            vfov_deg: 70.0,
            width: size,
            height: size,
            near: 0.05,
            far: 20.0,
        }
    }

    #[test]
    fn an_empty_scene_renders_nothing() {
        let frame = render(&RenderScene::default(), &camera(Vec3::ZERO, 16));
        assert!(frame.tri.iter().all(|&t| t == NO_HIT));
        assert!(frame.depth.iter().all(|&d| d == 1.0));
        let zero = camera(Vec3::ZERO, 0);
        assert_eq!(
            render(&soup(&cube(Vec3::ZERO, Vec3::ONE)), &zero).tri.len(),
            0
        );
    }

    #[test]
    fn inside_a_box_every_pixel_sees_a_wall_at_the_rasterisers_depth() {
        let scene = soup(&cube(Vec3::splat(-2.0), Vec3::splat(2.0)));
        let cam = camera(Vec3::new(0.3, 0.2, -0.4), 32);
        let (ray, raster) = (render(&scene, &cam), cpu::rasterise(&scene, &cam));
        assert!(ray.tri.iter().all(|&t| t != NO_HIT), "closed room: no hole");
        let (dr, dz) = (ray.linear_depth(&cam), raster.linear_depth(&cam));
        for p in 0..dr.len() {
            assert!(dr[p] >= cam.near && dr[p] <= 4.0 * 3f32.sqrt());
            assert!(
                (dr[p] - dz[p]).abs() < 1e-3 * dz[p],
                "pixel {p}: {} vs {}",
                dr[p],
                dz[p]
            );
        }
        // Walls of one face are two triangles: only the diagonal may differ.
        let faces_equal = ray
            .tri
            .iter()
            .zip(&raster.tri)
            .filter(|(a, b)| **a / 2 == **b / 2)
            .count();
        assert_eq!(faces_equal, ray.tri.len());
    }

    #[test]
    fn geometry_inside_the_near_plane_or_beyond_far_is_not_seen_and_degenerates_are_skipped() {
        let eye = Vec3::ZERO;
        let cam = Camera {
            yaw: 0.0,
            tilt: 0.0,
            ..camera(eye, 8)
        };
        let wall = |z: f32| {
            [[
                Vec3::new(-9.0, -9.0, z),
                Vec3::new(9.0, -9.0, z),
                Vec3::new(0.0, 9.0, z),
            ]]
        };
        // A triangle closer than near, one beyond far, a point and a line.
        let mut tris = vec![wall(-0.01)[0], wall(-30.0)[0]];
        let p = Vec3::new(0.0, 0.0, -1.0);
        tris.push([p, p, p]);
        tris.push([p, p + Vec3::X, p + Vec3::X * 2.0]);
        let frame = render(&soup(&tris), &cam);
        assert!(frame.tri.iter().all(|&t| t == NO_HIT));
        // A wall at 5 m is seen at 5 m across the image.
        tris.push(wall(-5.0)[0]);
        let frame = render(&soup(&tris), &cam);
        let depth = frame.linear_depth(&cam);
        for (t, d) in frame.tri.iter().zip(&depth) {
            if *t != NO_HIT {
                assert_eq!(*t, 4);
                assert!((d - 5.0).abs() < 1e-3);
            }
        }
        assert!(frame.tri.iter().filter(|&&t| t == 4).count() > 16);
    }

    #[test]
    fn frames_are_identical_for_any_thread_count() {
        let mut tris = Vec::new();
        for i in 0..40 {
            let o = Vec3::new(
                (i % 7) as f32 - 3.0,
                (i % 3) as f32 * 0.5,
                -(i as f32) * 0.3,
            );
            tris.extend(cube(o, o + Vec3::splat(0.4)));
        }
        tris.extend(cube(Vec3::splat(-20.0), Vec3::splat(20.0)));
        let scene = soup(&tris);
        let cams: Vec<Camera> = (0..3)
            .map(|k| Camera {
                yaw: k as f32 * 0.7,
                ..camera(Vec3::new(0.1, 0.5, 2.0), 256)
            })
            .collect();
        let frames = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool")
                .install(|| render_batch(&scene, &cams))
        };
        let one = frames(1);
        assert_eq!(one, frames(2));
        assert_eq!(one, frames(3));
        assert!(
            one[0].tri.iter().filter(|&&t| t < 480).count() > 100,
            "cubes seen"
        );
    }
}
