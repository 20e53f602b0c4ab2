//! Round-trip tests: export a hand-built scene, read it back with `tobj` / `gltf`, and compare
//! with what [`Scene::object_world_mesh`] and [`Scene::surface_world_mesh`] give.

use crate::file_error::FileError;
use std::collections::BTreeSet;
use std::fs;

use glam::{Mat4, Quat, Vec3};

use super::*;
use crate::scene::{
    Aabb, Categories, Dataset, Level, Material, MaterialOverride, Mesh, Object, ObjectFlags, Room,
    RoomClass, Scene, Surface, SurfaceKind,
};

const OVERRIDE: [f32; 4] = [0.1, 0.2, 0.9, 0.5];

/// A quad in the y = `y` plane facing +Y, already in world space.
fn quad(name: &str, material: &str, y: f32) -> Mesh {
    let mut m = Mesh {
        name: name.into(),
        positions: vec![[0.0, y, 0.0], [4.0, y, 0.0], [4.0, y, -3.0], [0.0, y, -3.0]],
        indices: vec![0, 1, 2, 0, 2, 3],
        face_materials: vec![0, 0],
        materials: vec![Material::solid(material, [0.6, 0.5, 0.3])],
        ..Default::default()
    };
    m.compute_normals();
    m
}

/// A model with two separate triangles in two material slots, and a third slot nobody uses.
fn chair() -> Mesh {
    let mut m = Mesh {
        name: "chair.obj".into(),
        positions: vec![
            [0.0, 0.0, 0.0],
            [0.5, 0.0, 0.0],
            [0.0, 0.8, 0.0],
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 0.5],
            [0.5, 0.0, 0.0],
        ],
        uvs: vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [0.0, 1.0],
            [0.0, 0.0],
            [0.0, 1.0],
            [1.0, 0.0],
        ],
        indices: vec![0, 1, 2, 3, 4, 5],
        face_materials: vec![0, 1],
        materials: vec![
            Material::solid("fabric", [0.8, 0.1, 0.1]),
            Material::solid("metal", [0.5, 0.5, 0.5]),
            Material::solid("unused", [0.0, 1.0, 0.0]),
        ],
        ..Default::default()
    };
    m.compute_normals();
    m
}

fn object(id: &str, categories: Categories, transform: Mat4) -> Object {
    Object {
        id: id.into(),
        model_id: "chair".into(),
        categories,
        transform,
        bbox: Aabb::EMPTY,
        mesh: Some(2),
        materials: Vec::new(),
        flags: ObjectFlags::default(),
        rooms: vec![0],
    }
}

fn mirror() -> Mat4 {
    Mat4::from_translation(Vec3::new(3.0, 0.0, -2.0)) * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0))
}

/// One level: a bedroom with a floor, a ground mesh, and two chairs sharing one mesh, the
/// second mirrored and with an override of slot 0.
fn scene() -> Scene {
    let plain = object(
        "0_1",
        Categories {
            fine: Some("chair".into()),
            ..Default::default()
        },
        Mat4::from_rotation_translation(
            Quat::from_rotation_y(30f32.to_radians()),
            Vec3::new(1.0, 0.0, -1.0),
        ),
    );
    let mut mirrored = object(
        "0_2",
        Categories {
            coarse: Some("armchair".into()),
            ..Default::default()
        },
        mirror(),
    );
    mirrored.materials.push(MaterialOverride {
        slot: 0,
        name: "blue fabric".into(),
        diffuse: Some(OVERRIDE),
        texture: Some("blue.png".into()),
    });
    let scene = Scene {
        id: "house1".into(),
        dataset: Dataset::Suncg,
        levels: vec![Level {
            index: 0,
            bbox: Aabb::EMPTY,
            floor_heights: vec![0.0],
            rooms: vec![Room {
                id: "0_0".into(),
                raw_types: vec!["Bedroom".into()],
                class: RoomClass::Bedroom,
                floor_polygon: None,
                surfaces: vec![Surface {
                    kind: SurfaceKind::Floor,
                    mesh: 0,
                }],
                area: 12.0,
                floor_height: 0.0,
                bbox: Aabb::EMPTY,
            }],
            objects: vec![plain, mirrored],
            ground: vec![1],
        }],
        meshes: vec![
            quad("floor", "floor wood", 0.0),
            quad("ground", "grass", -0.05),
            chair(),
        ],
    };
    assert_eq!(scene.validate(), Ok(()));
    assert!(mirror().determinant() < 0.0);
    scene
}

const NAMES: [&str; 4] = ["0_0 bedroom floor", "ground 0", "0_1 chair", "0_2 armchair"];

/// The world mesh of the part called `name`.
fn expected_world(scene: &Scene, name: &str) -> WorldMesh {
    let level = &scene.levels[0];
    match name {
        "0_0 bedroom floor" => scene.surface_world_mesh(0),
        "ground 0" => scene.surface_world_mesh(1),
        "0_1 chair" => scene.object_world_mesh(&level.objects[0]).expect("mesh"),
        "0_2 armchair" => scene.object_world_mesh(&level.objects[1]).expect("mesh"),
        other => panic!("unexpected part {other}"),
    }
}

/// The triangles of `world` as vertex positions, grouped by ascending material slot.
fn expected_triangles(world: &WorldMesh) -> Vec<[Vec3; 3]> {
    let mut slots: Vec<u16> = world.face_materials.clone();
    slots.sort_unstable();
    slots.dedup();
    let mut out = Vec::new();
    for slot in slots {
        for (t, tri) in world.indices.chunks_exact(3).enumerate() {
            if world.face_materials[t] == slot {
                out.push([0, 1, 2].map(|k| world.positions[tri[k] as usize]));
            }
        }
    }
    out
}

fn v3(a: &[f32], i: u32) -> Vec3 {
    let i = i as usize * 3;
    Vec3::new(a[i], a[i + 1], a[i + 2])
}

#[test]
fn obj_round_trip_matches_world_meshes() {
    let scene = scene();
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("sub").join("house1.obj");
    let summary = export_scene(&scene, ExportFormat::Obj, &out).expect("export");
    let mtl = dir.path().join("sub").join("house1.mtl");
    assert_eq!(summary.files, vec![out.clone(), mtl.clone()]);
    assert_eq!(summary.nodes, 4);
    assert_eq!(summary.triangles, scene.triangle_count());
    assert_eq!(summary.triangles, 8);
    assert!(summary.skipped.is_empty());
    let on_disk = fs::metadata(&out).expect("obj").len() + fs::metadata(&mtl).expect("mtl").len();
    assert_eq!(summary.bytes, on_disk);
    // Only the two final files: no temporaries left behind.
    assert_eq!(
        fs::read_dir(out.parent().expect("dir"))
            .expect("ls")
            .count(),
        2
    );
    let text = fs::read_to_string(&out).expect("read obj");
    assert!(text.lines().any(|l| l == "mtllib house1.mtl"), "{text}");

    let options = tobj::LoadOptions {
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let (models, materials) = tobj::load_obj(&out, &options).expect("tobj");
    let materials = materials.expect("mtl loads");
    // One model per (group, material): the chairs use two slots each.
    assert_eq!(models.len(), 6);
    let names: BTreeSet<&str> = models.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, NAMES.into_iter().collect());
    let total: usize = models.iter().map(|m| m.mesh.indices.len() / 3).sum();
    assert_eq!(total as u64, scene.triangle_count());

    for name in NAMES {
        let world = expected_world(&scene, name);
        let mut got = Vec::new();
        for m in models.iter().filter(|m| m.name == name) {
            let mesh = &m.mesh;
            assert_eq!(
                mesh.normal_indices.len(),
                mesh.indices.len(),
                "{name}: normals"
            );
            for (tri, ntri) in mesh
                .indices
                .chunks_exact(3)
                .zip(mesh.normal_indices.chunks_exact(3))
            {
                let p = [0, 1, 2].map(|k| v3(&mesh.positions, tri[k]));
                let geometric = (p[1] - p[0]).cross(p[2] - p[0]);
                for &n in ntri {
                    let stored = v3(&mesh.normals, n);
                    assert!(
                        geometric.dot(stored) > 0.0,
                        "{name}: face turned away from its normal"
                    );
                }
                got.push(p);
            }
        }
        // Exact equality, winding (vertex order) included.
        assert_eq!(got, expected_triangles(&world), "{name}");
    }

    // Materials: unique, no whitespace, override applied to the mirrored chair's slot 0 only.
    let mat_names: BTreeSet<&str> = materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(mat_names.len(), materials.len());
    assert!(mat_names.iter().all(|n| !n.contains(char::is_whitespace)));
    assert_eq!(
        mat_names,
        ["blue_fabric", "fabric", "floor_wood", "grass", "metal"]
            .into_iter()
            .collect()
    );
    let blue = materials
        .iter()
        .position(|m| m.name == "blue_fabric")
        .expect("override");
    assert_eq!(materials[blue].diffuse, Some([0.1, 0.2, 0.9]));
    assert_eq!(materials[blue].dissolve, Some(0.5));
    let fabric = materials
        .iter()
        .find(|m| m.name == "fabric")
        .expect("fabric");
    assert_eq!(fabric.diffuse, Some([0.8, 0.1, 0.1]));
    assert_eq!(fabric.dissolve, None);
    let mirrored_mats: BTreeSet<usize> = models
        .iter()
        .filter(|m| m.name == "0_2 armchair")
        .filter_map(|m| m.mesh.material_id)
        .collect();
    assert!(mirrored_mats.contains(&blue));
    let plain_mats: BTreeSet<usize> = models
        .iter()
        .filter(|m| m.name == "0_1 chair")
        .filter_map(|m| m.mesh.material_id)
        .collect();
    assert!(!plain_mats.contains(&blue));
    let mtl_text = fs::read_to_string(&mtl).expect("read mtl");
    assert!(mtl_text.contains("# map_Kd blue.png"), "{mtl_text}");
    assert!(!mtl_text.lines().any(|l| l.starts_with("map_Kd")));
}

#[test]
fn glb_round_trip_matches_world_meshes() {
    let scene = scene();
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("house1.glb");
    let summary = export_scene(&scene, ExportFormat::Glb, &out).expect("export");
    let bytes = fs::read(&out).expect("read glb");
    assert_eq!(summary.bytes, bytes.len() as u64);
    assert_eq!(summary.files, vec![out.clone()]);
    assert_eq!(summary.nodes, 4);
    assert_eq!(summary.triangles, scene.triangle_count());
    assert_eq!(fs::read_dir(dir.path()).expect("ls").count(), 1);

    // `from_slice` validates the document (e.g. POSITION accessors must have min/max).
    let gltf = gltf::Gltf::from_slice(&bytes).expect("valid glb");
    assert_eq!(
        gltf.document.as_json().asset.generator.as_deref(),
        Some("minos")
    );
    let root_scene = gltf.default_scene().expect("default scene");
    let levels: Vec<_> = root_scene.nodes().collect();
    assert_eq!(levels.len(), 1);
    assert_eq!(levels[0].name(), Some("level 0"));
    let children: BTreeSet<&str> = levels[0].children().filter_map(|n| n.name()).collect();
    assert_eq!(children, NAMES.into_iter().collect());

    let (doc, buffers, _) = gltf::import_slice(&bytes).expect("import");
    let mut triangles = 0;
    let mut seen = BTreeSet::new();
    for node in doc.nodes() {
        let Some(mesh) = node.mesh() else { continue };
        let name = node.name().expect("named");
        seen.insert(name.to_string());
        assert!(node.transform().matrix() == Mat4::IDENTITY.to_cols_array_2d());
        let world = expected_world(&scene, name);
        let mut got = Vec::new();
        for prim in mesh.primitives() {
            assert_eq!(prim.mode(), gltf::mesh::Mode::Triangles);
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| d.0.as_slice()));
            let positions: Vec<Vec3> = reader
                .read_positions()
                .expect("positions")
                .map(Vec3::from_array)
                .collect();
            assert_eq!(positions, world.positions, "{name}");
            let normals: Vec<Vec3> = reader
                .read_normals()
                .expect("normals")
                .map(Vec3::from_array)
                .collect();
            // Accessor min/max equal the true bounds of the positions.
            let acc = prim.get(&gltf::Semantic::Positions).expect("POSITION");
            let min: [f32; 3] = serde_json::from_value(acc.min().expect("min")).expect("min");
            let max: [f32; 3] = serde_json::from_value(acc.max().expect("max")).expect("max");
            let lo = positions.iter().fold(Vec3::INFINITY, |a, &p| a.min(p));
            let hi = positions.iter().fold(Vec3::NEG_INFINITY, |a, &p| a.max(p));
            assert_eq!((Vec3::from(min), Vec3::from(max)), (lo, hi), "{name}");
            let indices: Vec<u32> = reader.read_indices().expect("indices").into_u32().collect();
            for tri in indices.chunks_exact(3) {
                let p = [0, 1, 2].map(|k| positions[tri[k] as usize]);
                let geometric = (p[1] - p[0]).cross(p[2] - p[0]);
                for &i in tri {
                    assert!(
                        geometric.dot(normals[i as usize]) > 0.0,
                        "{name}: face turned away"
                    );
                }
                got.push(p);
            }
            triangles += indices.len() / 3;
        }
        assert_eq!(got, expected_triangles(&world), "{name}");
        if name.starts_with("0_") && name != "0_0 bedroom floor" {
            // The chairs: one primitive per used slot (the unused third slot has none).
            assert_eq!(mesh.primitives().count(), 2, "{name}");
        }
    }
    assert_eq!(seen, NAMES.iter().map(|s| s.to_string()).collect());
    assert_eq!(triangles as u64, scene.triangle_count());

    // The override colour, translucent, on the mirrored chair's first primitive only.
    let material_of = |node_name: &str| {
        let node = doc
            .nodes()
            .find(|n| n.name() == Some(node_name))
            .expect("node");
        let mesh = node.mesh().expect("mesh");
        let first = mesh.primitives().next().expect("primitive");
        let m = first.material();
        (
            m.pbr_metallic_roughness().base_color_factor(),
            m.alpha_mode(),
        )
    };
    assert_eq!(
        material_of("0_2 armchair"),
        (OVERRIDE, gltf::material::AlphaMode::Blend)
    );
    assert_eq!(
        material_of("0_1 chair"),
        ([0.8, 0.1, 0.1, 1.0], gltf::material::AlphaMode::Opaque)
    );
}

#[test]
fn formats_parse_and_infer_from_extensions() {
    assert_eq!(
        ExportFormat::from_path(Path::new("a/b.OBJ")),
        Some(ExportFormat::Obj)
    );
    assert_eq!(
        ExportFormat::from_path(Path::new("b.glb")),
        Some(ExportFormat::Glb)
    );
    assert_eq!(ExportFormat::from_path(Path::new("b.gltf")), None);
    assert_eq!(ExportFormat::from_path(Path::new("b")), None);
    assert_eq!("glb".parse::<ExportFormat>(), Ok(ExportFormat::Glb));
    assert!("ply"
        .parse::<ExportFormat>()
        .unwrap_err()
        .to_string()
        .contains("ply"));
    assert_eq!(ExportFormat::Obj.to_string(), "obj");
}

#[test]
fn material_names_are_sanitized_and_unique() {
    let mut table = MaterialTable::default();
    let red = Material::solid("my paint", [1.0, 0.0, 0.0]);
    let green = Material::solid("my paint", [0.0, 1.0, 0.0]);
    let a = table.add(Some(&red), None);
    let b = table.add(Some(&green), None);
    assert_eq!(
        table.add(Some(&red), None),
        a,
        "identical materials are shared"
    );
    assert_ne!(a, b);
    assert_eq!(table.materials[a].name, "my_paint");
    assert_eq!(table.materials[b].name, "my_paint_2");
    let odd = table.add(Some(&Material::solid(" \t#\n", [0.0; 3])), None);
    assert_eq!(table.materials[odd].name, "_");
    let empty = table.add(Some(&Material::solid("", [0.0; 3])), None);
    assert_eq!(table.materials[empty].name, "material");
}

#[test]
fn invalid_scene_is_refused_and_writes_nothing() {
    let mut scene = scene();
    scene.levels[0].objects[0].mesh = Some(99);
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("bad.glb");
    let err = export_scene(&scene, ExportFormat::Glb, &out).expect_err("invalid");
    let msg = err.to_string();
    assert!(
        msg.contains("bad.glb") && msg.contains("out of range"),
        "{msg}"
    );
    assert!(!out.exists());
}

#[test]
fn io_errors_name_the_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let blocker = dir.path().join("file");
    fs::write(&blocker, b"x").expect("write");
    let out = blocker.join("house1.obj");
    let err = export_scene(&scene(), ExportFormat::Obj, &out).expect_err("parent is a file");
    assert!(matches!(err, ExportError::Io(FileError { .. })), "{err:?}");
    assert!(
        err.to_string().contains(&blocker.display().to_string()),
        "{err}"
    );

    let mtl_out = dir.path().join("house1.mtl");
    let err = export_scene(&scene(), ExportFormat::Obj, &mtl_out).expect_err("name clash");
    assert!(err.to_string().contains("house1.mtl"), "{err}");
    assert!(!mtl_out.exists());
}

#[test]
fn non_finite_parts_are_skipped_not_written() {
    let mut scene = scene();
    // A finite transform whose placed vertices overflow f32 (a NaN or infinite transform is
    // refused earlier, by the scene's validation).
    scene.levels[0].objects[0].transform =
        Mat4::from_translation(Vec3::new(3e38, 0.0, 0.0)) * Mat4::from_scale(Vec3::splat(1e38));
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("house1.glb");
    let summary = export_scene(&scene, ExportFormat::Glb, &out).expect("export");
    assert_eq!(summary.skipped, vec!["0_1 chair".to_string()]);
    assert_eq!(summary.nodes, 3);
    assert_eq!(summary.triangles, 6);
    let bytes = fs::read(&out).expect("read");
    let gltf = gltf::Gltf::from_slice(&bytes).expect("still valid");
    assert!(gltf.nodes().all(|n| n.name() != Some("0_1 chair")));
}
