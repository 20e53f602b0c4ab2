//! glTF scenes written by hand in a temporary folder: node transforms, categories from names
//! and `extras`, a z-up stage config, Habitat scene instances and object configs, and an HM3D
//! semantic table tied (or not) to geometry through vertex colours.

use std::path::Path;

use glam::Vec3;
use minos::navmesh::build::build;
use minos::navmesh::NavParams;
use minos::scene::formats::gltf_scene::{GltfLoader, STAGE_ROOM_ID};
use minos::scene::formats::DatasetLoader;
use minos::scene::formats::{LoadedScene, SceneEntry};
use minos::scene::{Aabb, RoomClass, Scene, SurfaceKind};
use serde_json::{json, Value};

/// A glTF under construction: one binary buffer, accessors, meshes, nodes.
#[derive(Default)]
struct Gltf {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
    nodes: Vec<Value>,
}

impl Gltf {
    fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()}));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    /// A mesh of one triangle primitive; returns its index.
    fn mesh(
        &mut self,
        positions: &[[f32; 3]],
        indices: &[u32],
        colors: Option<&[[u8; 4]]>,
    ) -> usize {
        let bytes: Vec<u8> = positions
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let view = self.view(&bytes);
        let min = (0..3)
            .map(|a| positions.iter().map(|p| p[a]).fold(f32::INFINITY, f32::min))
            .collect::<Vec<_>>();
        let max = (0..3)
            .map(|a| {
                positions
                    .iter()
                    .map(|p| p[a])
                    .fold(f32::NEG_INFINITY, f32::max)
            })
            .collect::<Vec<_>>();
        self.accessors.push(
            json!({"bufferView": view, "componentType": 5126, "count": positions.len(),
            "type": "VEC3", "min": min, "max": max}),
        );
        let pos = self.accessors.len() - 1;
        let bytes: Vec<u8> = indices.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors
            .push(json!({"bufferView": view, "componentType": 5125, "count": indices.len(), "type": "SCALAR"}));
        let idx = self.accessors.len() - 1;
        let mut attributes = json!({"POSITION": pos});
        if let Some(colors) = colors {
            let bytes: Vec<u8> = colors.iter().flatten().copied().collect();
            let view = self.view(&bytes);
            self.accessors.push(
                json!({"bufferView": view, "componentType": 5121, "normalized": true,
                "count": colors.len(), "type": "VEC4"}),
            );
            attributes["COLOR_0"] = json!(self.accessors.len() - 1);
        }
        self.meshes
            .push(json!({"primitives": [{"attributes": attributes, "indices": idx, "mode": 4}]}));
        self.meshes.len() - 1
    }

    fn node(&mut self, node: Value) -> usize {
        self.nodes.push(node);
        self.nodes.len() - 1
    }

    fn json(&self, roots: &[usize], uri: Option<String>) -> Value {
        let mut buffer = json!({"byteLength": self.bin.len()});
        if let Some(uri) = uri {
            buffer["uri"] = json!(uri);
        }
        json!({
            "asset": {"version": "2.0", "generator": "minos test"},
            "scene": 0,
            "scenes": [{"nodes": roots}],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [buffer],
        })
    }

    /// `.gltf` with the buffer embedded as a base64 data URI.
    fn write_gltf(&self, path: &Path, roots: &[usize]) {
        let uri = format!("data:application/octet-stream;base64,{}", base64(&self.bin));
        let text = serde_json::to_string_pretty(&self.json(roots, Some(uri))).unwrap();
        std::fs::write(path, text).unwrap();
    }

    /// `.glb`: header, JSON chunk, BIN chunk.
    fn write_glb(&self, path: &Path, roots: &[usize]) {
        let mut json = serde_json::to_vec(&self.json(roots, None)).unwrap();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let mut bin = self.bin.clone();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json);
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
        std::fs::write(path, out).unwrap();
    }
}

fn base64(bytes: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let n = (u32::from(c[0]) << 16)
            | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
            | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            if k <= c.len() {
                s.push(T[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// Unit cube [0, 1]³, outward counter-clockwise faces.
const CUBE: [[f32; 3]; 8] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 1.0],
    [1.0, 1.0, 1.0],
    [0.0, 1.0, 1.0],
];
const CUBE_INDICES: [u32; 36] = [
    0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4, 3, 7, 6, 3, 6, 2, 0, 4, 7, 0, 7, 3, 1, 2,
    6, 1, 6, 5,
];
/// A 4 m × 4 m floor at y = 0 facing +Y.
const FLOOR: [[f32; 3]; 4] = [
    [-2.0, 0.0, -2.0],
    [2.0, 0.0, -2.0],
    [2.0, 0.0, 2.0],
    [-2.0, 0.0, 2.0],
];
const FLOOR_INDICES: [u32; 6] = [0, 3, 2, 0, 2, 1];

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() < 1e-4
}

fn assert_box(b: &Aabb, min: [f32; 3], max: [f32; 3]) {
    assert!(
        close(b.min, Vec3::from(min)) && close(b.max, Vec3::from(max)),
        "box {:?}..{:?}, expected {min:?}..{max:?}",
        b.min,
        b.max
    );
}

fn load(root: &Path, id: &str, file: &str) -> LoadedScene {
    let loader = GltfLoader::open(root, None).expect("root opens");
    loader
        .load(&SceneEntry {
            id: id.into(),
            path: root.join(file),
        })
        .unwrap_or_else(|e| panic!("{file} loads: {e}"))
}

fn ground_bounds(scene: &Scene) -> Aabb {
    scene.levels[0].ground.iter().fold(Aabb::EMPTY, |b, &g| {
        b.union(&scene.meshes[g as usize].bounds())
    })
}

/// room.gltf: a floor, a chair (extras), a table under a translated group (name), a small cube
/// with no category.
fn write_room(dir: &Path) {
    let mut g = Gltf::default();
    let floor = g.mesh(&FLOOR, &FLOOR_INDICES, None);
    let cube = g.mesh(&CUBE, &CUBE_INDICES, None);
    let n_floor = g.node(json!({"name": "floor", "mesh": floor}));
    let n_chair = g.node(
        json!({"name": "chair_1", "mesh": cube, "translation": [1.0, 0.0, -1.0],
        "scale": [0.5, 0.8, 0.5], "extras": {"category": "chair"}}),
    );
    let n_table =
        g.node(json!({"name": "Table.002", "mesh": cube, "translation": [-1.5, 0.0, 0.0]}));
    let n_group =
        g.node(json!({"name": "group", "translation": [0.0, 0.0, 0.5], "children": [n_table]}));
    let n_cube = g.node(
        json!({"name": "Cube", "mesh": cube, "translation": [0.0, 0.0, -1.8],
        "scale": [0.2, 0.2, 0.2]}),
    );
    g.write_gltf(&dir.join("room.gltf"), &[n_floor, n_chair, n_group, n_cube]);
}

#[test]
fn node_transforms_and_categories_from_extras_and_names() {
    let dir = tempfile::tempdir().unwrap();
    write_room(dir.path());
    let loaded = load(dir.path(), "room", "room.gltf");
    let scene = &loaded.scene;
    assert_eq!(scene.id, "room");
    let level = &scene.levels[0];
    // The floor and the uncategorised cube are the stage surface; the chair and table are not.
    assert_eq!(level.ground.len(), 1);
    assert_box(&ground_bounds(scene), [-2.0, 0.0, -2.0], [2.0, 0.2, 2.0]);
    let ids: Vec<&str> = level.objects.iter().map(|o| o.id.as_str()).collect();
    assert_eq!(ids, ["chair_1", "Table.002"]);
    let chair = &level.objects[0];
    assert_eq!(chair.categories.fine.as_deref(), Some("chair"));
    assert_eq!(chair.model_id, "room#chair_1");
    assert_box(&chair.bbox, [1.0, 0.0, -1.0], [1.5, 0.8, -0.5]);
    // The table's box is its group's translation plus its own.
    let table = &level.objects[1];
    assert_eq!(table.categories.best(), "table");
    assert_box(&table.bbox, [-1.5, 0.0, 0.5], [-0.5, 1.0, 1.5]);
    // Object meshes are in model space; the transform places them.
    let world = scene.object_world_mesh(table).unwrap();
    assert_box(
        &Aabb::from_points(world.positions.iter().copied()),
        [-1.5, 0.0, 0.5],
        [-0.5, 1.0, 1.5],
    );
    // One room covers the stage: class other, floor at 0, the floor's area plus the cube top.
    assert_eq!(level.rooms.len(), 1);
    let room = &level.rooms[0];
    assert_eq!(room.id, STAGE_ROOM_ID);
    assert_eq!(room.class, RoomClass::Other);
    assert!(room.surfaces.is_empty());
    assert_eq!(room.floor_height, 0.0);
    assert!((room.area - 16.04).abs() < 1e-3, "area {}", room.area);
    assert!(level.objects.iter().all(|o| o.rooms == vec![0]));
    assert_eq!(level.floor_heights, vec![0.0]);
    assert!(loaded.sources.iter().any(|p| p.ends_with("room.gltf")));

    // The bake walks the floor, not the inside of the chair, and gives the floor to the room.
    let grid = build(scene, &NavParams::default()).unwrap();
    let span_at = |x: f32, z: f32| {
        let (ix, iz) = grid.cell_of(x, z);
        let c = grid.column(ix, iz).unwrap();
        grid.column_spans(c)
            .find(|&s| grid.spans[s].walkable && grid.spans[s].y.abs() < 0.01)
    };
    let open = span_at(-1.0, -1.0).expect("open floor is walkable");
    assert_eq!(grid.spans[open].room, 0);
    assert!(
        span_at(1.25, -0.75).is_none(),
        "the chair's footprint is blocked"
    );
}

#[test]
fn z_up_stage_config_rotates_and_scales_to_y_up() {
    let dir = tempfile::tempdir().unwrap();
    let mut g = Gltf::default();
    // z-up floor at z = 0.1 over x in [0, 4], y in [0, 2], facing +Z.
    let floor = g.mesh(
        &[
            [0.0, 0.0, 0.1],
            [4.0, 0.0, 0.1],
            [4.0, 2.0, 0.1],
            [0.0, 2.0, 0.1],
        ],
        &[0, 1, 2, 0, 2, 3],
        None,
    );
    let cube = g.mesh(&CUBE, &CUBE_INDICES, None);
    let n_floor = g.node(json!({"name": "Floor", "mesh": floor}));
    let n_sofa = g.node(json!({"name": "sofa_1", "mesh": cube, "translation": [1.0, 1.0, 0.1]}));
    g.write_glb(&dir.path().join("zup.glb"), &[n_floor, n_sofa]);
    std::fs::write(
        dir.path().join("zup.stage_config.json"),
        "{\r\n  \"render_asset\": \"zup.glb\",\r\n  \"up\": [0, 0, 1],\r\n  \"front\": [0, 1, 0],\r\n  \"scale\": [2, 2, 2]\r\n}\r\n",
    )
    .unwrap();
    let loaded = load(dir.path(), "zup", "zup.glb");
    let scene = &loaded.scene;
    // (x, y, z) z-up -> (x, z, -y) y-up, then doubled.
    assert_box(&ground_bounds(scene), [0.0, 0.2, -4.0], [8.0, 0.2, 0.0]);
    let sofa = &scene.levels[0].objects[0];
    assert_eq!(sofa.categories.best(), "sofa");
    assert_box(&sofa.bbox, [2.0, 0.2, -4.0], [4.0, 2.2, -2.0]);
    // The floor still faces up: it has area and sets the floor height.
    let room = &scene.levels[0].rooms[0];
    assert!((room.area - 32.0).abs() < 1e-3, "area {}", room.area);
    assert!((room.floor_height - 0.2).abs() < 1e-6);
    assert!(loaded
        .sources
        .iter()
        .any(|p| p.ends_with("zup.stage_config.json")));

    // The file alone as root: one scene, and its folder's stage config still applies.
    let single = GltfLoader::open(&dir.path().join("zup.glb"), None).unwrap();
    let entries = single.discover().unwrap();
    assert_eq!(entries.len(), 1);
    assert_eq!(entries[0].id, "zup");
    let again = single.load(&entries[0]).unwrap();
    assert_box(
        &ground_bounds(&again.scene),
        [0.0, 0.2, -4.0],
        [8.0, 0.2, 0.0],
    );
}

#[test]
fn scene_instances_place_objects_from_configs_and_discovery_skips_their_parts() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    write_room(root);
    let mut g = Gltf::default();
    let cube = g.mesh(&CUBE, &CUBE_INDICES, None);
    let n = g.node(json!({"name": "box", "mesh": cube}));
    std::fs::create_dir(root.join("objects")).unwrap();
    g.write_gltf(&root.join("objects/box.gltf"), &[n]);
    std::fs::write(
        root.join("objects/box.object_config.json"),
        r#"{"render_asset": "box.gltf", "mass": 1}"#,
    )
    .unwrap();
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let instance = json!({
        "translation_origin": "com",
        "stage_instance": {"template_name": "room"},
        "object_instances": [
            // 90° about +Y, [w, x, y, z]; asset origin at the translation.
            {"template_name": "box", "translation": [1.0, 0.0, 2.0], "rotation": [s, 0.0, s, 0.0],
             "non_uniform_scale": [2.0, 1.0, 1.0], "translation_origin": "asset_local", "motion_type": "STATIC"},
            // Same, centre of mass (box centre) at the translation (the scene default).
            {"template_name": "box", "translation": [-1.0, 0.5, -1.0], "rotation": [s, 0.0, s, 0.0],
             "non_uniform_scale": [2.0, 1.0, 1.0], "motion_type": "DYNAMIC"}
        ]
    });
    std::fs::write(
        root.join("house.scene_instance.json"),
        serde_json::to_string_pretty(&instance).unwrap(),
    )
    .unwrap();
    let loader = GltfLoader::open(root, None).unwrap();
    let ids: Vec<String> = loader
        .discover()
        .unwrap()
        .into_iter()
        .map(|e| e.id)
        .collect();
    // room.gltf is the house's stage and box.gltf an object asset: neither is a scene.
    assert_eq!(ids, ["house"]);
    let entry = SceneEntry {
        id: "house".into(),
        path: root.join("house.scene_instance.json"),
    };
    let loaded = loader.load(&entry).unwrap();
    let level = &loaded.scene.levels[0];
    let instances: Vec<_> = level
        .objects
        .iter()
        .filter(|o| o.id.starts_with("inst_"))
        .collect();
    assert_eq!(instances.len(), 2);
    assert_eq!(instances[0].model_id, "box");
    assert_box(&instances[0].bbox, [1.0, 0.0, 0.0], [2.0, 1.0, 2.0]);
    assert_box(&instances[1].bbox, [-1.5, 0.0, -2.0], [-0.5, 1.0, 0.0]);
    // One mesh for both instances.
    assert_eq!(instances[0].mesh, instances[1].mesh);
    // The stage still brings its own categorised nodes.
    assert!(level.objects.iter().any(|o| o.id == "chair_1"));
    assert!(loaded
        .sources
        .iter()
        .any(|p| p.ends_with("objects/box.object_config.json")));

    // A template whose config cannot be used fails the scene at the record that names it,
    // the config's own error kept as the cause.
    std::fs::write(
        root.join("objects/box.object_config.json"),
        r#"{"render_asset": "box.gltf", "up": [0, 1, 0], "front": [0, 1, 0]}"#,
    )
    .unwrap();
    let err = GltfLoader::open(root, None)
        .unwrap()
        .load(&entry)
        .expect_err("up and front are parallel");
    let minos::scene::formats::LoadError::Referenced { node, source, .. } = &err else {
        panic!("{err:?}")
    };
    assert!(node.contains("object_instances"), "{node}");
    assert!(
        source.to_string().contains("box.object_config.json"),
        "{source}"
    );
    let line = minos::escape::error_line(&err);
    assert_eq!(line.matches("box.object_config.json").count(), 1, "{line}");
}

/// sem.glb (floor + box) and, when `colored`, sem.semantic.glb with the same geometry
/// coloured by semantic id; sem.semantic.txt names floor (1), chair (2) and a lamp (3) that
/// has no geometry.
fn write_semantic_scene(dir: &Path, colored: bool) {
    let mut g = Gltf::default();
    let floor = g.mesh(&FLOOR, &FLOOR_INDICES, None);
    let cube = g.mesh(&CUBE, &CUBE_INDICES, None);
    let a = g.node(json!({"name": "scan_floor", "mesh": floor}));
    let b = g.node(json!({"name": "scan_blob", "mesh": cube}));
    g.write_glb(&dir.join("sem.glb"), &[a, b]);
    if colored {
        let mut s = Gltf::default();
        let floor = s.mesh(&FLOOR, &FLOOR_INDICES, Some(&[[0x10, 0x20, 0x30, 255]; 4]));
        let cube = s.mesh(&CUBE, &CUBE_INDICES, Some(&[[0xAB, 0xCD, 0xEF, 255]; 8]));
        let a = s.node(json!({"mesh": floor}));
        let b = s.node(json!({"mesh": cube}));
        s.write_glb(&dir.join("sem.semantic.glb"), &[a, b]);
    }
    std::fs::write(
        dir.join("sem.semantic.txt"),
        "HM3D Semantic Annotations\r\n1,102030,\"floor\",0\r\n2,ABCDEF,\"chair\",0  \r\n3,FFFFFF,\"lamp\",1\r\n",
    )
    .unwrap();
}

#[test]
fn semantic_ids_tied_by_vertex_colour_become_rooms_and_objects() {
    let dir = tempfile::tempdir().unwrap();
    write_semantic_scene(dir.path(), true);
    let loader = GltfLoader::open(dir.path(), None).unwrap();
    let ids: Vec<String> = loader
        .discover()
        .unwrap()
        .into_iter()
        .map(|e| e.id)
        .collect();
    assert_eq!(ids, ["sem"], "the semantic mesh is not a scene");
    let loaded = load(dir.path(), "sem", "sem.glb");
    let level = &loaded.scene.levels[0];
    assert_eq!(level.rooms.len(), 1);
    let room = &level.rooms[0];
    assert_eq!(room.id, "region_0");
    assert_eq!(room.surfaces.len(), 1);
    assert_eq!(room.surfaces[0].kind, SurfaceKind::Floor);
    assert!((room.area - 16.0).abs() < 1e-3, "area {}", room.area);
    assert_eq!(level.objects.len(), 1);
    let chair = &level.objects[0];
    assert_eq!(chair.id, "sem_2");
    assert_eq!(chair.categories.fine.as_deref(), Some("chair"));
    assert_eq!(chair.rooms, vec![0]);
    assert_box(&chair.bbox, [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
    // The render mesh stays the walkable ground.
    assert_eq!(level.ground.len(), 1);
    assert!(
        loaded
            .warnings
            .iter()
            .any(|w| w.contains("2 of 3 semantic ids tied")),
        "{:?}",
        loaded.warnings
    );
}

#[test]
fn semantic_table_without_coloured_mesh_is_validated_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    write_semantic_scene(dir.path(), false);
    let loaded = load(dir.path(), "sem", "sem.glb");
    let level = &loaded.scene.levels[0];
    assert_eq!(level.rooms.len(), 1);
    assert_eq!(level.rooms[0].id, STAGE_ROOM_ID);
    assert!(level.objects.is_empty());
    let warning = loaded
        .warnings
        .iter()
        .find(|w| w.contains("not tied to geometry"))
        .expect("a warning says the table was not tied");
    assert!(
        warning.contains("sem.semantic.txt: 3 semantic ids in 2 regions"),
        "{warning}"
    );
    assert!(loaded
        .sources
        .iter()
        .any(|p| p.ends_with("sem.semantic.txt")));

    // A bad line fails the scene with the file and the line.
    std::fs::write(
        dir.path().join("sem.semantic.txt"),
        "HM3D Semantic Annotations\n1,102030,\"floor\",0\n2,ABCDEF,\"chair\"\n",
    )
    .unwrap();
    let loader = GltfLoader::open(dir.path(), None).unwrap();
    let err = loader
        .load(&SceneEntry {
            id: "sem".into(),
            path: dir.path().join("sem.glb"),
        })
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("sem.semantic.txt: line 3: missing region id"),
        "{err}"
    );
    assert!(!err.contains('\n'));
}

#[test]
fn category_table_adds_coarse_and_mpcat40_labels() {
    let dir = tempfile::tempdir().unwrap();
    write_room(dir.path());
    std::fs::write(
        dir.path().join("test_category_mappings.tsv"),
        "raw_category\tcategory\tmpcat40\nchair\tchair\tchair\ntable\tdining table\ttable\n",
    )
    .unwrap();
    let loader = GltfLoader::open(dir.path(), None).unwrap();
    assert!(loader
        .category_table()
        .is_some_and(|p| p.ends_with("test_category_mappings.tsv")));
    let loaded = loader
        .load(&SceneEntry {
            id: "room".into(),
            path: dir.path().join("room.gltf"),
        })
        .unwrap();
    let table = &loaded.scene.levels[0].objects[1];
    assert_eq!(table.categories.coarse.as_deref(), Some("dining table"));
    assert_eq!(table.categories.mpcat40.as_deref(), Some("table"));
}

#[test]
fn missing_external_buffer_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let mut g = Gltf::default();
    let floor = g.mesh(&FLOOR, &FLOOR_INDICES, None);
    let n = g.node(json!({"mesh": floor}));
    let text = serde_json::to_string(&g.json(&[n], Some("floor.bin".into()))).unwrap();
    std::fs::write(dir.path().join("split.gltf"), text).unwrap();
    let loader = GltfLoader::open(dir.path(), None).unwrap();
    let e = loader
        .load(&SceneEntry {
            id: "split".into(),
            path: dir.path().join("split.gltf"),
        })
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("split.gltf: glTF buffers: buffers[0]: `floor.bin`"),
        "{e}"
    );
    // With the file beside it, it loads, and the .bin counts as a source.
    std::fs::write(dir.path().join("floor.bin"), &g.bin).unwrap();
    let loaded = loader
        .load(&SceneEntry {
            id: "split".into(),
            path: dir.path().join("split.gltf"),
        })
        .unwrap();
    assert!(loaded.sources.iter().any(|p| p.ends_with("floor.bin")));
}
