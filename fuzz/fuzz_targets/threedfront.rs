//! cargo-fuzz target: arbitrary bytes read as a 3D-FRONT scene file.
//!
//! The reader must never panic; a failure is one line that starts with the file name, and a
//! scene it accepts passes the canonical model's own checks. No file system access (no model
//! folder, no category table). Run with `cargo fuzz run threedfront` from the crate root.

#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use minos::scene::formats::threedfront::parse_scene;

fuzz_target!(|data: &[u8]| {
    match parse_scene(data, Path::new("fuzz.json"), "fuzz") {
        Ok(loaded) => {
            if let Err(e) = loaded.scene.validate() {
                panic!("accepted scene is invalid: {e}");
            }
            for w in &loaded.warnings {
                assert!(!w.contains('\n'), "multi-line warning: {w:?}");
            }
        }
        Err(e) => {
            let message = e.to_string();
            assert!(
                message.starts_with("fuzz.json: ") && !message.contains('\n'),
                "bad error message: {message:?}"
            );
        }
    }
});
