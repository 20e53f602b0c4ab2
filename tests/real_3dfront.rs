//! The real 3D-FRONT sample scene loads, bakes and yields episodes. Gated on `MINOS_REAL_DATA`
//! (set by `.ci/run` to `../shared/datasets` when that folder exists); the expected counts are
//! computed here from the scene JSON itself with serde_json, not copied from the dataset.

use crate::common;

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::PathBuf;

use minos::episode::sample::{sample_scene, SampleConfig};
use minos::episode::Task;
use minos::navmesh::build::build;
use minos::navmesh::NavParams;
use minos::scene::formats::threedfront::ThreeDFrontLoader;
use minos::scene::formats::DatasetLoader;
use minos::scene::{RoomClass, SurfaceKind};
use serde_json::Value;

const SCENE: &str = "0a17c68b-b74d-4d81-afe4-bc2ed405f0ec";

fn real_data() -> Option<PathBuf> {
    match std::env::var_os("MINOS_REAL_DATA") {
        Some(p) => Some(PathBuf::from(p)),
        None => {
            common::skip("MINOS_REAL_DATA is not set");
            None
        }
    }
}

/// Floor area of a mesh record counted independently: upward triangles projected on XZ.
fn up_area(mesh: &Value) -> f64 {
    let xyz: Vec<f64> = mesh["xyz"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let faces: Vec<usize> = mesh["faces"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap() as usize)
        .collect();
    let p = |i: usize| [xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]];
    faces
        .chunks(3)
        .map(|t| {
            let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
            let (u, v) = (
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
            );
            let n = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if n[1] > 0.7 * len {
                n[1] / 2.0
            } else {
                0.0
            }
        })
        .sum()
}

#[test]
fn real_3dfront_scene_ingests_bakes_and_yields_episodes() {
    let Some(data) = real_data() else { return };
    let root = data.join("3dfront").join("scenes");
    let loader = ThreeDFrontLoader::open(&root, None, None).expect("loader");
    assert!(loader
        .mapping_path()
        .is_some_and(|p| p.ends_with("3D-FUTURE_ModelCategoryMapping.csv")));
    assert!(loader.categories().len() > 10_000);
    let entries = loader.discover().expect("discover");
    let entry = entries
        .iter()
        .find(|e| e.id == SCENE)
        .expect("the sample is discovered");
    let start = std::time::Instant::now();
    let loaded = loader.load(entry).expect("the real scene loads");
    eprintln!("load: {:.1} ms", start.elapsed().as_secs_f64() * 1e3);
    let scene = &loaded.scene;
    assert!(scene.validate().is_ok());

    // Independent counts from the JSON.
    let json: Value = serde_json::from_slice(&std::fs::read(&entry.path).unwrap()).unwrap();
    let rooms = json["scene"]["room"].as_array().unwrap();
    let meshes: HashMap<&str, &Value> = json["mesh"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| (m["uid"].as_str().unwrap(), m))
        .collect();
    let furniture: HashMap<&str, &Value> = json["furniture"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| (f["uid"].as_str().unwrap(), f))
        .collect();
    let level = &scene.levels[0];
    assert_eq!(scene.levels.len(), 1);
    assert_eq!(level.rooms.len(), rooms.len());
    // Room types seen in the sample and their MINOS classes.
    let expected: BTreeMap<&str, RoomClass> = [
        ("Balcony", RoomClass::Outdoor),
        ("LivingDiningRoom", RoomClass::LivingRoom),
        ("Kitchen", RoomClass::Kitchen),
        ("StorageRoom", RoomClass::Other),
        ("Bathroom", RoomClass::Bathroom),
        ("Bedroom", RoomClass::Bedroom),
    ]
    .into_iter()
    .collect();
    let mut want_objects = HashSet::new();
    for (room, r) in level.rooms.iter().zip(rooms) {
        let kind = r["type"].as_str().unwrap();
        assert_eq!(room.id, r["instanceid"].as_str().unwrap());
        assert_eq!(room.raw_types, vec![kind.to_string()]);
        assert_eq!(Some(&room.class), expected.get(kind), "{kind}");
        let mut area = 0.0;
        for c in r["children"].as_array().unwrap() {
            let reference = c["ref"].as_str().unwrap();
            let id = c["instanceid"].as_str().unwrap();
            if let Some(m) = meshes.get(reference) {
                match m["type"].as_str().unwrap() {
                    "Floor" => area += up_area(m),
                    "Door" | "Window" | "Hole" => {
                        want_objects.insert(id);
                    }
                    _ => {}
                }
            } else if let Some(f) = furniture.get(reference) {
                if f["valid"] != Value::Bool(false) {
                    want_objects.insert(id);
                }
            }
        }
        assert!(
            (f64::from(room.area) - area).abs() < 1e-3 * area.max(1.0),
            "{}: {} vs {area}",
            room.id,
            room.area
        );
        assert!(room.area > 1.0, "{} has no floor", room.id);
        assert!(room.surfaces.iter().any(|s| s.kind == SurfaceKind::Floor));
        assert!(room.surfaces.iter().any(|s| s.kind == SurfaceKind::Wall));
    }
    let got_objects: HashSet<&str> = level.objects.iter().map(|o| o.id.as_str()).collect();
    assert_eq!(got_objects, want_objects);
    assert_eq!(
        level.objects.len(),
        want_objects.len(),
        "object ids are unique"
    );
    // Door and window openings are flagged; furniture listed in the mapping has a
    // super-category.
    assert!(level.objects.iter().filter(|o| o.flags.door).count() >= 10);
    assert!(level.objects.iter().any(|o| o.flags.window));
    assert!(level.objects.iter().any(|o| o.flags.arch));
    for o in level.objects.iter().filter(|o| o.mesh.is_some()) {
        assert!(o.bbox.is_finite(), "{}", o.id);
    }
    assert!(level
        .objects
        .iter()
        .filter(|o| loader.categories().get(&o.model_id).is_some())
        .all(|o| o.categories.coarse.is_some()));
    // Mirrored furniture keep their faces outward.
    let mirrored: Vec<_> = level
        .objects
        .iter()
        .filter(|o| o.mesh.is_some() && o.transform.determinant() < 0.0)
        .collect();
    assert!(!mirrored.is_empty());
    for o in mirrored {
        let w = scene.object_world_mesh(o).unwrap();
        for t in 0..w.indices.len() / 3 {
            let n = w.face_normal(t);
            let p = w.positions[w.indices[3 * t] as usize];
            assert!(n.dot(p - o.bbox.center()) > 0.0, "{} face {t}", o.id);
        }
    }

    // Bake: a sensible share of the floor is walkable, every room but the cluttered ones has
    // walkable floor, and the floor lies at y = 0.
    let grid = build(scene, &NavParams::default()).expect("bakes");
    let floor: f32 = level.rooms.iter().map(|r| r.area).sum();
    let walkable = grid.walkable_count() as f32 * grid.cell() * grid.cell();
    eprintln!("floor {floor:.1} m², walkable {walkable:.1} m²");
    assert!(
        walkable > 0.35 * floor && walkable < floor,
        "{walkable} of {floor}"
    );
    let with_floor = (0..grid.rooms.len() as u32)
        .filter(|&r| !grid.room_spans(r).is_empty())
        .count();
    assert_eq!(with_floor, grid.rooms.len());
    for (r, room) in level.rooms.iter().enumerate() {
        let spans = grid.room_spans(r as u32);
        eprintln!(
            "{}: {:.1} of {:.1} m² walkable",
            room.id,
            spans.len() as f32 * grid.cell() * grid.cell(),
            room.area
        );
        assert!(spans.iter().all(|&s| grid.spans[s as usize].y.abs() < 0.05));
    }

    for task in [Task::PointGoal, Task::RoomGoal] {
        let cfg = SampleConfig {
            task,
            per_scene: 5,
            ..SampleConfig::default()
        };
        let out = sample_scene(&grid, SCENE, "train", &cfg);
        assert!(out.unusable.is_none(), "{task:?}: {:?}", out.unusable);
        assert!(!out.episodes.is_empty(), "{task:?}: {:?}", out.rejected);
    }
}
