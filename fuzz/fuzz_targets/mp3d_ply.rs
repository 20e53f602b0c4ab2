//! cargo-fuzz target: arbitrary bytes read as the house mesh (`<scan>.ply`) of a small, fixed
//! Matterport3D house.
//!
//! Reading the PLY and splitting it into per-region floor, ceiling and wall surfaces must never
//! panic; a failure is one line that starts with the PLY's name, and a mesh it accepts gives a
//! scene that passes the canonical model's checks. No file system access. Run with
//! `cargo fuzz run mp3d_ply` from the crate root.

#![no_main]

use std::path::{Path, PathBuf};

use libfuzzer_sys::fuzz_target;
use minos::scene::formats::mp3d::{house_file, ply, CategoryTables, Mp3dLoader};
use minos::scene::formats::SceneEntry;

/// Two regions on one level, one object with two segments, two categories.
const HOUSE: &str = "ASCII 1.1
H  -  -  0 0 8 2 2 1 2 2 0  1  0 0 0 0 0  0 0 0  8 4 3  0 0 0 0 0
L  0  2  -  4 2 0  0 0 0  8 4 3  0 0 0 0 0
R  0 0  0 0  k  2 2 0  0 0 0  4 4 2.5  2.5  0 0 0 0
R  1 0  0 0  s  6 2 0  4 0 0  8 4 2.5  2.5  0 0 0 0
S  0 0  0  F  2 2 0  0 0 1  0 0 0  4 4 0  0 0 0 0 0
S  1 1  0  F  6 2 0  0 0 1  4 0 0  8 4 0  0 0 0 0 0
V  0 0  F  0 0 0  0 0 1  0 0 0
V  1 0  F  4 0 0  0 0 1  0 0 0
V  2 0  F  4 4 0  0 0 1  0 0 0
V  3 0  F  0 4 0  0 0 1  0 0 0
V  4 1  F  4 0 0  0 0 1  0 0 0
V  5 1  F  8 0 0  0 0 1  0 0 0
V  6 1  F  8 4 0  0 0 1  0 0 0
V  7 1  F  4 4 0  0 0 1  0 0 0
C  0  1 wall  1 wall  0 0 0 0 0
C  1  4 floor  2 floor  0 0 0 0 0
O  0 0 1  2 2 0  1 0 0  0 1 0  2 2 0.05  0 0 0 0 0 0 0 0
E  0 0 1  1  2 2 0  0 0 0  4 4 0  0 0 0 0 0
E  1 -1 2  1  6 2 0  4 0 0  8 4 0  0 0 0 0 0
";

fuzz_target!(|data: &[u8]| {
    // The PLY reader alone.
    if let Err(e) = ply::read_ply(data) {
        assert!(!e.to_string().contains('\n'), "multi-line error: {e}");
    }
    // And the whole integration: labels → regions and surface kinds.
    let house = match house_file::parse(HOUSE.as_bytes()) {
        Ok(h) => h,
        Err(e) => panic!("the fixed house must parse: {e}"),
    };
    let loader = Mp3dLoader::with_tables(Path::new("fuzz"), CategoryTables::default());
    let entry = SceneEntry {
        id: "fuzz".into(),
        path: PathBuf::from("fuzz.house"),
    };
    match loader.build_with_ply(&entry, &house, Path::new("fuzz.ply"), data) {
        Ok(loaded) => {
            if let Err(e) = loaded.scene.validate() {
                panic!("accepted scene is invalid: {e}");
            }
            assert_eq!(loaded.scene.rooms().count(), 2);
            for w in &loaded.warnings {
                assert!(!w.contains('\n'), "multi-line warning: {w:?}");
            }
        }
        Err(e) => {
            let message = e.to_string();
            assert!(
                (message.starts_with("fuzz.ply: ") || message.starts_with("fuzz.house: "))
                    && !message.contains('\n'),
                "bad error message: {message:?}"
            );
        }
    }
});
