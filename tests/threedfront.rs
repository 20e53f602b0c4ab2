//! The 3D-FRONT loader on a small hand-made scene written by the test (no dataset content):
//! two rooms joined by a doorway, walls, a window, furniture with a negative scale, boxes vs
//! 3D-FUTURE meshes, categories, the bake and episodes on top, and the bad-input rules (one
//! line naming file, record and field; never a panic).

use std::path::{Path, PathBuf};

use glam::Vec3;
use minos::episode::sample::{sample_scene, SampleConfig};
use minos::episode::Task;
use minos::navmesh::build::build;
use minos::navmesh::path::shortest_path;
use minos::navmesh::{NavGrid, NavParams};
use minos::pipeline::ingest::{ingest, DatasetFormat, IngestConfig, Outcome};
use minos::progress::NoProgress;
use minos::scene::formats::threedfront::{parse_scene, ThreeDFrontLoader};
use minos::scene::formats::DatasetLoader;
use minos::scene::formats::{LoadError, LoadedScene, SceneEntry};
use minos::scene::{Object, RoomClass, Scene, SurfaceKind};
use serde_json::{json, Value};

/// Triangles of an architecture mesh being written.
#[derive(Default)]
struct Geo {
    xyz: Vec<f32>,
    normal: Vec<f32>,
    faces: Vec<u32>,
}

impl Geo {
    /// A quad whose front faces `normal` (corners in any consistent order).
    fn quad(&mut self, mut p: [[f32; 3]; 4], normal: [f32; 3]) -> &mut Self {
        let v = |a: [f32; 3]| Vec3::from_array(a);
        let n = (v(p[1]) - v(p[0])).cross(v(p[2]) - v(p[0]));
        if n.dot(v(normal)) < 0.0 {
            p.reverse();
        }
        let base = (self.xyz.len() / 3) as u32;
        for c in p {
            self.xyz.extend(c);
            self.normal.extend(normal);
        }
        self.faces
            .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
        self
    }

    /// A horizontal quad at height `y` facing up (or down).
    fn flat(&mut self, x: [f32; 2], z: [f32; 2], y: f32, up: bool) -> &mut Self {
        self.quad(
            [
                [x[0], y, z[0]],
                [x[1], y, z[0]],
                [x[1], y, z[1]],
                [x[0], y, z[1]],
            ],
            [0.0, if up { 1.0 } else { -1.0 }, 0.0],
        )
    }

    /// The six outward faces of a box.
    fn cuboid(&mut self, min: [f32; 3], max: [f32; 3]) -> &mut Self {
        let (x, y, z) = ([min[0], max[0]], [min[1], max[1]], [min[2], max[2]]);
        self.flat(x, z, y[1], true).flat(x, z, y[0], false);
        for (xx, n) in [(x[0], -1.0), (x[1], 1.0)] {
            self.quad(
                [
                    [xx, y[0], z[0]],
                    [xx, y[1], z[0]],
                    [xx, y[1], z[1]],
                    [xx, y[0], z[1]],
                ],
                [n, 0.0, 0.0],
            );
        }
        for (zz, n) in [(z[0], -1.0), (z[1], 1.0)] {
            self.quad(
                [
                    [x[0], y[0], zz],
                    [x[1], y[0], zz],
                    [x[1], y[1], zz],
                    [x[0], y[1], zz],
                ],
                [0.0, 0.0, n],
            );
        }
        self
    }

    fn mesh(&self, uid: &str, kind: &str) -> Value {
        json!({"uid": uid, "jid": "", "aid": [], "type": kind, "xyz": self.xyz,
               "normal": self.normal, "uv": [], "faces": self.faces, "material": "mat/wall"})
    }
}

fn geo() -> Geo {
    Geo::default()
}

fn child(r: &str, id: &str) -> Value {
    json!({"ref": r, "instanceid": id, "pos": [0, 0, 0], "rot": [0, 0, 0, 1], "scale": [1, 1, 1]})
}

/// Room A: x 0..4, room B: x 4.2..8.2, both z 0..4, 2.6 m high; a 0.2 m wall between them
/// with a 1 m doorway (z 1.5..2.5, 2.1 m high); a window in A's south wall.
fn house() -> Value {
    let h = 2.6;
    let mut meshes = vec![
        geo()
            .flat([0.0, 4.0], [0.0, 4.0], 0.0, true)
            .mesh("floor/a", "Floor"),
        geo()
            .flat([4.2, 8.2], [0.0, 4.0], 0.0, true)
            .mesh("floor/b", "Floor"),
        geo()
            .flat([0.0, 4.0], [0.0, 4.0], h, false)
            .mesh("ceil/a", "Ceiling"),
        geo()
            .flat([4.2, 8.2], [0.0, 4.0], h, false)
            .mesh("ceil/b", "Ceiling"),
        geo()
            .cuboid([-0.2, 0.0, -0.2], [0.0, h, 4.2])
            .cuboid([-0.2, 0.0, -0.2], [8.4, h, 0.0])
            .cuboid([-0.2, 0.0, 4.0], [8.4, h, 4.2])
            .mesh("wall/a", "WallInner"),
        geo()
            .cuboid([4.0, 0.0, 0.0], [4.2, h, 1.5])
            .cuboid([4.0, 0.0, 2.5], [4.2, h, 4.0])
            .cuboid([4.0, 2.1, 1.5], [4.2, h, 2.5])
            .mesh("wall/between", "WallOuter"),
        geo()
            .cuboid([8.2, 0.0, -0.2], [8.4, h, 4.2])
            .mesh("wall/b", "WallInner"),
        geo()
            .flat([4.0, 4.2], [0.0, 4.0], 0.0, false)
            .mesh("base/b", "Baseboard"),
    ];
    // The doorway's reveal (jambs and the header's underside) and its threshold.
    let mut reveal = geo();
    reveal
        .quad(
            [
                [4.0, 0.0, 1.5],
                [4.2, 0.0, 1.5],
                [4.2, 2.1, 1.5],
                [4.0, 2.1, 1.5],
            ],
            [0.0, 0.0, 1.0],
        )
        .quad(
            [
                [4.0, 0.0, 2.5],
                [4.2, 0.0, 2.5],
                [4.2, 2.1, 2.5],
                [4.0, 2.1, 2.5],
            ],
            [0.0, 0.0, -1.0],
        )
        .flat([4.0, 4.2], [1.5, 2.5], 2.1, false);
    meshes.push(reveal.mesh("door/reveal", "Door"));
    meshes.push(
        geo()
            .flat([4.0, 4.2], [1.5, 2.5], 0.0, true)
            .mesh("door/threshold", "Door"),
    );
    meshes.push(
        geo()
            .cuboid([1.0, 0.9, 4.0], [2.0, 2.0, 4.2])
            .mesh("window/a", "Window"),
    );
    let mut bed = child("7/model", "furniture/bed");
    bed["pos"] = json!([6.2, 0.0, 3.0]);
    bed["scale"] = json!([-1.0, 1.0, 1.0]);
    let mut chair = child("8/model", "furniture/chair");
    chair["pos"] = json!([1.0, 0.0, 1.0]);
    let mut leaf = child("9/model", "furniture/door-leaf");
    leaf["pos"] = json!([4.1, 0.0, 2.0]);
    json!({
        "uid": "hand-made",
        "version": "2.0",
        "mesh": meshes,
        "material": [{"uid": "mat/wall", "jid": "x", "texture": "", "color": [255, 128, 0, 255]}],
        "furniture": [
            {"uid": "7/model", "jid": "jid-bed", "aid": [], "category": "King-size Bed",
             "size": [2.0, 2.0, 0.5], "bbox": [2.0, 2.0, 0.5], "valid": true},
            {"uid": "8/model", "jid": "jid-chair", "aid": [], "title": "chair",
             "bbox": [[0.5, 1.0, 0.5]], "valid": true},
            {"uid": "9/model", "jid": "jid-door", "aid": []},
            {"uid": "10/model", "jid": "jid-gone", "aid": [], "size": [1, 1, 1], "valid": false},
        ],
        "extension": {"door": [{"type": "interiorDoor", "ref": ["9/model", "door/reveal"]}]},
        "scene": {"ref": "-1", "pos": [0, 0, 0], "rot": [0, 0, 0, 1], "scale": [1, 1, 1], "room": [
            {"type": "LivingRoom", "instanceid": "LivingRoom-1", "children": [
                child("floor/a", "mesh/1"), child("ceil/a", "mesh/2"), child("wall/a", "mesh/3"),
                child("wall/between", "mesh/4"), child("door/reveal", "mesh/5"),
                child("door/threshold", "mesh/6"), child("window/a", "mesh/7"),
                chair, leaf, child("404/model", "furniture/ghost"),
            ]},
            {"type": "MasterBedroom", "instanceid": "MasterBedroom-2", "children": [
                child("floor/b", "mesh/11"), child("ceil/b", "mesh/12"), child("wall/b", "mesh/13"),
                child("base/b", "mesh/14"), bed, child("10/model", "furniture/invalid"),
            ]},
        ]},
    })
}

fn parse(v: &Value) -> Result<LoadedScene, LoadError> {
    let bytes = serde_json::to_vec_pretty(v).unwrap();
    parse_scene(&bytes, Path::new("hand-made.json"), "hand-made")
}

fn object<'a>(scene: &'a Scene, id: &str) -> &'a Object {
    scene
        .objects()
        .find(|o| o.id == id)
        .unwrap_or_else(|| panic!("no object {id}"))
}

fn near(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() < 1e-4
}

#[test]
fn rooms_get_their_surfaces_types_classes_and_floor_area() {
    let loaded = parse(&house()).expect("loads");
    let scene = &loaded.scene;
    assert_eq!(scene.id, "hand-made");
    assert_eq!(scene.levels.len(), 1);
    let rooms = &scene.levels[0].rooms;
    assert_eq!(rooms.len(), 2);
    assert_eq!(rooms[0].id, "LivingRoom-1");
    assert_eq!(rooms[0].raw_types, vec!["LivingRoom"]);
    assert_eq!(rooms[0].class, RoomClass::LivingRoom);
    assert_eq!(rooms[1].class, RoomClass::Bedroom);
    for r in rooms {
        let kinds: Vec<SurfaceKind> = r.surfaces.iter().map(|s| s.kind).collect();
        assert_eq!(
            kinds,
            vec![SurfaceKind::Floor, SurfaceKind::Ceiling, SurfaceKind::Wall]
        );
        assert!((r.area - 16.0).abs() < 1e-3, "{}: {}", r.id, r.area);
        assert_eq!(r.floor_height, 0.0);
        assert!((r.bbox.max.y - 2.6).abs() < 1e-5);
    }
    // Surfaces are world-space: room B's floor sits at x 4.2..8.2; its wall mesh holds the
    // east wall and the baseboard.
    let floor_b = scene.surface_world_mesh(rooms[1].surfaces[0].mesh);
    let xs = floor_b.positions.iter().map(|p| p.x);
    assert_eq!(xs.clone().fold(f32::INFINITY, f32::min), 4.2);
    assert_eq!(xs.fold(f32::NEG_INFINITY, f32::max), 8.2);
    let wall_b = &scene.meshes[rooms[1].surfaces[2].mesh as usize];
    assert_eq!(wall_b.triangle_count(), 12 + 2);
    // The material colour comes from material[].
    assert_eq!(wall_b.materials[0].diffuse, [1.0, 128.0 / 255.0, 0.0, 1.0]);
    assert!(scene.validate().is_ok());
}

#[test]
fn doors_windows_and_furniture_become_objects_with_flags_and_categories() {
    let loaded = parse(&house()).expect("loads");
    let scene = &loaded.scene;
    let ids: Vec<&str> = scene.objects().map(|o| o.id.as_str()).collect();
    assert_eq!(
        ids,
        vec![
            "mesh/5",
            "mesh/6",
            "mesh/7",
            "furniture/chair",
            "furniture/door-leaf",
            "furniture/bed"
        ]
    );
    for id in ["mesh/5", "mesh/6"] {
        let o = object(scene, id);
        assert!(o.flags.door && !o.flags.window, "{id}");
        assert_eq!(o.categories.best(), "door");
        assert_eq!(o.rooms, vec![0]);
    }
    let window = object(scene, "mesh/7");
    assert!(window.flags.window && !window.flags.door);
    assert!(near(window.bbox.min, Vec3::new(1.0, 0.9, 4.0)));
    // The door leaf has no geometry but is a door through extension.door.
    let leaf = object(scene, "furniture/door-leaf");
    assert!(leaf.flags.door && leaf.mesh.is_none());
    assert!(near(leaf.bbox.min, Vec3::new(4.1, 0.0, 2.0)));
    // Furniture boxes: the chair from its nested bbox (x, y, z), the bed from size (x, z, y).
    let chair = object(scene, "furniture/chair");
    assert_eq!(chair.categories.fine.as_deref(), Some("chair"));
    assert_eq!(chair.model_id, "jid-chair");
    assert!(near(chair.bbox.min, Vec3::new(0.75, 0.0, 0.75)));
    assert!(near(chair.bbox.max, Vec3::new(1.25, 1.0, 1.25)));
    let bed = object(scene, "furniture/bed");
    assert_eq!(bed.categories.fine.as_deref(), Some("King-size Bed"));
    assert_eq!(bed.rooms, vec![1]);
    assert!(
        near(bed.bbox.min, Vec3::new(5.2, 0.0, 2.0)),
        "{:?}",
        bed.bbox
    );
    assert!(
        near(bed.bbox.max, Vec3::new(7.2, 0.5, 4.0)),
        "{:?}",
        bed.bbox
    );
    // One unit box shared by both.
    assert_eq!(chair.mesh, bed.mesh);
    // Warnings: the missing uid and the invalid furniture, each on one line naming the record.
    let missing = loaded
        .warnings
        .iter()
        .find(|w| w.contains("404/model"))
        .expect("warning for the missing uid");
    assert!(missing.starts_with("hand-made.json: scene.room[0].children[9] (furniture/ghost)"));
    assert!(missing.contains("matches no mesh[] or furniture[] uid"));
    assert!(loaded.warnings.iter().any(|w| w.contains("valid: false")));
    assert!(loaded.warnings.iter().all(|w| !w.contains('\n')));
}

#[test]
fn a_negative_scale_mirrors_the_box_and_keeps_its_faces_outward() {
    let loaded = parse(&house()).expect("loads");
    let scene = &loaded.scene;
    let bed = object(scene, "furniture/bed");
    assert!(bed.transform.determinant() < 0.0);
    let w = scene.object_world_mesh(bed).unwrap();
    let centre = bed.bbox.center();
    for t in 0..w.indices.len() / 3 {
        let n = w.face_normal(t).normalize();
        let p = w.positions[w.indices[3 * t] as usize];
        assert!(
            n.dot(w.normals[w.indices[3 * t] as usize]) > 0.99,
            "face {t}"
        );
        assert!(n.dot(p - centre) > 0.0, "face {t} points inward");
    }
}

fn grid_of(scene: &Scene) -> NavGrid {
    build(scene, &NavParams::default()).expect("bakes")
}

#[test]
fn the_bake_joins_both_rooms_through_the_doorway_only() {
    let loaded = parse(&house()).expect("loads");
    let grid = grid_of(&loaded.scene);
    let a = Vec3::new(2.0, 0.0, 2.5);
    let b = Vec3::new(5.0, 0.0, 1.0);
    assert!(grid.is_walkable(a) && grid.is_walkable(b));
    // Under the mirrored bed, inside the walls and in the doorway's jamb: not walkable.
    assert!(!grid.is_walkable(Vec3::new(6.2, 0.0, 3.0)));
    assert!(!grid.is_walkable(Vec3::new(4.1, 0.0, 1.0)));
    let (sa, sb) = (grid.span_at(a).unwrap(), grid.span_at(b).unwrap());
    let path = shortest_path(&grid, sa, sb);
    let path = path.path().expect("a path through the doorway");
    // The path squeezes through z 1.5..2.5 at x 4..4.2, so it is longer than the straight line.
    assert!(path.length > a.distance(b), "{}", path.length);
    assert!(path.points.iter().any(|p| (1.5..=2.5).contains(&p.z)));
    let doors: Vec<&str> = path
        .doors
        .iter()
        .map(|&o| grid.objects[o as usize].id.as_str())
        .collect();
    assert!(
        !doors.is_empty() && doors.iter().all(|d| d.starts_with("mesh/")),
        "{doors:?}"
    );
    assert_eq!(path.rooms.first(), Some(&0));
    assert_eq!(path.rooms.last(), Some(&1));
    // Walkable floor: two 16 m² rooms less the bed, the chair and a 0.1 m margin.
    let area = grid.walkable_count() as f32 * grid.cell() * grid.cell();
    assert!((20.0..29.0).contains(&area), "{area}");
}

#[test]
fn pointgoal_and_roomgoal_episodes_come_out() {
    let loaded = parse(&house()).expect("loads");
    let grid = grid_of(&loaded.scene);
    for task in [Task::PointGoal, Task::RoomGoal] {
        let cfg = SampleConfig {
            task,
            per_scene: 3,
            min_island_radius: 1.0,
            ..SampleConfig::default()
        };
        let out = sample_scene(&grid, "hand-made", "train", &cfg);
        assert!(out.unusable.is_none(), "{task:?}: {:?}", out.unusable);
        assert!(!out.episodes.is_empty(), "{task:?}: {:?}", out.rejected);
    }
}

fn error_of(v: &Value) -> String {
    let e = parse(v).expect_err("must fail").to_string();
    assert!(!e.contains('\n'), "{e}");
    assert!(e.starts_with("hand-made.json: "), "{e}");
    e
}

#[test]
fn malformed_json_names_file_line_and_column() {
    let text = serde_json::to_string_pretty(&house()).unwrap();
    let cut = &text.as_bytes()[..text.len() / 2];
    let e = parse_scene(cut, Path::new("hand-made.json"), "hand-made")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("hand-made.json: line ") && e.contains("column"),
        "{e}"
    );
    let e = error_of(&json!({"mesh": []}));
    assert!(e.contains("missing field `scene`"), "{e}");
    let e = error_of(&json!({"scene": {"room": [{"children": [{"ref": 3}]}]}}));
    assert!(e.contains("line") && e.contains("invalid type"), "{e}");
}

#[test]
fn non_finite_positions_name_the_child_and_the_field() {
    let mut v = house();
    v["scene"]["room"][1]["children"][4]["pos"] = json!([6.2, "NaN", 3.0]);
    // The NaN token Python writes (not valid JSON) reads as a non-finite value.
    let text = serde_json::to_string(&v).unwrap().replace("\"NaN\"", "NaN");
    let e = parse_scene(text.as_bytes(), Path::new("hand-made.json"), "hand-made")
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "hand-made.json: node scene.room[1].children[4] (furniture/bed): \
         `pos[1]` is NaN, infinite or null"
    );
    v["scene"]["room"][1]["children"][4]["pos"] = json!([6.2, 1e300, 3.0]);
    let e = error_of(&v);
    assert!(
        e.contains("(furniture/bed)") && e.contains("`pos[1]`"),
        "{e}"
    );
}

#[test]
fn a_degenerate_quaternion_or_scale_is_an_error() {
    let mut v = house();
    v["scene"]["room"][0]["children"][7]["rot"] = json!([0, 0, 0, 0]);
    let e = error_of(&v);
    assert!(
        e.contains("scene.room[0].children[7] (furniture/chair)") && e.contains("`rot`"),
        "{e}"
    );
    assert!(e.contains("not a rotation"), "{e}");
    let mut v = house();
    v["scene"]["room"][0]["children"][7]["scale"] = json!([1, 0, 1]);
    assert!(error_of(&v).contains("`scale[1]` is 0"));
    let mut v = house();
    v["scene"]["room"][0]["children"][7]["rot"] = json!([0, 0, 1]);
    assert!(error_of(&v).contains("`rot` has 3 values, expected 4"));
}

#[test]
fn bad_architecture_meshes_name_the_mesh_record() {
    let mut v = house();
    v["mesh"][1]["faces"] = json!([0, 1, 2, 0, 2, 17]);
    let e = error_of(&v);
    assert!(
        e.contains("mesh[1] (floor/b)") && e.contains("`faces[5]` is 17"),
        "{e}"
    );
    let mut v = house();
    v["mesh"][0]["xyz"][4] = Value::Null;
    let e = error_of(&v);
    assert!(
        e.contains("mesh[0] (floor/a)") && e.contains("`xyz[4]`"),
        "{e}"
    );
    let mut v = house();
    v["furniture"][0]["size"] = json!([2.0, -1.0, 0.5]);
    let e = error_of(&v);
    assert!(
        e.contains("furniture[0] (7/model)") && e.contains("negative"),
        "{e}"
    );
}

#[test]
fn control_characters_from_the_file_do_not_break_messages_into_lines() {
    let mut v = house();
    v["scene"]["room"][0]["type"] = json!("Living\nRoom");
    v["scene"]["room"][0]["children"][9]["ref"] = json!("404\n/model");
    let loaded = parse(&v).expect("loads");
    let bad_type = loaded
        .warnings
        .iter()
        .find(|w| w.contains("3dfront_room_types.csv"))
        .expect("unknown room type warning");
    assert!(bad_type.contains("type `Living\\nRoom`"), "{bad_type}");
    assert!(loaded.warnings.iter().all(|w| !w.contains('\n')));
    assert_eq!(loaded.scene.levels[0].rooms[0].class, RoomClass::Other);
    v["scene"]["room"][0]["children"][7]["instanceid"] = json!("chair\r\nbroken");
    v["scene"]["room"][0]["children"][7]["rot"] = json!([0, 0, 0, 0]);
    let e = error_of(&v);
    assert!(e.contains("(chair\\r\\nbroken)"), "{e}");
}

#[test]
fn crlf_and_trailing_whitespace_load_the_same_scene() {
    let pretty = serde_json::to_string_pretty(&house()).unwrap();
    let crlf = pretty.replace('\n', "  \r\n") + " \r\n\t\r\n";
    let with_bom = [&b"\xEF\xBB\xBF"[..], crlf.as_bytes()].concat();
    let a = parse_scene(pretty.as_bytes(), Path::new("a.json"), "s").unwrap();
    let b = parse_scene(&with_bom, Path::new("a.json"), "s").unwrap();
    assert_eq!(a.scene, b.scene);
}

#[test]
fn mutated_files_never_panic_and_errors_stay_on_one_line() {
    let bytes = serde_json::to_vec(&house()).unwrap();
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let (mut ok, mut failed) = (0, 0);
    for _ in 0..300 {
        let mut m = bytes.clone();
        for _ in 0..1 + next() % 4 {
            let i = (next() % m.len() as u64) as usize;
            match next() % 3 {
                0 => m[i] = b"0123456789-.eE,:[]{}\"nul"[(next() % 24) as usize],
                1 => {
                    m.remove(i);
                }
                _ => m.truncate(i),
            }
        }
        match parse_scene(&m, Path::new("m.json"), "m") {
            Ok(l) => {
                assert!(l.scene.validate().is_ok());
                ok += 1;
            }
            Err(e) => {
                let e = e.to_string();
                assert!(e.starts_with("m.json: ") && !e.contains('\n'), "{e}");
                failed += 1;
            }
        }
    }
    assert!(failed > 0 && ok + failed == 300);
}

/// A dataset root with the hand-made scene and a 3D-FUTURE folder holding the bed's mesh and
/// a `model_info.json`.
fn dataset(dir: &Path) -> (PathBuf, PathBuf) {
    let root = dir.join("3D-FRONT");
    let models = dir.join("3D-FUTURE-model");
    std::fs::create_dir_all(&root).unwrap();
    std::fs::create_dir_all(models.join("jid-bed")).unwrap();
    std::fs::write(
        root.join("hand-made.json"),
        serde_json::to_vec(&house()).unwrap(),
    )
    .unwrap();
    std::fs::write(root.join("notes.txt"), "not a scene").unwrap();
    // A bed model: one 2 m × 2 m slab, 0.4 m high, standing on its origin.
    std::fs::write(
        models.join("jid-bed").join("raw_model.obj"),
        "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nv -1 0.4 -1\nv 1 0.4 -1\nv 1 0.4 1\nv -1 0.4 1\n\
         f 5 8 7 6\nf 1 2 3 4\nf 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 4 8 5 1\n",
    )
    .unwrap();
    std::fs::write(
        models.join("model_info.json"),
        r#"[{"model_id": "jid-bed", "category": "King-size Bed", "super-category": "Bed"},
            {"model_id": "jid-chair", "category": "Dining Chair", "super-category": "Chair"}]"#,
    )
    .unwrap();
    (root, models)
}

#[test]
fn models_folder_meshes_replace_boxes_and_add_super_categories() {
    let dir = tempfile::tempdir().unwrap();
    let (root, models) = dataset(dir.path());
    let loader = ThreeDFrontLoader::open(&root, Some(&models), None).unwrap();
    assert!(loader
        .mapping_path()
        .is_some_and(|p| p.ends_with("model_info.json")));
    let entries = loader.discover().unwrap();
    assert_eq!(
        entries,
        vec![SceneEntry {
            id: "hand-made".into(),
            path: root.join("hand-made.json")
        }]
    );
    let loaded = loader.load(&entries[0]).unwrap();
    let scene = &loaded.scene;
    let bed = object(scene, "furniture/bed");
    let mesh = &scene.meshes[bed.mesh.unwrap() as usize];
    assert!(mesh.name.ends_with("raw_model.obj"), "{}", mesh.name);
    assert!(
        near(bed.bbox.max, Vec3::new(7.2, 0.4, 4.0)),
        "{:?}",
        bed.bbox
    );
    assert_eq!(bed.categories.coarse.as_deref(), Some("Bed"));
    assert_eq!(
        object(scene, "furniture/chair")
            .categories
            .coarse
            .as_deref(),
        Some("Chair")
    );
    // The chair has no model file: still a box, and a warning names it.
    assert!(loaded
        .warnings
        .iter()
        .any(|w| w.contains("furniture[1] (8/model)") && w.contains("box used")));
    assert!(loaded
        .sources
        .iter()
        .any(|p| p.ends_with("jid-bed/raw_model.obj")));
    let err = ThreeDFrontLoader::open(&root, Some(&dir.path().join("nope")), None)
        .err()
        .expect("missing --models folder");
    assert!(err.to_string().contains("nope"), "{err}");
}

#[test]
fn ingest_and_the_cli_read_a_3dfront_root() {
    let dir = tempfile::tempdir().unwrap();
    let (root, models) = dataset(dir.path());
    let data = dir.path().join("DATA");
    let cfg = IngestConfig {
        format: DatasetFormat::ThreeDFront,
        models: Some(models.clone()),
        ..IngestConfig::suncg(&root, &data)
    };
    let report = ingest(&cfg, &NoProgress).expect("ingest");
    assert_eq!(report.scenes.len(), 1);
    let (row, outcome) = &report.scenes[0];
    assert_eq!(*outcome, Outcome::Compiled, "{:?}", row.error);
    assert_eq!(row.dataset, "3dfront");
    let (_, scene) = minos::store::DataDir::new(&data)
        .read_scene("hand-made")
        .expect("compiled scene");
    assert_eq!(scene.levels[0].rooms.len(), 2);
    // The CLI flag names: --dataset 3dfront --models DIR.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_minos"))
        .args(["ingest", "--dataset", "3dfront", "--force", "--root"])
        .arg(&root)
        .arg("--models")
        .arg(&models)
        .arg("--out")
        .arg(dir.path().join("CLI"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(dir.path().join("CLI/houses.parquet").is_file());
}
