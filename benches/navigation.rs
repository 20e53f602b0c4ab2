//! Navigation benchmarks: `cargo bench --bench navigation`.
//!
//! Bake time of a ~100 m² furnished level and of the largest generated multi-level house at
//! 5 cm cells (one core); one full distance field over ~1M spans; point-to-point path queries
//! on the largest house and on the furnished level, and the per-scene setup of the latter.
//! Prints Markdown rows for `docs/PERFORMANCE.md`.

use std::hint::black_box;
use std::time::Instant;

use glam::{Mat4, Vec3};
use minos::generate::{generate, GenerateConfig, OutputFormat};
use minos::navmesh::build::build;
use minos::navmesh::geodesic::distance_field;
use minos::navmesh::geodesic::Geodesic;
use minos::navmesh::path::{shortest_path, shortest_path_in};
use minos::navmesh::NavParams;
use minos::pipeline::ingest::{ingest, IngestConfig};
use minos::progress::NoProgress;
use minos::scene::{
    Aabb, Dataset, Level, Material, Mesh, Room, RoomClass, Scene, Surface, SurfaceKind,
};
use minos::seed::Rng;

fn best_ms(reps: usize, mut f: impl FnMut()) -> f64 {
    (0..reps)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .fold(f64::INFINITY, f64::min)
}

fn houses(cfg: &GenerateConfig, dir: &std::path::Path) -> Vec<Scene> {
    let root = dir.join("suncg");
    let data = dir.join("DATA");
    generate(cfg, OutputFormat::Suncg, &root, false, &NoProgress).expect("generate");
    let report = ingest(&IngestConfig::suncg(&root, &data), &NoProgress).expect("ingest");
    report
        .scenes
        .iter()
        .map(|(row, _)| {
            minos::store::DataDir::new(&data)
                .read_scene(&row.id)
                .expect("scene")
                .1
        })
        .collect()
}

fn flat_floor(side: f32) -> Scene {
    let mut mesh = Mesh {
        name: "floor".into(),
        positions: vec![
            [0.0, 0.0, 0.0],
            [0.0, 0.0, side],
            [side, 0.0, side],
            [side, 0.0, 0.0],
        ],
        indices: vec![0, 1, 2, 0, 2, 3],
        face_materials: vec![0, 0],
        materials: vec![Material::solid("f", [0.5, 0.5, 0.5])],
        ..Default::default()
    };
    mesh.compute_normals();
    let bbox = Aabb::from_corners(Vec3::ZERO, Vec3::new(side, 2.7, side));
    let _ = Mat4::IDENTITY;
    Scene {
        id: "flat".into(),
        dataset: Dataset::Suncg,
        levels: vec![Level {
            index: 0,
            bbox,
            floor_heights: vec![0.0],
            rooms: vec![Room {
                id: "r".into(),
                raw_types: vec![],
                class: RoomClass::Other,
                floor_polygon: None,
                surfaces: vec![Surface {
                    kind: SurfaceKind::Floor,
                    mesh: 0,
                }],
                area: side * side,
                floor_height: 0.0,
                bbox,
            }],
            objects: vec![],
            ground: vec![],
        }],
        meshes: vec![mesh],
    }
}

fn main() {
    // MINOS's 1.19 m body, as every figure in docs/PERFORMANCE.md was measured with it.
    let params = NavParams::for_body(minos::body::AgentBody::MINOS);
    let dir = tempfile::tempdir().expect("tempdir");
    println!("| measurement | scene | time |\n|---|---|---|");
    let single = houses(
        &GenerateConfig {
            houses: 40,
            seed: 2,
            rooms: (6, 9),
            levels: (1, 1),
            closed_door_prob: 0.25,
            ..Default::default()
        },
        &dir.path().join("a"),
    );
    let level = single
        .iter()
        .min_by(|a, b| {
            (a.floor_area() - 100.0)
                .abs()
                .total_cmp(&(b.floor_area() - 100.0).abs())
        })
        .expect("houses");
    let ms = best_ms(5, || {
        black_box(build(level, &params).expect("bake"));
    });
    println!(
        "| bake, 5 cm, 1 core | furnished level, {:.0} m², {} objects | {ms:.1} ms |",
        level.floor_area(),
        level.objects().count()
    );
    let multi = houses(
        &GenerateConfig {
            houses: 20,
            seed: 3,
            rooms: (24, 24),
            levels: (2, 2),
            closed_door_prob: 0.25,
            ..Default::default()
        },
        &dir.path().join("b"),
    );
    let big = multi
        .iter()
        .max_by(|a, b| a.floor_area().total_cmp(&b.floor_area()))
        .expect("houses");
    let ms = best_ms(3, || {
        black_box(build(big, &params).expect("bake"));
    });
    println!(
        "| bake, 5 cm, 1 core | {} levels, {:.0} m², {} objects | {ms:.1} ms |",
        big.levels.len(),
        big.floor_area(),
        big.objects().count()
    );
    let flat = flat_floor(50.0);
    let grid = build(&flat, &params).expect("bake");
    let goal = grid.snap(Vec3::new(25.0, 0.0, 25.0)).expect("centre");
    let ms = best_ms(3, || {
        black_box(distance_field(&grid, &[goal]));
    });
    println!(
        "| distance field, one goal | open floor, {} walkable spans | {ms:.1} ms |",
        grid.walkable_count()
    );
    let grid = build(big, &params).expect("bake");
    let island = (0..grid.islands.len())
        .max_by_key(|&i| grid.islands[i].spans)
        .expect("island") as u32;
    let spans = grid.walkable_spans(Some(island));
    let ms = best_ms(3, || {
        black_box(distance_field(&grid, &[spans[0]]));
    });
    println!(
        "| distance field, one goal | largest house, {} walkable spans | {ms:.1} ms |",
        grid.walkable_count()
    );
    let queries = 2_000;
    let mut rng = Rng::new(7);
    let pairs: Vec<(u32, u32)> = (0..queries)
        .map(|_| (*rng.pick(&spans).unwrap(), *rng.pick(&spans).unwrap()))
        .collect();
    let geo = Geodesic::new(&grid);
    let ms = best_ms(2, || {
        for &(a, b) in &pairs {
            black_box(shortest_path_in(&geo, a, b));
        }
    });
    println!(
        "| point-to-point paths (shared `Geodesic`) | largest house | {:.3} ms/query ({:.1} s per 100k) |",
        ms / queries as f64,
        ms / queries as f64 * 100.0
    );
    let one = best_ms(3, || {
        black_box(shortest_path(&grid, pairs[0].0, pairs[0].1));
    });
    println!("| one path query from scratch (`shortest_path`) | largest house | {one:.2} ms |");
    // A typical furnished single-level house (the ~100 m² level above): episode sampling
    // builds one `Geodesic` per scene and runs a few dozen queries on it.
    let small = build(level, &params).expect("bake");
    let island = (0..small.islands.len())
        .max_by_key(|&i| small.islands[i].spans)
        .expect("island") as u32;
    let spans = small.walkable_spans(Some(island));
    let pairs: Vec<(u32, u32)> = (0..queries)
        .map(|_| (*rng.pick(&spans).unwrap(), *rng.pick(&spans).unwrap()))
        .collect();
    let setup = best_ms(3, || {
        let geo = Geodesic::new(&small);
        black_box(shortest_path_in(&geo, pairs[0].0, pairs[0].1));
    });
    let geo = Geodesic::new(&small);
    let ms = best_ms(2, || {
        for &(a, b) in &pairs {
            black_box(shortest_path_in(&geo, a, b));
        }
    });
    println!(
        "| point-to-point paths (shared `Geodesic`) | furnished level, {:.0} m² | {:.3} ms/query ({:.1} s per 100k) |",
        level.floor_area(),
        ms / queries as f64,
        ms / queries as f64 * 100.0
    );
    println!(
        "| per-scene setup (`Geodesic::new` + first path) | furnished level, {:.0} m² | {setup:.2} ms |",
        level.floor_area()
    );
}
