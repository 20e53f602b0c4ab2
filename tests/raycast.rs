//! The ray caster against the rasteriser on generated houses: every image a camera records
//! (colour, depth, normals, the three semantic taxonomies, instance, room, room class) agrees
//! within the parity rules the wgpu renderer is held to (`tests/sim.rs`), and pixels that
//! show the same triangle agree exactly (colour, labels) or to depth-buffer precision.

use crate::common;

use std::f32::consts::FRAC_PI_2;

use glam::Vec3;
use minos::render::NO_HIT;
use minos::render::{cpu, raycast, Camera, RenderScene};
use minos::scene::Taxonomy;

#[test]
fn ray_caster_matches_the_rasteriser_on_every_channel() {
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    let cfg = minos::generate::GenerateConfig {
        houses: 2,
        seed: 9,
        rooms: (4, 6),
        levels: (1, 1),
        closed_door_prob: 0.25,
        ..Default::default()
    };
    let plans = common::generate_into(&cfg, &root);
    common::ingest_into(&root, &data);
    let (mut pixels, mut same_tri, mut hit_eq) = (0usize, 0usize, 0usize);
    let (mut label_eq, mut label_off_edge) = (0usize, 0usize);
    let (mut depth_se, mut depth_n, mut color_ae) = (0f64, 0usize, 0f64);
    let mut worst = 0f64;
    for plan in &plans {
        let (_, scene) = minos::store::DataDir::new(&data)
            .read_scene(&plan.id)
            .unwrap();
        let rs = RenderScene::new(&scene);
        assert!(
            rs.tris
                .iter()
                .any(|t| t.texture != minos::render::scene::NO_TEXTURE),
            "generated houses are textured, so parity covers textures"
        );
        for size in [84u32, 128] {
            for room in &plan.levels[0].rooms {
                let c = [
                    (room.rect.x0 + room.rect.x1) as f32 / 2.0,
                    (room.rect.z0 + room.rect.z1) as f32 / 2.0,
                ];
                for k in 0..4 {
                    let cam = Camera {
                        position: Vec3::new(c[0], 1.09, c[1]),
                        yaw: k as f32 * FRAC_PI_2 + 0.3,
                        tilt: -0.2,
                        vfov_deg: 60.0,
                        width: size,
                        height: size,
                        near: 0.01,
                        far: 50.0,
                    };
                    let (r, z) = (raycast::render(&rs, &cam), cpu::rasterise(&rs, &cam));
                    let labels = |f: &minos::render::Frame| -> Vec<[u32; 6]> {
                        let (n, m, co) = (
                            f.semantic(&rs, Taxonomy::Nyu40),
                            f.semantic(&rs, Taxonomy::Mpcat40),
                            f.semantic(&rs, Taxonomy::Coarse),
                        );
                        let (i, ro, rc) = (f.instance(&rs), f.room(&rs), f.room_class(&rs));
                        (0..f.tri.len())
                            .map(|p| {
                                [
                                    u32::from(n[p]),
                                    u32::from(m[p]),
                                    u32::from(co[p]),
                                    i[p],
                                    ro[p],
                                    u32::from(rc[p]),
                                ]
                            })
                            .collect()
                    };
                    let (lr, lz) = (labels(&r), labels(&z));
                    let (cr, cz) = (r.color(&rs, &cam), z.color(&rs, &cam));
                    let (dr, dz) = (r.linear_depth(&cam), z.linear_depth(&cam));
                    let (nr, nz) = (r.normals(&rs), z.normals(&rs));
                    let w = size as usize;
                    // A silhouette pixel: the rasteriser shows another label or nothing
                    // within one pixel.
                    let edge = |p: usize| {
                        let (x, y) = ((p % w) as i64, (p / w) as i64);
                        (-1..=1).any(|dy| {
                            (-1..=1).any(|dx| {
                                let (u, v) = (x + dx, y + dy);
                                u >= 0
                                    && v >= 0
                                    && u < w as i64
                                    && v < w as i64
                                    && lz[(v * w as i64 + u) as usize] != lz[p]
                            })
                        })
                    };
                    for p in 0..r.tri.len() {
                        pixels += 1;
                        hit_eq += usize::from((r.tri[p] == NO_HIT) == (z.tri[p] == NO_HIT));
                        if lr[p] == lz[p] {
                            label_eq += 1;
                        } else if !edge(p) {
                            label_off_edge += 1;
                        }
                        for k in 0..3 {
                            color_ae +=
                                f64::from((i16::from(cr[p][k]) - i16::from(cz[p][k])).abs());
                        }
                        if dr[p] > 0.0 && dz[p] > 0.0 {
                            depth_se += f64::from(dr[p] - dz[p]).powi(2);
                            depth_n += 1;
                        }
                        if r.tri[p] == z.tri[p] && r.tri[p] != NO_HIT {
                            same_tri += 1;
                            assert_eq!(cr[p], cz[p], "same triangle, same colour");
                            assert_eq!(nr[p], nz[p]);
                            // The ray caster's depth against the exact distance to the
                            // triangle's plane along the pixel's ray (double precision);
                            // the rasteriser interpolates depth-buffer values across the
                            // screen and is off by up to ~1 % at grazing angles.
                            let exact = exact_depth(&cam, rs.triangle(r.tri[p] as usize), p);
                            let rel = (f64::from(dr[p]) - exact).abs() / exact;
                            worst = worst.max(rel);
                            assert!(rel <= 1e-4, "pixel {p}: depth {} exact {exact}", dr[p]);
                        }
                    }
                }
            }
        }
    }
    let n = pixels as f64;
    let rmse = (depth_se / depth_n as f64).sqrt();
    let mae = color_ae / (3.0 * n);
    eprintln!(
        "ray cast vs rasterised: same triangle {:.3}%, hit/miss equal {:.3}%, labels equal \
         {:.3}% ({} differing pixels off silhouettes), depth RMSE {rmse:.5} m, colour MAE \
         {mae:.3}/255, ray-cast depth within {:.5}% of exact",
        100.0 * same_tri as f64 / n,
        100.0 * hit_eq as f64 / n,
        100.0 * label_eq as f64 / n,
        label_off_edge,
        100.0 * worst
    );
    assert!(label_eq as f64 / n >= 0.995, "labels");
    assert!(label_off_edge as f64 / n <= 0.001, "labels off silhouettes");
    assert!(hit_eq as f64 / n >= 0.999, "hit or miss");
    assert!(rmse < 0.01, "depth RMSE {rmse}");
    assert!(mae < 3.0, "colour MAE {mae}");
}

/// Depth along the viewing axis where pixel `p`'s centre ray meets the plane of `tri`,
/// computed in double precision from the camera's definition.
fn exact_depth(cam: &Camera, tri: [Vec3; 3], p: usize) -> f64 {
    let (w, h) = (f64::from(cam.width), f64::from(cam.height));
    let (x, y) = (
        (p % cam.width as usize) as f64 + 0.5,
        (p / cam.width as usize) as f64 + 0.5,
    );
    let tan = (f64::from(cam.vfov_deg).to_radians() * 0.5).tan();
    // Camera space: x right, y up, looking down −z; one unit along the axis per unit of t.
    let d_cam = glam::DVec3::new(
        (x / w * 2.0 - 1.0) * tan * w / h,
        (1.0 - y / h * 2.0) * tan,
        -1.0,
    );
    let d = cam.view().as_dmat4().inverse().transform_vector3(d_cam);
    let (o, a) = (cam.position.as_dvec3(), tri[0].as_dvec3());
    let n = (tri[1].as_dvec3() - a).cross(tri[2].as_dvec3() - a);
    n.dot(a - o) / n.dot(d)
}
