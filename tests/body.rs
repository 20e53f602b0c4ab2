//! One agent body from bake to run: a grid baked for one body refuses an agent of another
//! (with a one-line error naming both bodies and the rebake), unless the mismatch is allowed
//! explicitly, which the run manifest records.

use crate::common;

use common::{cli_ingested, minos, RunOk};
use std::path::Path;

/// Generates, ingests and splits two houses into `dir/DATA`, and bakes them for `preset`.
fn baked_for(dir: &Path, preset: &str) -> std::path::PathBuf {
    let data = cli_ingested(dir, 2, 4);
    minos()
        .args([
            "-q", "split", "--name", "all", "--ratios", "1,0,0", "--data",
        ])
        .arg(&data)
        .ok_output();
    minos()
        .args(["-q", "bake", "--no-preview", "--preset", preset, "--data"])
        .arg(&data)
        .ok_output();
    data
}

/// The first ingested scene of `data`.
fn first_scene(data: &Path) -> String {
    minos::store::DataDir::new(data).ingested_ids().unwrap()[0].clone()
}

#[test]
fn a_grid_baked_for_1_19_m_refuses_the_1_5_m_agent_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let data = baked_for(dir.path(), "minos");
    let eps = dir.path().join("eps.parquet");
    // Sampling for the default (Habitat, 1.5 m) body on MINOS's grids: every scene refused.
    let out = minos()
        .args([
            "episodes",
            "--task",
            "pointgoal",
            "--split",
            "all",
            "--per-scene",
            "2",
        ])
        .arg("--data")
        .arg(&data)
        .arg("--out")
        .arg(&eps)
        .ok_output();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.starts_with("0 pointgoal episodes"), "{stdout}");
    // For the body they were baked for, episodes come.
    minos()
        .args([
            "-q",
            "episodes",
            "--task",
            "pointgoal",
            "--split",
            "all",
            "--per-scene",
            "2",
        ])
        .args(["--preset", "minos", "--data"])
        .arg(&data)
        .arg("--out")
        .arg(&eps)
        .ok_output();
    let run = |extra: &[&str], out: &Path| {
        minos()
            .args([
                "-q",
                "run",
                "--agent",
                "forward",
                "--max-steps",
                "3",
                "--size",
                "16",
            ])
            .arg("--data")
            .arg(&data)
            .arg("--episodes")
            .arg(&eps)
            .arg("--out")
            .arg(out)
            .args(extra)
            .output()
            .unwrap()
    };
    // The default run moves Habitat's 1.5 m agent: refused, with both bodies and the fix.
    let refused = run(&[], &dir.path().join("r1"));
    assert!(!refused.status.success());
    let err = String::from_utf8_lossy(&refused.stderr);
    let first = err.lines().next().unwrap_or_default();
    assert!(
        first.contains("height 1.19 m") && first.contains("height 1.5 m"),
        "{err}"
    );
    assert!(
        first.contains("minos bake --preset habitat --force"),
        "{err}"
    );
    assert!(first.contains("--allow-body-mismatch"), "{err}");
    // MINOS's agent on MINOS's grids runs.
    let same = dir.path().join("r2");
    let ok = run(&["--preset", "minos"], &same);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    // Allowed explicitly: it runs, and the manifest says so.
    let allowed = dir.path().join("r3");
    let ok = run(&["--allow-body-mismatch"], &allowed);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(allowed.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["allow_body_mismatch"], true);
    assert_eq!(manifest["preset"], "habitat");
    assert_eq!(manifest["body"]["height"], 1.5);
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(same.join("manifest.json")).unwrap()).unwrap();
    assert!(manifest.get("allow_body_mismatch").is_none());
    // Rendering refuses the mismatch too.
    let scene = first_scene(&data);
    let render = minos()
        .args([
            "render",
            "--scene",
            &scene,
            "--pose",
            "0,0,0,0",
            "--renderer",
            "cpu",
        ])
        .arg("--data")
        .arg(&data)
        .arg("--out")
        .arg(dir.path().join("frames"))
        .output()
        .unwrap();
    assert!(!render.status.success());
    assert!(String::from_utf8_lossy(&render.stderr).contains("height 1.19 m"));
}

#[test]
fn nav_query_on_a_retexture_only_variant_uses_its_scenes_grid() {
    let dir = tempfile::tempdir().unwrap();
    let data = baked_for(dir.path(), "habitat");
    minos()
        .args([
            "-q",
            "variants",
            "--name",
            "tex",
            "--retexture-seed",
            "3",
            "--data",
        ])
        .arg(&data)
        .ok_output();
    let scene = first_scene(&data);
    assert!(!data.join(format!("nav/{scene}@tex.nav")).exists());
    // Two walkable points of the scene's grid.
    let store = minos::store::DataDir::new(&data);
    let grid = store.read_grid(&scene.parse().unwrap()).unwrap();
    let largest = (0..grid.islands.len() as u32)
        .max_by_key(|&i| grid.walkable_spans(Some(i)).len())
        .unwrap();
    let spans = grid.walkable_spans(Some(largest));
    let mut rng = minos::seed::Rng::new(7);
    let (_, a) = grid.random_point_from(&mut rng, &spans).unwrap();
    let (_, b) = grid.random_point_from(&mut rng, &spans).unwrap();
    let query = |scene: &str| {
        let out = minos()
            .args(["nav", "query", "--scene", scene, "--json"])
            .arg(format!("--from={},{},{}", a.x, a.y, a.z))
            .arg(format!("--to={},{},{}", b.x, b.y, b.z))
            .arg("--data")
            .arg(&data)
            .ok_output();
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let (base, tex) = (query(&scene), query(&format!("{scene}@tex")));
    assert!(base["geodesic"].is_number(), "{base}");
    assert_eq!(base, tex);
}

/// Baking for one body over grids baked for another says what it replaced (which scenes,
/// which body) instead of replacing them silently; baking again for the same body does not.
#[test]
fn a_bake_for_another_body_names_the_grids_it_replaces() {
    let dir = tempfile::tempdir().unwrap();
    let data = baked_for(dir.path(), "habitat");
    let bake = |preset: &str| {
        let out = minos()
            .args(["bake", "--no-preview", "--preset", preset, "--data"])
            .arg(&data)
            .ok_output();
        String::from_utf8(out.stderr).unwrap()
    };
    let stderr = bake("minos");
    let warnings: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("warning: "))
        .collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    let ids = minos::store::DataDir::new(&data).ingested_ids().unwrap();
    let habitat = minos::body::AgentBody::HABITAT.to_string();
    let minos_body = minos::body::AgentBody::MINOS.to_string();
    assert!(
        warnings[0].starts_with(&format!(
            "warning: replaced {} grids baked for another body ({habitat}) with grids for {minos_body}: ",
            ids.len()
        )),
        "{stderr}"
    );
    for id in &ids {
        assert!(warnings[0].contains(id.as_str()), "{id}: {stderr}");
    }
    // The grids now are MINOS's: the same bake again is up to date and says nothing.
    let again = bake("minos");
    assert!(!again.contains("warning"), "{again}");
    for id in &ids {
        let nav = minos::store::DataDir::new(&data).nav_path(&minos::scene::SceneRef::parse(id));
        let params = minos::navmesh::file::read_nav_params(&nav).unwrap();
        assert_eq!(params.body, minos::body::AgentBody::MINOS);
    }
}
