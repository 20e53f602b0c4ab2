//! Rendering and simulation throughput: `cargo bench --bench render`.
//!
//! A furnished generated house; frames per second of the CPU rasteriser and of wgpu (when an
//! adapter exists, e.g. lavapipe) at 84², 128² and 256², one camera at a time and batched;
//! simulator steps per second with collisions, blind and with an RGB-D-semantic camera.

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
use minos::render::{cpu, Camera, RenderScene};
use minos::seed::Rng;
use minos::sim::simulator::Renderer;
use minos::sim::{Actions, AgentConfig, RendererChoice, SceneAssets, SensorSuite, Simulator};

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
                        black_box(f.semantic(scene, minos::render::Taxonomy::Nyu40));
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
            gpu.upload(&rs);
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
}
