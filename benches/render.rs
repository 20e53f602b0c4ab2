//! Rendering and simulation throughput: `cargo bench --bench render`.
//!
//! A furnished generated house; frames per second of the CPU renderer (which rasterises a
//! scene this small), the ray caster and wgpu (when an adapter exists, e.g. lavapipe) at 84²,
//! 128² and 256², one camera at a time and batched; simulator steps per second with
//! collisions, blind and with an RGB-D-semantic camera. Then rendering at scale: the house
//! (multi-room) and its largest room made dense (every triangle split, clutter boxes added)
//! from 4k to 3M triangles, the ray caster against the rasteriser.

use std::hint::black_box;
use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use minos::generate::{generate, GenerateConfig, OutputFormat};
use minos::navmesh::build::build;
use minos::navmesh::NavParams;
use minos::pipeline::ingest::{ingest, IngestConfig};
use minos::progress::NoProgress;
use minos::render::gpu::GpuRenderer;
use minos::render::Renderer;
use minos::render::RendererChoice;
use minos::render::{cpu, raycast, Camera, Frame, RenderScene};
use minos::seed::Rng;
use minos::sim::{Actions, AgentConfig, SceneAssets, SensorSuite, Simulator};

#[path = "support/dense.rs"]
mod dense;

fn fps(frames: usize, mut f: impl FnMut()) -> f64 {
    f();
    let t = Instant::now();
    f();
    frames as f64 / t.elapsed().as_secs_f64()
}

fn main() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    let cfg = GenerateConfig {
        houses: 6,
        seed: 11,
        rooms: (7, 8),
        levels: (1, 1),
        closed_door_prob: 0.25,
        ..Default::default()
    };
    generate(&cfg, OutputFormat::Suncg, &root, false, &NoProgress).expect("generate");
    let report = ingest(&IngestConfig::suncg(&root, &data), &NoProgress).expect("ingest");
    let scene = report
        .scenes
        .iter()
        .map(|(r, _)| {
            minos::store::DataDir::new(&data)
                .read_scene(&r.id)
                .expect("scene")
                .1
        })
        .max_by_key(|s| s.triangle_count())
        .expect("houses");
    let rs = RenderScene::new(&scene);
    // MINOS's body, as the simulator bench below moves MINOS's continuous agent.
    let grid = build(&scene, &NavParams::for_body(minos::body::AgentBody::MINOS)).expect("bake");
    let spans = grid.walkable_spans(None);
    let mut rng = Rng::new(3);
    let poses: Vec<(Vec3, f32)> = (0..64)
        .map(|_| {
            let (_, p) = grid.random_point_from(&mut rng, &spans).expect("walkable");
            (p, rng.range_f64(0.0, std::f64::consts::TAU) as f32)
        })
        .collect();
    if std::env::args().any(|a| a == "gpu") {
        // `scripts/gpu_bench.sh`: only the batched wgpu figures at scale.
        gpu_at_scale(&rs, &grid, &poses);
        return;
    }
    if std::env::args().any(|a| a == "clutter") {
        // Only the cluttered-room rows (`cargo bench --bench render -- clutter`).
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("pool");
        cluttered_room(&rs, &grid, &one);
        return;
    }
    if std::env::args().any(|a| a == "scale") {
        // Only the rendering-at-scale table (`cargo bench --bench render -- scale`).
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("pool");
        at_scale(&rs, &grid, &poses, &one);
        return;
    }
    let cams = |size: u32| -> Vec<Camera> {
        poses
            .iter()
            .map(|(p, yaw)| Camera {
                position: *p + Vec3::Y * 1.09,
                yaw: *yaw,
                tilt: 0.0,
                vfov_deg: 45.0,
                width: size,
                height: size,
                near: 0.01,
                far: 50.0,
            })
            .collect()
    };
    println!(
        "scene: {} triangles rendered ({} objects, {} textured triangles, {} textures)\n",
        rs.triangle_count(),
        scene.objects().count(),
        rs.tris
            .iter()
            .filter(|t| t.texture != minos::render::scene::NO_TEXTURE)
            .count(),
        rs.textures.len()
    );
    println!("| renderer | size | one camera at a time | batch of 64 |\n|---|---|---|---|");
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    for size in [84, 128, 256] {
        let c = cams(size);
        let single = one.install(|| {
            fps(c.len(), || {
                c.iter()
                    .for_each(|cam| drop(black_box(cpu::render(&rs, cam))))
            })
        });
        let batch = fps(c.len(), || drop(black_box(cpu::render_batch(&rs, &c))));
        println!(
            "| cpu (1 core / all cores batched) | {size}² | {single:.0} fps | {batch:.0} fps |"
        );
        let single = one.install(|| {
            fps(c.len(), || {
                c.iter()
                    .for_each(|cam| drop(black_box(raycast::render(&rs, cam))))
            })
        });
        let batch = fps(c.len(), || drop(black_box(raycast::render_batch(&rs, &c))));
        println!(
            "| ray caster (1 core / all cores batched) | {size}² | {single:.0} fps | {batch:.0} fps |"
        );
    }
    // The images a colour + depth + semantic camera needs: rasterise once, then derive the
    // (textured) colour, the linear depth and the labels from the frame.
    println!(
        "\n| cpu, 1 core, best of 5 | size | rasterise + colour + depth + semantic | the same, textures off |\n|---|---|---|---|"
    );
    let flat = {
        let mut f = rs.clone();
        for t in &mut f.tris {
            t.texture = minos::render::scene::NO_TEXTURE;
        }
        f.textures.clear();
        f
    };
    for size in [84, 128] {
        let c = cams(size);
        // Best of 5 passes, textured and untextured interleaved, so load from other
        // processes on a shared machine affects both alike.
        let images = |scene: &RenderScene| {
            one.install(|| {
                fps(c.len(), || {
                    c.iter().for_each(|cam| {
                        let f = cpu::render(scene, cam);
                        black_box(f.color(scene, cam));
                        black_box(f.linear_depth(cam));
                        black_box(f.semantic(scene, minos::scene::Taxonomy::Nyu40));
                    })
                })
            })
        };
        let (mut textured, mut untextured) = (0f64, 0f64);
        for _ in 0..5 {
            textured = textured.max(images(&rs));
            untextured = untextured.max(images(&flat));
        }
        println!("| textured house | {size}² | {textured:.0} fps | {untextured:.0} fps |");
    }
    match GpuRenderer::new() {
        Ok(mut gpu) => {
            gpu.upload(&rs).expect("upload");
            for size in [84, 128, 256] {
                let c = cams(size);
                let single = fps(c.len(), || {
                    c.iter().for_each(|cam| {
                        drop(black_box(
                            gpu.render_batch(std::slice::from_ref(cam)).expect("render"),
                        ))
                    })
                });
                let batch = fps(c.len(), || {
                    drop(black_box(gpu.render_batch(&c).expect("render")))
                });
                println!(
                    "| wgpu {} | {size}² | {single:.0} fps | {batch:.0} fps |",
                    gpu.adapter_name()
                );
            }
        }
        Err(e) => println!("| wgpu | – | skipped: {e} | |"),
    }
    println!("\n| simulator | steps/s (1 core) |\n|---|---|");
    let agent = AgentConfig::minos_continuous();
    let assets = Arc::new(SceneAssets::new(&scene, grid, &agent).expect("assets"));
    let renderer = Arc::new(Renderer::new(RendererChoice::Cpu, &assets.render).expect("cpu"));
    for (name, sensors) in [
        (
            "blind, collisions + contacts",
            SensorSuite {
                cameras: vec![],
                contact: SensorSuite::minos(84).contact,
            },
        ),
        ("RGB-D-semantic 84², cpu", SensorSuite::minos(84)),
    ] {
        let mut sim = Simulator::new(assets.clone(), renderer.clone(), agent, sensors, 500, 0);
        let steps = 2000;
        let rate = one.install(|| {
            fps(steps, || {
                sim.reset(poses[0].0, poses[0].1, None, "bench");
                let mut rng = Rng::new(1);
                for _ in 0..steps {
                    let a = Actions::single(
                        ["forward", "forward", "turn_left", "turn_right"][rng.below(4)],
                    )
                    .expect("action");
                    black_box(sim.step(a).expect("step"));
                }
            })
        });
        println!("| {name} | {rate:.0} |");
    }
    at_scale(&rs, &assets.grid, &poses, &one);
}

/// Colour + depth + semantic frames per second of `render` over `cams`, one core.
fn images_fps(
    one: &rayon::ThreadPool,
    scene: &RenderScene,
    cams: &[Camera],
    render: fn(&RenderScene, &Camera) -> Frame,
) -> f64 {
    one.install(|| {
        fps(cams.len(), || {
            cams.iter().for_each(|cam| {
                let f = render(scene, cam);
                black_box(f.color(scene, cam));
                black_box(f.linear_depth(cam));
                black_box(f.semantic(scene, minos::scene::Taxonomy::Nyu40));
            })
        })
    })
}

/// The house and its largest room made dense, 4k → 3M triangles: ray caster and rasteriser
/// at 84² (colour + depth + semantic, one core), the ray caster at 128² and 256² too, the
/// BVH's build time and memory. `MINOS_BENCH_SCALE_TRIANGLES` (comma-separated) picks the
/// sizes; `0` is the scene as generated.
fn at_scale(
    rs: &RenderScene,
    grid: &minos::navmesh::NavGrid,
    poses: &[(Vec3, f32)],
    one: &rayon::ThreadPool,
) {
    let targets: Vec<usize> = std::env::var("MINOS_BENCH_SCALE_TRIANGLES")
        .ok()
        .map(|v| v.split(',').filter_map(|n| n.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![0, 10_000, 30_000, 100_000, 300_000, 1_000_000, 3_000_000]);
    let (room, room_poses) = largest_room(rs, grid);
    let room_scene = dense::single_room(rs, room);
    println!(
        "\n## Rendering at scale (colour + depth + semantic, one core; room {room}: {} poses)\n",
        room_poses.len()
    );
    println!(
        "| scene | triangles | BVH build | BVH MB | ray cast 84² (ids + depth only) | rasterised 84² | ray cast 128² | ray cast 256² |\n|---|---|---|---|---|---|---|---|"
    );
    for (name, base, poses, boxes) in [
        ("multi-room house", rs, poses, 300usize),
        ("single dense room", &room_scene, &room_poses[..], 100),
    ] {
        for &target in &targets {
            let scene = if target == 0 {
                dense::densify(base, 0, 0, 1)
            } else {
                dense::densify(base, boxes, target, 1)
            };
            let t = Instant::now();
            let bvh = scene.bvh();
            let build = t.elapsed().as_secs_f64();
            let mb = bvh.memory_bytes() as f64 / 1e6;
            let at = |size: u32, n: usize| -> Vec<Camera> {
                poses.iter().take(n).map(|&p| eye_camera(p, size)).collect()
            };
            let ray84 = images_fps(one, &scene, &at(84, 64), raycast::render);
            let cams84 = at(84, 64);
            // Best of three: the figure least disturbed by other processes.
            let cast84 = (0..3)
                .map(|_| {
                    one.install(|| {
                        fps(cams84.len(), || {
                            cams84
                                .iter()
                                .for_each(|cam| drop(black_box(raycast::render(&scene, cam))))
                        })
                    })
                })
                .fold(0.0, f64::max);
            // The rasteriser's cost grows with the triangles: fewer poses on big scenes.
            let raster_poses = if scene.triangle_count() > 200_000 {
                8
            } else {
                64
            };
            let raster84 = images_fps(one, &scene, &at(84, raster_poses), cpu::rasterise);
            let big = if target == 1_000_000 || target == 0 {
                let r128 = images_fps(one, &scene, &at(128, 64), raycast::render);
                let r256 = images_fps(one, &scene, &at(256, 16), raycast::render);
                (format!("{r128:.0} fps"), format!("{r256:.0} fps"))
            } else {
                ("".into(), "".into())
            };
            println!(
                "| {name} | {} | {:.0} ms | {mb:.1} | {ray84:.0} fps ({cast84:.0} fps) | {raster84:.0} fps | {} | {} |",
                scene.triangle_count(),
                build * 1e3,
                big.0,
                big.1
            );
        }
    }
}

/// Triangles of the cluttered room and of the dense room it is compared with.
const CLUTTER_TRIANGLES: usize = 861_000;
/// Small objects in the cluttered room.
const CLUTTER_BOXES: usize = 10_000;

/// The house's largest room at about 861k triangles two ways: its surfaces densified with
/// 100 boxes (as in the table above), and with 10,000 small boxes of 12 triangles
/// (`dense::cluttered`) — colour + depth + semantic at 84² on one core, ray cast alone
/// (best of three) and the BVH's build time, memory and depth.
fn cluttered_room(rs: &RenderScene, grid: &minos::navmesh::NavGrid, one: &rayon::ThreadPool) {
    let (room, poses) = largest_room(rs, grid);
    let base = dense::single_room(rs, room);
    println!(
        "\n## Cluttered room (room {room}, {} poses, 84², one core)\n",
        poses.len()
    );
    println!(
        "| scene | triangles | objects | BVH build | BVH MB | BVH depth | colour + depth + semantic 84² | ray cast alone |\n|---|---|---|---|---|---|---|---|"
    );
    for (name, boxes, scene) in [
        (
            "dense room",
            100,
            dense::densify(&base, 100, CLUTTER_TRIANGLES, 1),
        ),
        (
            "cluttered room",
            CLUTTER_BOXES,
            dense::cluttered(&base, CLUTTER_BOXES, CLUTTER_TRIANGLES, 1),
        ),
    ] {
        let t = Instant::now();
        let bvh = scene.bvh();
        let build = t.elapsed().as_secs_f64();
        let cams: Vec<Camera> = poses.iter().map(|&p| eye_camera(p, 84)).collect();
        let images = (0..3)
            .map(|_| images_fps(one, &scene, &cams, raycast::render))
            .fold(0.0, f64::max);
        let cast = (0..3)
            .map(|_| {
                one.install(|| {
                    fps(cams.len(), || {
                        cams.iter()
                            .for_each(|cam| drop(black_box(raycast::render(&scene, cam))))
                    })
                })
            })
            .fold(0.0, f64::max);
        println!(
            "| {name} | {} | {boxes} boxes | {:.0} ms | {:.1} | {} | {images:.0} fps | {cast:.0} fps |",
            scene.triangle_count(),
            build * 1e3,
            bvh.memory_bytes() as f64 / 1e6,
            bvh.depth()
        );
    }
}

/// A camera at eye height 1.09 m above a walkable point, looking level.
fn eye_camera((p, yaw): (Vec3, f32), size: u32) -> Camera {
    Camera {
        position: p + Vec3::Y * 1.09,
        yaw,
        tilt: 0.0,
        vfov_deg: 45.0,
        width: size,
        height: size,
        near: 0.01,
        far: 50.0,
    }
}

/// The room most of 4,000 random walkable points fall in, and up to 64 of those points with
/// random headings.
fn largest_room(rs: &RenderScene, grid: &minos::navmesh::NavGrid) -> (u32, Vec<(Vec3, f32)>) {
    let spans = grid.walkable_spans(None);
    let mut rng = Rng::new(5);
    let points: Vec<(Vec3, f32)> = (0..4000)
        .filter_map(|_| {
            let (_, p) = grid.random_point_from(&mut rng, &spans)?;
            Some((p, rng.range_f64(0.0, std::f64::consts::TAU) as f32))
        })
        .collect();
    let room_of = |p: Vec3| {
        // The room of the floor triangle straight below, from the render scene itself.
        let down = minos::render::bvh::Ray::new(p + Vec3::Y * 0.5, Vec3::NEG_Y, 0.0, 2.0);
        rs.bvh()
            .closest(&down, None)
            .map_or(0, |h| rs.tris[h.tri as usize].room)
    };
    let mut counts = std::collections::BTreeMap::new();
    for (p, _) in &points {
        *counts.entry(room_of(*p)).or_insert(0usize) += 1;
    }
    let room = counts
        .iter()
        .filter(|(r, _)| **r != 0)
        .max_by_key(|(r, n)| (**n, std::cmp::Reverse(**r)))
        .map_or(1, |(r, _)| *r);
    let poses = points
        .iter()
        .filter(|(p, _)| room_of(*p) == room)
        .take(64)
        .copied()
        .collect();
    (room, poses)
}

/// Batched wgpu frames per second at 128² on the 1M-triangle dense scenes (both uploaded,
/// views alternating between them), batches of 1,024 views (or `MINOS_GPU_BENCH_VIEWS`): the id + depth pass with its
/// one read-back, and with colour, linear depth and NYU-40 semantics derived on all cores.
fn gpu_at_scale(rs: &RenderScene, grid: &minos::navmesh::NavGrid, poses: &[(Vec3, f32)]) {
    let mut gpu = match GpuRenderer::new() {
        Ok(g) => g,
        Err(e) => {
            println!("wgpu: skipped: {e}");
            return;
        }
    };
    let (room, room_poses) = largest_room(rs, grid);
    let scenes = [
        (
            "multi-room house",
            dense::densify(rs, 300, 1_000_000, 1),
            poses.to_vec(),
        ),
        (
            "single dense room",
            dense::densify(&dense::single_room(rs, room), 100, 1_000_000, 1),
            room_poses,
        ),
    ];
    let slots: Vec<_> = scenes
        .iter()
        .map(|(_, s, _)| gpu.add_scene(s).expect("upload"))
        .collect();
    println!(
        "adapter: {}\nscenes: {}\n",
        gpu.adapter_name(),
        scenes
            .iter()
            .map(|(n, s, _)| format!("{n} ({} triangles)", s.triangle_count()))
            .collect::<Vec<_>>()
            .join(", ")
    );
    println!("| size | views per batch | ids + depth, one read-back | + colour, depth, semantic (all cores) |\n|---|---|---|---|");
    for size in [84u32, 128, 256] {
        // MINOS_GPU_BENCH_VIEWS: a smaller batch for a software adapter.
        let batch = std::env::var("MINOS_GPU_BENCH_VIEWS")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(1024usize);
        let views: Vec<minos::render::gpu::View> = (0..batch)
            .map(|i| {
                let k = i % scenes.len();
                let ps = &scenes[k].2;
                minos::render::gpu::View {
                    scene: slots[k],
                    camera: eye_camera(ps[(i / scenes.len()) % ps.len()], size),
                }
            })
            .collect();
        let pass = fps(batch, || {
            drop(black_box(gpu.render_views(&views).expect("render")))
        });
        let derived = fps(batch, || {
            use rayon::prelude::*;
            let frames = gpu.render_views(&views).expect("render");
            frames.par_iter().zip(&views).for_each(|(f, v)| {
                let s = &scenes[v.scene.0].1;
                black_box(f.color(s, &v.camera));
                black_box(f.linear_depth(&v.camera));
                black_box(f.semantic(s, minos::scene::Taxonomy::Nyu40));
            });
        });
        println!("| {size}² | {batch} | {pass:.0} fps | {derived:.0} fps |");
    }
}
