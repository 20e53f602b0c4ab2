//! Inputs the fuzz targets (`fuzz/`) found crashes with, kept as ordinary tests on the stable
//! toolchain: each must give a one-line error, never a panic. The files are the fuzzers'
//! crash inputs as found (`tests/data/fuzz/<target>-<what>.*`).

use crate::common;

use std::path::{Path, PathBuf};

use common::generate_into;
use minos::episode::format::read_episodes;
use minos::generate::GenerateConfig;
use minos::scene::formats::load_mesh_file;
use minos::scene::formats::suncg::SuncgLoader;
use minos::scene::formats::DatasetLoader;
use minos::scene::formats::SceneEntry;

fn input(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/fuzz")
        .join(name)
}

fn one_line_error<T: std::fmt::Debug, E: std::error::Error + 'static>(
    r: Result<T, E>,
    names: &str,
) {
    let e = r.expect_err("refused");
    let line = minos::escape::error_line(&e);
    assert!(line.contains(names), "{line}");
    // Every message of the chain is one line by itself (error_line only joins them).
    let mut link: Option<&(dyn std::error::Error + 'static)> = Some(&e);
    while let Some(l) = link {
        assert!(!l.to_string().contains('\n'), "{l:?}");
        link = l.source();
    }
}

#[test]
fn episode_parquet_whose_schema_panicked_arrow_ipc() {
    // arrow-ipc 58 panicked: "Int type with bit width of 0 and signed of false not supported".
    let path = input("episodes_parquet-arrow_ipc_int_width_0.parquet");
    let r = std::panic::catch_unwind(|| read_episodes(&path)).expect("no panic");
    one_line_error(r, "episodes_parquet-arrow_ipc_int_width_0.parquet");
}

#[test]
fn episode_parquet_whose_schema_panicked_arrow_ipc_type_none() {
    // arrow-ipc 58 panicked: "not implemented: Type NONE not supported".
    let path = input("episodes_parquet-arrow_ipc_type_none.parquet");
    let r = std::panic::catch_unwind(|| read_episodes(&path)).expect("no panic");
    one_line_error(r, "episodes_parquet-arrow_ipc_type_none.parquet");
}

#[test]
fn episode_parquet_whose_field_name_holds_a_newline() {
    // The error quoted a corrupt schema's field name (`euclidean_d`, 1, 0, 0, newline, `nce`)
    // raw: two lines. Control characters are now escaped.
    let path = input("episodes_parquet-newline_in_field_name.parquet");
    let r = std::panic::catch_unwind(|| read_episodes(&path)).expect("no panic");
    let e = minos::escape::error_line(r.as_ref().expect_err("refused"));
    assert!(
        e.contains("expected field named euclidean_d\\u{1}\\u{0}\\u{0}\\nnce"),
        "{e}"
    );
    one_line_error(r, "episodes_parquet-newline_in_field_name.parquet");
}

#[test]
fn glb_whose_accessor_panicked_gltf() {
    // gltf 1.4.1 panicked in accessor/util.rs (`assertion left == right`).
    let path = input("gltf-accessor_assert.glb");
    let r = std::panic::catch_unwind(|| load_mesh_file(&path)).expect("no panic");
    one_line_error(r, "gltf-accessor_assert.glb");
}

#[test]
fn glb_whose_mesh_panicked_gltf_unreachable() {
    // gltf 1.4.1 panicked in mesh/mod.rs:396 (`entered unreachable code`).
    let path = input("gltf-mesh_unreachable.glb");
    let r = std::panic::catch_unwind(|| load_mesh_file(&path)).expect("no panic");
    one_line_error(r, "gltf-mesh_unreachable.glb");
}

#[test]
fn gltf_whose_node_is_its_own_child_is_refused_at_once() {
    // A mutated GLB (target `gltf`) whose node listed itself as a child took 24 s and 1.7 GB:
    // the traversal expanded the cycle to a million mesh instances before calling it cyclic.
    // The same hierarchy, one triangle, written here (the found input came from a test asset).
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cycle.gltf");
    let gltf = r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [1]}],
        "nodes": [{"mesh": 0, "children": [0]}, {"children": [0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 0, 1]}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [{"byteLength": 36, "uri":
            "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAAAAAAIA/"}]}"#;
    std::fs::write(&path, gltf).unwrap();
    // Refused by the hierarchy check before any traversal (the traversal's own limit says
    // "node hierarchy too deep or cyclic" after a million instances).
    let e = load_mesh_file(&path).expect_err("refused").to_string();
    assert!(
        e.contains("cycle.gltf") && e.contains("nodes[0]: the node is its own ancestor"),
        "{e}"
    );
    assert!(!e.contains('\n'), "{e}");

    // Without the cycle the same file loads: one triangle.
    std::fs::write(
        &path,
        gltf.replace(r#""children": [0]}, {"#, r#""children": []}, {"#),
    )
    .unwrap();
    assert_eq!(load_mesh_file(&path).unwrap().triangle_count(), 1);
}

#[test]
fn suncg_house_with_a_non_affine_transform() {
    // glam panicked in `transform_point3` (debug builds): a transform whose last row is not
    // (0, 0, 0, 1). The house's meshes come from a generated dataset.
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("suncg");
    generate_into(
        &GenerateConfig {
            houses: 4,
            seed: 3,
            rooms: (1, 4),
            levels: (1, 2),
            closed_door_prob: 0.25,
            ..Default::default()
        },
        &root,
    );
    let house = root.join("house").join("fuzz");
    std::fs::create_dir_all(&house).unwrap();
    std::fs::copy(
        input("suncg_house-not_affine.json"),
        house.join("house.json"),
    )
    .unwrap();
    let loader = SuncgLoader::open(&root, None).unwrap();
    let entry = SceneEntry {
        id: "fuzz".into(),
        path: house.join("house.json"),
    };
    let r = std::panic::catch_unwind(|| loader.load(&entry).map(|_| ())).expect("no panic");
    let e = r.expect_err("refused").to_string();
    assert!(
        e.contains("house.json") && e.contains("not affine") && !e.contains('\n'),
        "{e}"
    );
}
