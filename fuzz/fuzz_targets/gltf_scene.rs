//! cargo-fuzz target: one file of a glTF scene root replaced by arbitrary bytes, then the
//! root opened and every scene it finds loaded by minos's glTF scene loader (GLB/glTF
//! stages, Habitat scene instances, stage/object/dataset configs, semantic configs, the
//! category table).
//!
//! The root is `$MINOS_FUZZ_GLTF_ROOT` (copied once per process to a folder of its own;
//! `fuzz/smoke.sh` makes one from a minos-made house and, when present, Habitat's test
//! dataset) or, without it, an empty folder. An input is `<relative path>\n<bytes>`: the
//! file of that path is replaced (a path the root lacks picks a file by its bytes' sum), and
//! restored afterwards. A scene the loader accepts must pass `Scene::validate`; errors are
//! one line.

#![no_main]

#[path = "common.rs"]
mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use minos::scene::formats::gltf_scene::GltfLoader;
use minos::scene::formats::DatasetLoader;

struct Root {
    dir: PathBuf,
    /// Every file, relative path and original bytes.
    files: Vec<(String, Vec<u8>)>,
}

fn copy_tree(from: &Path, to: &Path, rel: &str, files: &mut Vec<(String, Vec<u8>)>) {
    let mut entries: Vec<_> = std::fs::read_dir(from)
        .expect("read the fuzzing root")
        .map(|e| e.expect("read the fuzzing root").path())
        .collect();
    entries.sort();
    for p in entries {
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        let r = if rel.is_empty() { name.clone() } else { format!("{rel}/{name}") };
        if p.is_dir() {
            std::fs::create_dir_all(to.join(&name)).expect("copy the fuzzing root");
            copy_tree(&p, &to.join(&name), &r, files);
        } else {
            let bytes = std::fs::read(&p).expect("copy the fuzzing root");
            std::fs::write(to.join(&name), &bytes).expect("copy the fuzzing root");
            files.push((r, bytes));
        }
    }
}

fn root() -> &'static Root {
    static ROOT: OnceLock<Root> = OnceLock::new();
    ROOT.get_or_init(|| {
        let dir = common::temp_dir().join("gltf_root");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("fuzzing root");
        let mut files = Vec::new();
        if let Some(from) = std::env::var_os("MINOS_FUZZ_GLTF_ROOT") {
            copy_tree(Path::new(&from), &dir, "", &mut files);
        }
        Root { dir, files }
    })
}

fuzz_target!(|data: &[u8]| {
    common::count_only_uncaught_panics();
    let root = root();
    let (name, bytes) = match data.iter().position(|&b| b == b'\n') {
        Some(i) => (String::from_utf8_lossy(&data[..i]).to_string(), &data[i + 1..]),
        None => (String::new(), data),
    };
    // The file replaced, and what to put back afterwards.
    let (rel, original) = match root.files.iter().find(|(r, _)| *r == name) {
        Some((r, b)) => (r.clone(), Some(b)),
        None if root.files.is_empty() => ("fuzz.glb".to_string(), None),
        None => {
            let sum = data.iter().map(|&b| usize::from(b)).sum::<usize>();
            let (r, b) = &root.files[sum % root.files.len()];
            (r.clone(), Some(b))
        }
    };
    let path = root.dir.join(&rel);
    std::fs::write(&path, bytes).expect("write the fuzzing input");

    match GltfLoader::open(&root.dir, None) {
        Ok(loader) => {
            let entries = match DatasetLoader::discover(&loader) {
                Ok(entries) => entries,
                Err(e) => {
                    common::one_line_naming(&e.to_string(), "");
                    Vec::new()
                }
            };
            for entry in &entries {
                match DatasetLoader::load(&loader, entry) {
                    Ok(loaded) => {
                        if let Err(e) = loaded.scene.validate() {
                            panic!("accepted scene {} is invalid: {e}", entry.id);
                        }
                    }
                    Err(e) => common::one_line_naming(&e.to_string(), ""),
                }
            }
        }
        Err(e) => common::one_line_naming(&e.to_string(), ""),
    }

    match original {
        Some(b) => std::fs::write(&path, b).expect("restore the fuzzing root"),
        None => std::fs::remove_file(&path).expect("remove the fuzzing input"),
    }
});
