//! cargo-fuzz target: arbitrary bytes as a glTF (`{`…) or GLB file, through minos's glTF mesh
//! loader. A mesh it accepts must pass `Mesh::validate` or be refused by `load_mesh_file`;
//! errors are one line naming the file.

#![no_main]

#[path = "common.rs"]
mod common;

use libfuzzer_sys::fuzz_target;
use minos::scene::formats::load_mesh_file;

fuzz_target!(|data: &[u8]| {
    common::count_only_uncaught_panics();
    let name = if data.first() == Some(&b'{') {
        "fuzz.gltf"
    } else {
        "fuzz.glb"
    };
    let path = common::temp_file(name, data);
    match load_mesh_file(&path) {
        Ok(mesh) => assert!(mesh.validate().is_ok()),
        // The file named may be the glTF or a buffer or image it names.
        Err(e) => common::one_line_naming(&e.to_string(), ""),
    }
});
