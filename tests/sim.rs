//! The simulator with answers known in advance: MINOS's motion per step, walls, sliding, doors,
//! tilt limits; depth, normals, labels, contacts and the geodesic measurement; and CPU/wgpu
//! renderer parity on a generated house.

use crate::common;

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
use std::sync::Arc;

use common::scenes::SceneBuilder;
use glam::Vec3;
use minos::navmesh::build::build;
use minos::navmesh::route::route;
use minos::navmesh::NavParams;
use minos::render::Renderer;
use minos::render::RendererChoice;
use minos::render::{cpu, Camera, RenderScene};
use minos::render::{Image, Modality};
use minos::scene::{ObjectFlags, RoomClass, Scene};
use minos::sim::{Actions, AgentConfig, GoalSpec, SceneAssets, SensorSuite, Simulator};

fn sim_with(scene: &Scene, agent: AgentConfig, sensors: SensorSuite) -> Simulator {
    let grid = build(scene, &NavParams::for_body(agent.body)).unwrap();
    let assets = Arc::new(SceneAssets::new(scene, grid, &agent).unwrap());
    let renderer = Arc::new(Renderer::new(RendererChoice::Cpu, &assets.render).unwrap());
    Simulator::new(assets, renderer, agent, sensors, 500, 0)
}

fn blind() -> SensorSuite {
    SensorSuite {
        cameras: vec![],
        contact: None,
    }
}

fn open_room() -> Scene {
    SceneBuilder::new("open")
        .room("r", RoomClass::LivingRoom, [0.0, 0.0, 10.0, 10.0], 0.0, &[])
        .build()
}

fn act(name: &str) -> Actions {
    Actions::single(name).unwrap()
}

#[test]
fn one_forward_step_moves_each_agent_its_distance_and_turns_match() {
    for (agent, dist, turn) in [
        (AgentConfig::minos_continuous(), 0.2, 4.0 * PI * 0.1 * 0.1),
        (AgentConfig::minos_gridworld(), 0.4, FRAC_PI_2),
        (AgentConfig::habitat(), 0.25, 10f32.to_radians()),
    ] {
        let mut sim = sim_with(&open_room(), agent, blind());
        sim.reset(Vec3::new(5.0, 0.0, 5.0), 0.0, None, "e");
        let m = sim.step(act("forward")).unwrap().measurements;
        assert!(
            (Vec3::from_array(m.position) - Vec3::new(5.0, 0.0, 5.0 - dist)).length() < 1e-4,
            "{agent:?}: {:?}",
            m.position
        );
        assert!(!m.collision);
        let m = sim.step(act("turn_left")).unwrap().measurements;
        assert!((m.yaw - turn).abs() < 1e-4, "turn {} vs {turn}", m.yaw);
    }
    let mut sim = sim_with(&open_room(), AgentConfig::minos_continuous(), blind());
    sim.reset(Vec3::new(5.0, 0.0, 9.0), 0.0, None, "e");
    for _ in 0..10 {
        let m = sim.step(act("forward")).unwrap().measurements;
        assert!(Vec3::new(m.velocity[0], 0.0, m.velocity[1]).length() <= 2.0 + 1e-4);
    }
}

fn walled_room(wall_z: f32, thickness: f32) -> Scene {
    SceneBuilder::new("wall")
        .room(
            "r",
            RoomClass::Hallway,
            [0.0, 0.0, 10.0, 10.0],
            0.0,
            &[([0.0, 0.0, wall_z - thickness], [10.0, 2.7, wall_z])],
        )
        .build()
}

#[test]
fn walking_into_a_thin_wall_stops_at_it_with_the_collision_flag() {
    let wall = 3.0;
    let mut sim = sim_with(
        &walled_room(wall, 0.01),
        AgentConfig::minos_continuous(),
        blind(),
    );
    sim.reset(Vec3::new(5.0, 0.0, 6.0), 0.0, None, "e");
    let mut hit = false;
    for _ in 0..30 {
        let m = sim.step(act("forward")).unwrap().measurements;
        hit |= m.collision;
        assert!(
            m.position[2] >= wall + 0.1 - 1e-3,
            "went through the wall: {:?}",
            m.position
        );
    }
    assert!(hit);
    assert!(
        sim.state().position[2] < wall + 0.2,
        "stopped short: {:?}",
        sim.state().position
    );
}

#[test]
fn sliding_along_a_wall_at_45_degrees_keeps_moving() {
    let wall = 3.0;
    let mut sim = sim_with(
        &walled_room(wall, 0.1),
        AgentConfig::minos_continuous(),
        blind(),
    );
    sim.reset(Vec3::new(8.0, 0.0, 3.6), FRAC_PI_4, None, "e");
    for _ in 0..5 {
        sim.step(act("forward")).unwrap();
    }
    let before = sim.state().position;
    let mut collided = false;
    for _ in 0..10 {
        collided |= sim.step(act("forward")).unwrap().measurements.collision;
    }
    let after = sim.state().position;
    assert!(collided);
    assert!(
        before[0] - after[0] > 0.5,
        "stuck at the wall: {before:?} -> {after:?}"
    );
    assert!(after[2] >= wall + 0.1 - 1e-3);
}

fn doorway(closed: bool) -> Scene {
    let w = |x0: f32, x1: f32| ([x0, 0.0, 2.95], [x1, 2.7, 3.05]);
    let b = SceneBuilder::new("door").room(
        "r",
        RoomClass::Hallway,
        [0.0, 0.0, 10.0, 10.0],
        0.0,
        &[
            w(0.0, 4.5),
            w(5.5, 10.0),
            ([4.5, 2.1, 2.95], [5.5, 2.7, 3.05]),
        ],
    );
    let b = if closed {
        b.object(
            "door",
            "door",
            ObjectFlags {
                door: true,
                ..Default::default()
            },
            &[([4.5, 0.0, 2.98], [5.5, 2.1, 3.02])],
            vec![0],
        )
    } else {
        b
    };
    b.build()
}

#[test]
fn a_closed_door_stops_the_agent_and_an_open_one_does_not() {
    for closed in [true, false] {
        let mut sim = sim_with(&doorway(closed), AgentConfig::minos_continuous(), blind());
        sim.reset(Vec3::new(5.0, 0.0, 5.0), 0.0, None, "e");
        for _ in 0..20 {
            sim.step(act("forward")).unwrap();
        }
        let z = sim.state().position[2];
        if closed {
            assert!(z > 3.0, "passed a closed door: z = {z}");
        } else {
            assert!(z < 2.0, "an open doorway blocked: z = {z}");
        }
    }
}

#[test]
fn an_agent_walking_at_a_doorway_a_little_off_its_line_slides_past_the_jamb() {
    // The doorway is x 4.5..5.5 in a wall at z 2.95..3.05; a body of radius r passes where its
    // centre is over r from both jambs. Walking straight at it with the centre a few mm
    // closer than r to a jamb, or at it obliquely past the jamb's corner, the body meets the
    // corner's edge and must slide off it into the doorway, not stop there for good.
    let agent = AgentConfig::minos_continuous();
    let r = agent.body.radius;
    for (x, yaw) in [
        (4.5 + r - 0.006, 0.0),
        (5.5 - r + 0.006, 0.0),
        (4.5 + r - 0.03, 0.0),
        (4.5 + r, -0.15),
        (5.5 - r, 0.15),
    ] {
        let mut sim = sim_with(&doorway(false), agent, blind());
        sim.reset(Vec3::new(x, 0.0, 3.6), yaw, None, "e");
        for _ in 0..15 {
            sim.step(act("forward")).unwrap();
        }
        let p = sim.state().position;
        assert!(p[2] < 2.5, "stuck at the jamb from x {x}, yaw {yaw}: {p:?}");
    }
}

#[test]
fn tilt_clamps_at_straight_up_and_down() {
    let mut sim = sim_with(&open_room(), AgentConfig::minos_continuous(), blind());
    sim.reset(Vec3::new(5.0, 0.0, 5.0), 0.0, None, "e");
    for _ in 0..20 {
        sim.step(act("look_up")).unwrap();
    }
    assert_eq!(sim.state().tilt, FRAC_PI_2);
    for _ in 0..40 {
        sim.step(act("look_down")).unwrap();
    }
    assert_eq!(sim.state().tilt, -FRAC_PI_2);
}

fn camera_suite(modalities: &[(&str, Modality)], size: u32, tilt_deg: f32) -> SensorSuite {
    let mut s = SensorSuite::minos(size);
    let template = s.cameras[0].clone();
    s.cameras = modalities
        .iter()
        .map(|(n, m)| {
            let mut c = template.clone();
            c.name = n.to_string();
            c.modality = *m;
            c.orientation = [0.0, tilt_deg];
            c
        })
        .collect();
    s.contact = None;
    s
}

fn centre<T: Copy>(data: &[T], size: u32, channels: usize) -> &[T] {
    let i = ((size / 2) * size + size / 2) as usize * channels;
    &data[i..i + channels]
}

#[test]
fn depth_of_a_wall_normals_of_the_floor_and_the_label_of_an_object() {
    let size = 64;
    let scene = SceneBuilder::new("s")
        .room(
            "r",
            RoomClass::Bedroom,
            [0.0, 0.0, 10.0, 10.0],
            0.0,
            &[([0.0, 0.0, -0.1], [10.0, 2.7, 0.0])],
        )
        .build();
    let mut sim = sim_with(
        &scene,
        AgentConfig::minos_continuous(),
        camera_suite(&[("d", Modality::Depth)], size, 0.0),
    );
    sim.reset(Vec3::new(5.0, 0.0, 3.0), 0.0, None, "e");
    let obs = sim.observe().unwrap();
    let Image::F32 { data, .. } = &obs.images[0].1 else {
        panic!("float depth")
    };
    assert!(
        (centre(data, size, 1)[0] - 3.0).abs() < 0.01,
        "{}",
        centre(data, size, 1)[0]
    );
    let mut sim = sim_with(
        &scene,
        AgentConfig::minos_continuous(),
        camera_suite(&[("n", Modality::Normal)], size, -60.0),
    );
    sim.reset(Vec3::new(5.0, 0.0, 5.0), 0.0, None, "e");
    let Image::F32 { data, .. } = &sim.observe().unwrap().images[0].1 else {
        panic!("normals")
    };
    let n = &data[((size - 2) * size + size / 2) as usize * 3..][..3];
    assert!((n[1] - 1.0).abs() < 1e-5 && n[0].abs() < 1e-5, "{n:?}");
    let scene = SceneBuilder::new("bed")
        .room("r", RoomClass::Bedroom, [0.0, 0.0, 10.0, 10.0], 0.0, &[])
        .object(
            "b",
            "bed",
            ObjectFlags::default(),
            &[([4.0, 0.0, 1.0], [6.0, 2.0, 2.0])],
            vec![0],
        )
        .build();
    let mut sim = sim_with(
        &scene,
        AgentConfig::minos_continuous(),
        camera_suite(
            &[("s", Modality::Semantic), ("i", Modality::Instance)],
            size,
            0.0,
        ),
    );
    sim.reset(Vec3::new(5.0, 0.0, 5.0), 0.0, None, "e");
    let obs = sim.observe().unwrap();
    let (Image::U16(sem), Image::U32(inst)) = (&obs.images[0].1, &obs.images[1].1) else {
        panic!("labels")
    };
    assert_eq!(centre(sem, size, 1)[0], 4);
    assert_eq!(centre(inst, size, 1)[0], 1);
    sim.reset(Vec3::new(5.0, 0.0, 5.0), PI, None, "e");
    let obs = sim.observe().unwrap();
    let Image::U16(sem) = &obs.images[0].1 else {
        panic!()
    };
    assert!(!sem.contains(&4));
}

#[test]
fn the_coarse_taxonomy_labels_a_known_object_and_the_floor() {
    let size = 32;
    let scene = SceneBuilder::new("sofa")
        .room("r", RoomClass::LivingRoom, [0.0, 0.0, 10.0, 10.0], 0.0, &[])
        .object(
            "s",
            "sofa",
            ObjectFlags::default(),
            &[([3.0, 0.0, 1.0], [7.0, 2.5, 2.0])],
            vec![0],
        )
        .build();
    let mut suite = camera_suite(&[("s", Modality::Semantic)], size, 0.0);
    suite.cameras[0].taxonomy = minos::scene::Taxonomy::Coarse;
    let mut sim = sim_with(&scene, AgentConfig::minos_continuous(), suite);
    sim.reset(Vec3::new(5.0, 0.0, 5.0), 0.0, None, "e");
    let obs = sim.observe().unwrap();
    let Image::U16(sem) = &obs.images[0].1 else {
        panic!("labels")
    };
    // data/taxonomy/coarse.csv: 2 floor, 10 sofa.
    assert_eq!(centre(sem, size, 1)[0], 10);
    assert_eq!(
        sem[(size * size - size / 2) as usize],
        2,
        "bottom row: floor"
    );
}

#[test]
fn contact_fires_only_on_the_touching_side() {
    let mut sensors = blind();
    sensors.contact = Some(minos::sim::ContactSensors {
        count: 4,
        height: 0.3,
    });
    let mut sim = sim_with(
        &walled_room(3.0, 0.1),
        AgentConfig::minos_continuous(),
        sensors,
    );
    sim.reset(Vec3::new(5.0, 0.0, 5.0), 0.0, None, "e");
    let mut m = sim.step(act("idle")).unwrap().measurements;
    assert_eq!(m.contacts, vec![false; 4]);
    for _ in 0..20 {
        m = sim.step(act("forward")).unwrap().measurements;
    }
    assert_eq!(m.contacts, vec![true, false, false, false], "front only");
    assert!(m.contact_impulses[0] > 0.0 && m.contact_impulses[1..].iter().all(|i| *i == 0.0));
}

#[test]
fn the_geodesic_measurement_equals_the_navigation_query() {
    let scene = SceneBuilder::new("partial")
        .room(
            "r",
            RoomClass::Hallway,
            [0.0, 0.0, 10.0, 10.0],
            0.0,
            &[([0.0, 0.0, 4.9], [7.0, 2.7, 5.0])],
        )
        .build();
    let mut sim = sim_with(&scene, AgentConfig::minos_continuous(), blind());
    let (start, goal) = (Vec3::new(2.0, 0.0, 8.0), Vec3::new(2.0, 0.0, 2.0));
    sim.reset(start, 0.0, Some(GoalSpec::Point(goal)), "e");
    let m = sim.observe().unwrap().measurements;
    let want = route(&sim.assets().grid, start, goal)
        .unwrap()
        .geodesic
        .unwrap();
    let got = m.goal_geodesic.unwrap();
    assert!((got - want).abs() < 0.01 * want, "{got} vs {want}");
    assert!(got > 6.0 + 2.0, "must go around the wall: {got}");
    assert!((m.goal_euclidean.unwrap() - 6.0).abs() < 1e-4);
    assert!((m.goal_direction.unwrap()[1] - 1.0).abs() < 1e-4);
    assert!(
        m.waypoint_direction.unwrap()[0] > 0.3,
        "{:?}",
        m.waypoint_direction
    );
}

#[test]
fn cpu_and_wgpu_ray_tracer_agree() {
    cpu_and_wgpu_agree(minos::render::gpu::GpuMethod::RayTrace);
}

#[test]
fn cpu_and_wgpu_rasteriser_agree() {
    cpu_and_wgpu_agree(minos::render::gpu::GpuMethod::Rasterise);
}

/// The CPU renderer and wgpu's `method` give the same images within the parity tolerances.
fn cpu_and_wgpu_agree(method: minos::render::gpu::GpuMethod) {
    let mut gpu = match minos::render::gpu::GpuRenderer::with_method(method) {
        Ok(g) => g,
        Err(e) => {
            common::skip(e);
            return;
        }
    };
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    let cfg = minos::generate::GenerateConfig {
        houses: 2,
        seed: 4,
        rooms: (4, 6),
        levels: (1, 1),
        closed_door_prob: 0.25,
        ..Default::default()
    };
    let plans = common::generate_into(&cfg, &root);
    common::ingest_into(&root, &data);
    let (mut depth_se, mut depth_n, mut label_eq, mut label_n, mut color_ae, mut color_n) =
        (0f64, 0usize, 0usize, 0usize, 0f64, 0usize);
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
        gpu.upload(&rs).unwrap();
        for size in [84u32, 128] {
            let cams: Vec<Camera> = plan.levels[0]
                .rooms
                .iter()
                .flat_map(|r| {
                    let c = [
                        (r.rect.x0 + r.rect.x1) as f32 / 2.0,
                        (r.rect.z0 + r.rect.z1) as f32 / 2.0,
                    ];
                    (0..4).map(move |k| Camera {
                        position: Vec3::new(c[0], 1.09, c[1]),
                        yaw: k as f32 * FRAC_PI_2 + 0.3,
                        tilt: -0.2,
                        vfov_deg: 60.0,
                        width: size,
                        height: size,
                        near: 0.01,
                        far: 50.0,
                    })
                })
                .collect();
            let gpu_frames = gpu.render_batch(&cams).unwrap();
            for (cam, g) in cams.iter().zip(&gpu_frames) {
                let c = cpu::render(&rs, cam);
                let (dc, dg) = (c.linear_depth(cam), g.linear_depth(cam));
                let (sc, sg) = (
                    c.semantic(&rs, minos::scene::Taxonomy::Nyu40),
                    g.semantic(&rs, minos::scene::Taxonomy::Nyu40),
                );
                let (ic, ig) = (c.instance(&rs), g.instance(&rs));
                let (cc, cg) = (c.color(&rs, cam), g.color(&rs, cam));
                for p in 0..dc.len() {
                    if dc[p] > 0.0 && dg[p] > 0.0 {
                        depth_se += f64::from(dc[p] - dg[p]).powi(2);
                        depth_n += 1;
                    }
                    label_eq += usize::from(sc[p] == sg[p] && ic[p] == ig[p]);
                    label_n += 1;
                    for k in 0..3 {
                        color_ae += f64::from((i16::from(cc[p][k]) - i16::from(cg[p][k])).abs());
                        color_n += 1;
                    }
                }
            }
        }
    }
    let rmse = (depth_se / depth_n as f64).sqrt();
    let labels = label_eq as f64 / label_n as f64;
    let mae = color_ae / color_n as f64;
    eprintln!(
        "parity ({}): depth RMSE {rmse:.5} m, labels equal {:.3}%, colour MAE {mae:.3}/255 ({})",
        method.name(),
        100.0 * labels,
        gpu.adapter_name()
    );
    assert!(rmse < 0.01, "depth RMSE {rmse}");
    assert!(labels >= 0.995, "labels {labels}");
    assert!(mae < 3.0, "colour MAE {mae}");
}

#[test]
fn wgpu_renders_views_of_several_scenes_in_one_batch() {
    let mut gpu = match minos::render::gpu::GpuRenderer::new() {
        Ok(g) => g,
        Err(e) => {
            common::skip(e);
            return;
        }
    };
    use minos::render::gpu::View;
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    let cfg = minos::generate::GenerateConfig {
        houses: 2,
        seed: 6,
        rooms: (3, 5),
        levels: (1, 1),
        closed_door_prob: 0.25,
        ..Default::default()
    };
    let plans = common::generate_into(&cfg, &root);
    common::ingest_into(&root, &data);
    let scenes: Vec<RenderScene> = plans
        .iter()
        .map(|p| {
            RenderScene::new(
                &minos::store::DataDir::new(&data)
                    .read_scene(&p.id)
                    .unwrap()
                    .1,
            )
        })
        .collect();
    let slots: Vec<_> = scenes.iter().map(|s| gpu.add_scene(s).unwrap()).collect();
    assert_eq!(gpu.scene_count(), 2);
    // Views alternate between the houses, several per room centre.
    let mut views = Vec::new();
    for (plan, slot) in plans.iter().zip(&slots) {
        for (k, r) in plan.levels[0].rooms.iter().enumerate() {
            let c = [
                (r.rect.x0 + r.rect.x1) as f32 / 2.0,
                (r.rect.z0 + r.rect.z1) as f32 / 2.0,
            ];
            views.push(minos::render::gpu::View {
                scene: *slot,
                camera: Camera {
                    position: Vec3::new(c[0], 1.2, c[1]),
                    yaw: k as f32 * 1.3,
                    tilt: -0.1,
                    vfov_deg: 60.0,
                    width: 96,
                    height: 72,
                    near: 0.01,
                    far: 50.0,
                },
            });
        }
    }
    let (a, b): (Vec<View>, Vec<View>) = views.iter().partition(|v| v.scene == slots[0]);
    let mixed: Vec<View> = a
        .iter()
        .zip(&b)
        .flat_map(|(x, y)| [*x, *y])
        .chain(a.iter().skip(b.len()).copied())
        .chain(b.iter().skip(a.len()).copied())
        .collect();
    let frames = gpu.render_views(&mixed).unwrap();
    assert_eq!(frames.len(), mixed.len());
    let (mut equal, mut total) = (0usize, 0usize);
    for (v, f) in mixed.iter().zip(&frames) {
        let rs = &scenes[v.scene.0];
        // The same view alone in its own batch gives the same frame.
        let alone = gpu.render_views(std::slice::from_ref(v)).unwrap().remove(0);
        assert_eq!(f.tri, alone.tri, "a frame does not depend on its batch");
        // And it agrees with the CPU renderer as in the single-scene parity test.
        let c = cpu::render(rs, &v.camera);
        let (sc, sg) = (c.instance(rs), f.instance(rs));
        equal += sc.iter().zip(&sg).filter(|(x, y)| x == y).count();
        total += sc.len();
        assert!(f.tri.iter().any(|&t| t != minos::render::NO_HIT));
    }
    let share = equal as f64 / total as f64;
    eprintln!(
        "multi-scene batch: instances equal {:.3}% ({})",
        100.0 * share,
        gpu.adapter_name()
    );
    assert!(share >= 0.995, "{share}");
}

/// The images the GPU derives in its second pass (`render/gpu/derive.wgsl`) are those the CPU
/// derives from the same frame: labels, instances, rooms, room classes and normals exactly,
/// linear depth to single-precision rounding, colour within one level on a few pixels — for
/// textured generated houses, in one batch whose views alternate between two scenes. The ids
/// and depth of the batch are those of a batch that derives nothing.
#[test]
fn wgpu_derives_the_images_the_cpu_derives_from_its_frames() {
    use minos::render::{Channel, Channels};
    use minos::scene::Taxonomy;
    let mut gpu = match minos::render::gpu::GpuRenderer::new() {
        Ok(g) => g,
        Err(e) => {
            common::skip(e);
            return;
        }
    };
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    let cfg = minos::generate::GenerateConfig {
        houses: 2,
        seed: 4,
        rooms: (4, 6),
        levels: (1, 1),
        closed_door_prob: 0.25,
        ..Default::default()
    };
    let plans = common::generate_into(&cfg, &root);
    common::ingest_into(&root, &data);
    let scenes: Vec<RenderScene> = plans
        .iter()
        .map(|p| {
            RenderScene::new(
                &minos::store::DataDir::new(&data)
                    .read_scene(&p.id)
                    .unwrap()
                    .1,
            )
        })
        .collect();
    assert!(
        scenes.iter().all(|s| !s.textures.is_empty()),
        "textures are covered"
    );
    let slots: Vec<_> = scenes.iter().map(|s| gpu.add_scene(s).unwrap()).collect();
    let mut views = Vec::new();
    for k in 0..4 {
        for (plan, slot) in plans.iter().zip(&slots) {
            for r in &plan.levels[0].rooms {
                let c = [
                    (r.rect.x0 + r.rect.x1) as f32 / 2.0,
                    (r.rect.z0 + r.rect.z1) as f32 / 2.0,
                ];
                views.push(minos::render::gpu::View {
                    scene: *slot,
                    camera: Camera {
                        position: Vec3::new(c[0], 1.09, c[1]),
                        yaw: k as f32 * FRAC_PI_2 + 0.3,
                        tilt: -0.2,
                        vfov_deg: 60.0,
                        width: 84,
                        height: 66,
                        near: 0.01,
                        far: 50.0,
                    },
                });
            }
        }
    }
    let all = Channels::all();
    let derived = gpu.render_views_with(&views, all).unwrap();
    let plain = gpu.render_views(&views).unwrap();
    let (mut color_eq, mut color_n, mut hits) = (0usize, 0usize, 0usize);
    let mut depth_err = 0f32;
    for ((v, d), p) in views.iter().zip(&derived).zip(&plain) {
        assert_eq!(
            (&d.tri, &d.depth),
            (&p.tri, &p.depth),
            "deriving changes no frame"
        );
        assert!(p.derived.is_none());
        let got = d.derived.as_deref().expect("the GPU derived images");
        let rs = &scenes[v.scene.0];
        let cam = &v.camera;
        for t in [Taxonomy::Nyu40, Taxonomy::Mpcat40, Taxonomy::Coarse] {
            let slot = minos::render::derived::taxonomy_slot(t);
            assert!(all.contains(Channel::Semantic(t)));
            assert_eq!(
                got.semantic[slot].as_ref(),
                Some(&p.semantic(rs, t)),
                "{t:?}"
            );
        }
        assert_eq!(got.instance.as_ref(), Some(&p.instance(rs)));
        assert_eq!(got.room.as_ref(), Some(&p.room(rs)));
        assert_eq!(got.room_class.as_ref(), Some(&p.room_class(rs)));
        assert_eq!(got.normals.as_ref(), Some(&p.normals(rs)));
        let (dg, dc) = (got.linear_depth.as_ref().unwrap(), p.linear_depth(cam));
        for (a, b) in dg.iter().zip(&dc) {
            assert_eq!(*a == 0.0, *b == 0.0, "nothing hit in both or neither");
            depth_err = depth_err.max((a - b).abs() / b.max(1e-3));
        }
        let (cg, cc) = (got.color.as_ref().unwrap(), p.color(rs, cam));
        for (a, b) in cg.iter().zip(&cc) {
            for k in 0..3 {
                assert!(a[k].abs_diff(b[k]) <= 1, "colour {a:?} against {b:?}");
            }
            color_eq += usize::from(a == b);
            color_n += 1;
        }
        hits += p
            .tri
            .iter()
            .filter(|&&t| t != minos::render::NO_HIT)
            .count();
        // The frame's methods read the derived images.
        assert_eq!(&d.color(rs, cam), cg);
        assert_eq!(d.instance(rs), p.instance(rs));
    }
    let equal = color_eq as f64 / color_n as f64;
    eprintln!(
        "GPU derivation: colour equal on {:.3}% of pixels, depth within {depth_err:e} ({})",
        100.0 * equal,
        gpu.adapter_name()
    );
    assert!(hits > color_n / 2, "the cameras see the houses");
    // Bit for bit on lavapipe; within 2.8e-5 (relative: 0.03 mm at 1 m) on an NVIDIA H100,
    // whose shader compiler need not round as the CPU does (WGSL allows fused operations).
    assert!(depth_err < 1e-4, "{depth_err}");
    assert!(equal >= 0.999, "{equal}");
}

/// Simulators stepped together (`sim::batch::step_many`: motion in parallel, every camera in
/// one render call per shared renderer) observe exactly what each observes stepped alone, on
/// the CPU renderer and, where an adapter exists, on wgpu (one submission for all of them).
#[test]
fn stepping_many_simulators_at_once_observes_what_each_observes_alone() {
    use minos::sim::batch::step_many;
    let scene = walled_room(4.0, 0.2);
    let agent = AgentConfig::minos_continuous();
    let grid = build(&scene, &NavParams::for_body(agent.body)).unwrap();
    let assets = Arc::new(SceneAssets::new(&scene, grid, &agent).unwrap());
    let mut sensors = camera_suite(
        &[
            ("color", Modality::Color),
            ("depth", Modality::Depth),
            ("semantic", Modality::Semantic),
        ],
        24,
        -10.0,
    );
    sensors.contact = SensorSuite::minos(24).contact;
    let mut choices = vec![RendererChoice::Cpu];
    match minos::render::gpu::GpuRenderer::new() {
        Ok(_) => choices.push(RendererChoice::Wgpu),
        Err(e) => common::skip(format!("wgpu part: {e}")),
    }
    for choice in choices {
        let renderer = Arc::new(Renderer::new(choice, &assets.render).unwrap());
        let make = || {
            (0..5)
                .map(|k| {
                    let mut s = Simulator::new(
                        assets.clone(),
                        renderer.clone(),
                        agent,
                        sensors.clone(),
                        500,
                        7,
                    );
                    let p = Vec3::new(1.0 + k as f32 * 1.5, 0.0, 2.0 + 0.3 * k as f32);
                    s.reset(p, k as f32 * 1.1, None, &format!("ep{k}"));
                    s
                })
                .collect::<Vec<_>>()
        };
        let (mut alone, mut together) = (make(), make());
        let names = ["forward", "turn_left", "forward", "turn_right", "forward"];
        for t in 0..6 {
            let actions: Vec<Actions> = (0..5).map(|k| act(names[(k + t) % names.len()])).collect();
            let want: Vec<_> = alone
                .iter_mut()
                .zip(&actions)
                .map(|(s, a)| s.step(*a).unwrap())
                .collect();
            let mut refs: Vec<&mut Simulator> = together.iter_mut().collect();
            let got: Vec<_> = step_many(&mut refs, &actions)
                .into_iter()
                .map(|o| o.unwrap())
                .collect();
            assert_eq!(got, want, "{choice:?}, step {t}");
            // The agents see the room (an open one: some face its edge up close and see
            // nothing), each its own view.
            let near: Vec<usize> = got
                .iter()
                .map(|o| match o.images.iter().find(|(n, _)| n == "depth") {
                    Some((_, Image::F32 { data, .. })) => {
                        data.iter().filter(|&&d| d > 0.0 && d < 20.0).count()
                    }
                    _ => panic!("no float depth image"),
                })
                .collect();
            assert!(
                near.iter().filter(|&&n| n > 0).count() >= 3,
                "{choice:?}: {near:?}"
            );
            assert!(
                near.iter().any(|&n| n > 24 * 24 / 4),
                "{choice:?}: {near:?}"
            );
        }
        // The agents moved.
        for (k, s) in alone.iter().enumerate() {
            let start = Vec3::new(1.0 + k as f32 * 1.5, 0.0, 2.0 + 0.3 * k as f32);
            assert!(Vec3::from_array(s.state().position).distance(start) > 0.1);
        }
    }
}
