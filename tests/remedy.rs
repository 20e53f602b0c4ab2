//! Errors whose fix is another step of the pipeline carry it as data
//! (`minos::store::remedy::remedy_of`), their messages name no command or flag, and each
//! front door says the step in its own words: the command line as `minos …` with flags.

use crate::common;

use common::{baked_houses, minos};
use minos::generate::GenerateConfig;
use minos::scene::SceneRef;
use minos::store::remedy::{remedy_of, Remedy};
use minos::store::DataDir;

/// The message of a failed `minos` command (its one line of stderr).
fn fails(args: &[&str], data: &std::path::Path) -> String {
    let out = minos()
        .args(args)
        .arg("--data")
        .arg(data)
        .output()
        .expect("minos runs");
    assert!(!out.status.success(), "{args:?} succeeded");
    let err = String::from_utf8_lossy(&out.stderr).trim().to_string();
    assert_eq!(err.lines().count(), 1, "{err}");
    err
}

/// No command and no flag in a library message.
fn neutral(message: &str) {
    assert!(
        !message.contains("`minos") && !message.contains(" --"),
        "{message}"
    );
}

#[test]
fn missing_and_stale_steps_are_named_as_data_and_the_cli_says_the_command() {
    let dir = tempfile::tempdir().unwrap();
    // Nothing ingested: the manifest is missing.
    let empty = dir.path().join("EMPTY");
    std::fs::create_dir_all(&empty).unwrap();
    let e = DataDir::new(&empty).ingested_ids().unwrap_err();
    assert_eq!(remedy_of(&e), Some(Remedy::Ingest), "{e}");
    neutral(&minos::escape::error_line(&e));
    let err = fails(&["bake"], &empty);
    assert!(err.ends_with("(run `minos ingest` first)"), "{err}");
    // Another writer holds the folder: wait for it.
    {
        let _held = DataDir::new(&empty)
            .lock("test", minos::lock::LockMode::Fail)
            .unwrap();
        let e = DataDir::new(&empty)
            .lock("split", minos::lock::LockMode::Fail)
            .unwrap_err();
        assert_eq!(remedy_of(&e), Some(Remedy::Wait), "{e}");
        neutral(&minos::escape::error_line(&e));
    }

    let (data, ids) = baked_houses(
        dir.path(),
        &GenerateConfig {
            houses: 1,
            seed: 3,
            rooms: (2, 3),
            levels: (1, 1),
            closed_door_prob: 0.0,
            ..Default::default()
        },
    );
    let scene = SceneRef::parse(&ids[0]);
    let view = |data: &std::path::Path| {
        let out = dir.path().join("v.rrd");
        fails(
            &["view", "--scene", &ids[0], "--out", out.to_str().unwrap()],
            data,
        )
    };
    // A corrupt grid: rebake it.
    let grid = data.grid_path(&scene);
    let good = std::fs::read(&grid).unwrap();
    let mut bad = good.clone();
    let middle = bad.len() / 2;
    bad[middle] ^= 0x5a;
    std::fs::write(&grid, &bad).unwrap();
    let Err(e) = data.read_grid(&scene) else {
        panic!("a corrupt grid reads");
    };
    assert_eq!(remedy_of(&e), Some(Remedy::Rebake), "{e}");
    neutral(&minos::escape::error_line(&e));
    let err = view(data.root());
    assert!(err.contains("rebake it: `minos bake --force`"), "{err}");
    // No grid: bake it.
    std::fs::remove_file(&grid).unwrap();
    let Err(e) = data.read_grid(&scene) else {
        panic!("a missing grid reads");
    };
    assert_eq!(remedy_of(&e), Some(Remedy::Bake), "{e}");
    let err = view(data.root());
    assert!(err.contains("(run `minos bake` first"), "{err}");
    std::fs::write(&grid, &good).unwrap();
    // A corrupt compiled scene: ingest it again.
    let scene_file = data.scene_path(&ids[0]);
    let good = std::fs::read(&scene_file).unwrap();
    let mut bad = good.clone();
    let middle = bad.len() / 2;
    bad[middle] ^= 0x5a;
    std::fs::write(&scene_file, &bad).unwrap();
    let Err(e) = data.load_scene(&scene) else {
        panic!("a corrupt scene reads");
    };
    assert_eq!(remedy_of(&e), Some(Remedy::Reingest), "{e}");
    neutral(&minos::escape::error_line(&e));
    let err = view(data.root());
    assert!(
        err.contains("ingest it again: `minos ingest --force`"),
        "{err}"
    );
    std::fs::write(&scene_file, &good).unwrap();
    // A variant nobody defined.
    let e = data.read_variant("nope").unwrap_err();
    assert_eq!(remedy_of(&e), Some(Remedy::DefineVariant), "{e}");
    neutral(&minos::escape::error_line(&e));
    let err = fails(&["bake", "--variant", "nope"], data.root());
    assert!(
        err.contains("--variant nope") && err.contains("define it with `minos variants"),
        "{err}"
    );
    // Everything restored: the view works again.
    let out = dir.path().join("v.rrd");
    minos()
        .args([
            "view",
            "--scene",
            &ids[0],
            "--out",
            out.to_str().unwrap(),
            "--data",
        ])
        .arg(data.root())
        .output()
        .map(|o| assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr)))
        .unwrap();
}
