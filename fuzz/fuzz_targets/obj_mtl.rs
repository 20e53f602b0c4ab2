//! cargo-fuzz target: arbitrary bytes as an OBJ mesh and its MTL library, through minos's
//! loader (`obj_mesh::load_obj_bytes`, which checks MTL lines tobj would panic on and runs
//! tobj under `catch_unwind`).
//!
//! Input: the OBJ text, then optionally a line `%%MTL` and the MTL text (which every
//! `mtllib` reads). Errors are one line naming a file.

#![no_main]

#[path = "common.rs"]
mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use minos::scene::formats::obj_mesh::load_obj_bytes;

const SEPARATOR: &[u8] = b"\n%%MTL\n";

fuzz_target!(|data: &[u8]| {
    common::count_only_uncaught_panics();
    let (obj, mtl) = match data.windows(SEPARATOR.len()).position(|w| w == SEPARATOR) {
        Some(at) => (&data[..at], Some(&data[at + SEPARATOR.len()..])),
        None => (data, None),
    };
    let read_mtl = |_: &Path| match mtl {
        Some(m) => Ok(m.to_vec()),
        None => Err(std::io::Error::from(std::io::ErrorKind::NotFound)),
    };
    match load_obj_bytes(Path::new("fuzz/m.obj"), obj, &read_mtl) {
        Ok(mesh) => {
            // `load_mesh_file` turns an invalid mesh into an error; it must not panic.
            let _ = mesh.validate();
        }
        // The file named may be the OBJ or an MTL library it names.
        Err(e) => common::one_line_naming(&e.to_string(), ""),
    }
});
