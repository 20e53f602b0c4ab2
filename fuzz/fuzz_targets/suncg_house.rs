//! cargo-fuzz target: arbitrary bytes as a SUNCG `house.json`, loaded by minos's SUNCG loader.
//!
//! The house is written to `<root>/house/fuzz/house.json`, where `<root>` is
//! `$MINOS_FUZZ_SUNCG_ROOT` (a generated dataset, so the house's room and object meshes
//! exist; `fuzz/smoke.sh` makes one) or an empty folder. A scene the loader accepts must pass
//! `Scene::validate`; errors are one line naming the file.

#![no_main]

#[path = "common.rs"]
mod common;

use std::path::PathBuf;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use minos::scene::formats::suncg::SuncgLoader;
use minos::scene::formats::{DatasetLoader, SceneEntry};

fn loader() -> &'static (SuncgLoader, PathBuf) {
    static LOADER: OnceLock<(SuncgLoader, PathBuf)> = OnceLock::new();
    LOADER.get_or_init(|| {
        let root = std::env::var_os("MINOS_FUZZ_SUNCG_ROOT")
            .map(PathBuf::from)
            .unwrap_or_else(common::temp_dir);
        let loader = SuncgLoader::open(&root, None).expect("open the SUNCG root");
        // A folder of its own per process, so parallel jobs do not share the file.
        let house = root
            .join("house")
            .join(format!("fuzz{}", std::process::id()));
        std::fs::create_dir_all(&house).expect("house folder");
        (loader, house.join("house.json"))
    })
}

fuzz_target!(|data: &[u8]| {
    let (loader, path) = loader();
    std::fs::write(path, data).expect("write house.json");
    let entry = SceneEntry {
        id: "fuzz".into(),
        path: path.clone(),
    };
    match loader.load(&entry) {
        Ok(loaded) => {
            if let Err(e) = loaded.scene.validate() {
                panic!("accepted scene is invalid: {e}");
            }
        }
        Err(e) => common::one_line_naming(&e.to_string(), ""),
    }
});
