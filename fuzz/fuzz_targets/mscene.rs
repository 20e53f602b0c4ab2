//! cargo-fuzz target: arbitrary bytes decoded as a compiled scene (`.mscene`).
//!
//! Built with `--cfg fuzzing`, the decoder skips the checksum so that inputs reach the postcard
//! decoding and `Scene::validate`. A decoded scene must be usable: every count and world mesh
//! computed from it without a panic. Errors are one line naming the file.

#![no_main]

#[path = "common.rs"]
mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use minos::store::scene_file::decode;

fuzz_target!(|data: &[u8]| {
    match decode(Path::new("fuzz.mscene"), data) {
        Ok((_, scene)) => {
            let _ = scene.triangle_count();
            let _ = scene.floor_area();
            for o in scene.objects() {
                let _ = scene.object_world_mesh(o);
            }
            for l in &scene.levels {
                for r in &l.rooms {
                    for s in &r.surfaces {
                        let _ = scene.surface_world_mesh(s.mesh);
                    }
                }
            }
        }
        Err(e) => common::one_line_naming(&e.to_string(), "fuzz.mscene: "),
    }
});
