//! habitat-sim's public test assets (MIT) load as the issue describes: `simple_room.glb`
//! ingests, bakes with walkable floor and yields episodes; the test scene instance places its
//! objects where its config says; broken inputs give one-line errors naming file and record.
//! Gated on `MINOS_REAL_DATA` (the shared datasets folder); files are read in place or
//! copied into a temporary folder, never into the repository.

use crate::common;

use std::path::{Path, PathBuf};

use glam::Vec3;
use minos::episode::sample::{sample_scene, SampleConfig};
use minos::navmesh::build::build;
use minos::navmesh::NavParams;
use minos::pipeline::ingest::{ingest, DatasetFormat, IngestConfig, Outcome};
use minos::progress::NoProgress;
use minos::scene::formats::gltf_scene::{GltfLoader, STAGE_ROOM_ID};
use minos::scene::formats::DatasetLoader;
use minos::scene::formats::{load_mesh_file, SceneEntry};
use minos::scene::RoomClass;

fn real_data() -> Option<PathBuf> {
    match std::env::var_os("MINOS_REAL_DATA") {
        Some(p) => Some(PathBuf::from(p)),
        None => {
            common::skip("MINOS_REAL_DATA is not set");
            None
        }
    }
}

fn assets(data: &Path) -> PathBuf {
    data.join("gltf_habitat/test_assets")
}

fn entry(dir: &Path, id: &str, file: &str) -> SceneEntry {
    SceneEntry {
        id: id.into(),
        path: dir.join(file),
    }
}

#[test]
fn simple_room_ingests_bakes_with_walkable_floor_and_yields_episodes() {
    let Some(data) = real_data() else { return };
    let scenes = assets(&data).join("scenes");
    let loader = GltfLoader::open(&scenes, None).unwrap();
    let ids: Vec<String> = loader
        .discover()
        .unwrap()
        .into_iter()
        .map(|e| e.id)
        .collect();
    assert_eq!(ids, ["simple_room", "stage_floor1"]);
    let loaded = loader
        .load(&entry(&scenes, "simple_room", "simple_room.glb"))
        .unwrap();
    let scene = &loaded.scene;
    assert!(loaded
        .sources
        .iter()
        .any(|p| p.ends_with("simple_room.stage_config.json")));
    let level = &scene.levels[0];
    assert_eq!(level.ground.len(), 1, "the stage is one ground surface");
    assert!(level.objects.is_empty(), "Cube* nodes name no category");
    // The stage config says z-up: the floor slab (thin along the file's z) is horizontal in
    // minos, its top 0.0421 + 0.1034 m above the origin (the slab's z and half thickness).
    let room = &level.rooms[0];
    assert_eq!(room.id, STAGE_ROOM_ID);
    assert!(
        (room.floor_height - 0.1455).abs() < 1e-3,
        "{}",
        room.floor_height
    );
    let size = level.bbox.size();
    assert!(size.x > 10.0 && size.z > 10.0 && size.y < 3.0, "{size}");

    let grid = build(scene, &NavParams::default()).unwrap();
    let cell = grid.cell();
    let floor_spans = grid
        .spans
        .iter()
        .filter(|s| s.walkable && (s.y - room.floor_height).abs() < 0.01)
        .count();
    let area = floor_spans as f32 * cell * cell;
    // 10.5 m × 10.8 m of floor less the table, the box and the border.
    assert!(area > 90.0 && area < 114.0, "walkable floor {area} m²");
    assert!(grid
        .spans
        .iter()
        .filter(|s| s.walkable)
        .all(|s| s.room == 0));

    let cfg = SampleConfig {
        per_scene: 5,
        ..SampleConfig::default()
    };
    let episodes = sample_scene(&grid, "simple_room", "train", &cfg);
    assert_eq!(episodes.unusable, None);
    assert_eq!(episodes.episodes.len(), 5);
}

#[test]
fn ingest_compiles_every_test_asset_scene() {
    let Some(data) = real_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let cfg = IngestConfig {
        format: DatasetFormat::Gltf,
        root: assets(&data),
        data: minos::store::DataDir::new(dir.path().join("DATA")),
        ids: None,
        force: false,
        categories: Some(data.join("gltf_habitat/hm3d_semantics/hm3dsem_category_mappings.tsv")),
        models: None,
    };
    let report = ingest(&cfg, &NoProgress).unwrap();
    let ids: Vec<&str> = report.scenes.iter().map(|(r, _)| r.id.as_str()).collect();
    // chair.glb is an object asset, dataset_test_stage.glb the test scene's stage.
    assert_eq!(
        ids,
        [
            "5boxes",
            "dataset_test_scene",
            "simple_room",
            "stage_floor1"
        ]
    );
    assert_eq!(report.count(Outcome::Compiled), 4, "{:?}", report.scenes);
    let again = ingest(&cfg, &NoProgress).unwrap();
    assert_eq!(again.count(Outcome::UpToDate), 4);
}

#[test]
fn test_scene_instance_places_objects_where_its_config_says() {
    let Some(data) = real_data() else { return };
    let root = assets(&data).join("dataset_tests/dataset_0");
    let loader = GltfLoader::open(&root, None).unwrap();
    let ids: Vec<String> = loader
        .discover()
        .unwrap()
        .into_iter()
        .map(|e| e.id)
        .collect();
    assert_eq!(ids, ["dataset_test_scene"]);
    let si = root.join("scenes/dataset_test_scene.scene_instance.json");
    let loaded = loader
        .load(&entry(
            &root,
            "dataset_test_scene",
            "scenes/dataset_test_scene.scene_instance.json",
        ))
        .unwrap();
    let level = &loaded.scene.levels[0];

    // Stage: template `modified_test_stage` of the dataset config, whose scale [1, 1, 1]
    // overrides the stage config's [2, 2, 2].
    let ground = loaded.scene.meshes[level.ground[0] as usize].bounds();
    assert!((ground.max.x - 9.9988).abs() < 1e-3, "{:?}", ground);
    assert!(loaded
        .warnings
        .iter()
        .any(|w| w.contains("stage_instance translation/rotation/scale not applied")));

    // Objects: `asset_local`, so each asset's origin lands on its translation.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&si).unwrap()).unwrap();
    let instances = json["object_instances"].as_array().unwrap();
    assert_eq!(level.objects.len(), instances.len());
    for (object, inst) in level.objects.iter().zip(instances) {
        let t: Vec<f32> = inst["translation"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap() as f32)
            .collect();
        let template = inst["template_name"].as_str().unwrap();
        assert_eq!(object.model_id, template);
        let asset = load_mesh_file(&root.join(format!("objects/{template}.glb"))).unwrap();
        let expected_min = asset.bounds().min + Vec3::from_slice(&t);
        assert!(
            (object.bbox.min - expected_min).abs().max_element() < 1e-5,
            "{template}: {} vs {expected_min}",
            object.bbox.min
        );
    }
    // dataset_test_object1 (the donut): its glb's accessor minimum plus [0.1, 0.2, 0.3].
    let donut = &level.objects[0];
    let expected = Vec3::new(-0.11 + 0.1, -0.036_145 + 0.2, -0.108_265 + 0.3);
    assert!(
        (donut.bbox.min - expected).abs().max_element() < 1e-4,
        "{}",
        donut.bbox.min
    );

    // Rooms: the scene dataset's default semantic config, two labelled regions.
    let rooms: Vec<(&str, RoomClass)> = level
        .rooms
        .iter()
        .map(|r| (r.id.as_str(), r.class))
        .collect();
    assert_eq!(
        rooms,
        [
            ("test_region_negativeX", RoomClass::Bedroom),
            ("test_region_positiveX", RoomClass::Bathroom)
        ]
    );
    assert_eq!(level.rooms[0].floor_height, -2.0);
    assert_eq!(level.rooms[0].floor_polygon.as_ref().map(Vec::len), Some(6));
}

fn copy_simple_room(data: &Path, dir: &Path) {
    let scenes = assets(data).join("scenes");
    for f in ["simple_room.glb", "simple_room.stage_config.json"] {
        std::fs::copy(scenes.join(f), dir.join(f)).unwrap();
    }
}

fn load_error(dir: &Path, id: &str, file: &str) -> String {
    let loader = GltfLoader::open(dir, None).unwrap();
    let e = loader
        .load(&entry(dir, id, file))
        .expect_err("the scene must fail")
        .to_string();
    assert!(!e.contains('\n'), "one line: {e}");
    e
}

#[test]
fn broken_inputs_give_one_line_errors_naming_file_and_record() {
    let Some(data) = real_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();

    // A truncated GLB: its header declares more bytes than the file has.
    let glb = std::fs::read(assets(&data).join("scenes/simple_room.glb")).unwrap();
    std::fs::write(d.join("broken.glb"), &glb[..2000]).unwrap();
    let e = load_error(d, "broken", "broken.glb");
    assert!(
        e.starts_with(&format!(
            "{}: GLB header: declared length",
            d.join("broken.glb").display()
        )),
        "{e}"
    );
    // Garbage JSON inside a well-formed container.
    std::fs::write(
        d.join("broken.glb"),
        b"glTF\x02\0\0\0\x1c\0\0\0\x08\0\0\0JSON{\"asset\"",
    )
    .unwrap();
    let e = load_error(d, "broken", "broken.glb");
    assert!(e.contains("broken.glb: invalid glTF JSON: line 1"), "{e}");
    std::fs::remove_file(d.join("broken.glb")).unwrap();

    // A scene instance naming an object config that does not exist.
    copy_simple_room(&data, d);
    std::fs::write(
        d.join("x.scene_instance.json"),
        r#"{"stage_instance": {"template_name": "simple_room"},
            "object_instances": [{"template_name": "no_such_chair", "translation": [0, 0, 0]}]}"#,
    )
    .unwrap();
    let e = load_error(d, "x", "x.scene_instance.json");
    assert!(
        e.starts_with(&format!(
            "{}: node object_instances[0]: object template `no_such_chair` not found",
            d.join("x.scene_instance.json").display()
        )),
        "{e}"
    );
    std::fs::remove_file(d.join("x.scene_instance.json")).unwrap();

    // A bad line in the stage's semantic table (CRLF line ends are fine, the colour is not).
    std::fs::write(
        d.join("simple_room.semantic.txt"),
        "HM3D Semantic Annotations\r\n1,9A8A8A,\"wall\",0\r\n2,9A8A8,\"floor\",0\r\n",
    )
    .unwrap();
    let e = load_error(d, "simple_room", "simple_room.glb");
    assert!(
        e.starts_with(&format!(
            "{}: line 3: colour `9A8A8` is not 6 hex digits",
            d.join("simple_room.semantic.txt").display()
        )),
        "{e}"
    );
}
