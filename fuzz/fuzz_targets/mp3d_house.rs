//! cargo-fuzz target: arbitrary bytes read as a Matterport3D `.house` file.
//!
//! The parser must never panic; a failure is one line naming the line number. A file it
//! accepts must also build into a valid scene with proxy geometry (floors, walls, obstacle
//! boxes), or fail with one line naming the file. No file system access: no category tables,
//! no mesh files. Run with `cargo fuzz run mp3d_house` from the crate root.

#![no_main]

use std::path::{Path, PathBuf};

use libfuzzer_sys::fuzz_target;
use minos::scene::formats::mp3d::{
    house_file, CategoryTables, GeometrySource, Mp3dLoader, Mp3dOptions,
};
use minos::scene::formats::SceneEntry;

fuzz_target!(|data: &[u8]| {
    let house = match house_file::parse(data) {
        Ok(h) => h,
        Err(e) => {
            let message = e.to_string();
            assert!(
                message.starts_with("line ") && !message.contains('\n'),
                "bad error message: {message:?}"
            );
            assert!(e.line >= 1, "line numbers start at 1: {message:?}");
            return;
        }
    };
    let loader = Mp3dLoader::with_tables(Path::new("fuzz"), CategoryTables::default())
        .with_options(Mp3dOptions {
            geometry: GeometrySource::Proxy,
            proxy_walls: true,
        });
    let entry = SceneEntry {
        id: "fuzz".into(),
        path: PathBuf::from("fuzz.house"),
    };
    match loader.build(&entry, &house) {
        Ok(loaded) => {
            if let Err(e) = loaded.scene.validate() {
                panic!("accepted scene is invalid: {e}");
            }
            assert_eq!(loaded.scene.rooms().count(), house.regions.len());
            assert_eq!(loaded.scene.objects().count(), house.objects.len());
            for w in &loaded.warnings {
                assert!(!w.contains('\n'), "multi-line warning: {w:?}");
            }
        }
        Err(e) => {
            let message = e.to_string();
            assert!(
                message.starts_with("fuzz.house: ") && !message.contains('\n'),
                "bad error message: {message:?}"
            );
        }
    }
});
