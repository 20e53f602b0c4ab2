//! Scan-like houses (`generate --scan`): dense, noisy, holed Matterport3D meshes with clutter
//! ingest with `--dataset mp3d`, have the triangle count asked for, keep their labels, and
//! their three levels are joined by walkable stairs after the bake.

use crate::common;

use std::collections::BTreeSet;

use common::minos;
use minos::generate::scan::CLUTTER_CATEGORIES;
use minos::generate::{generate, house_id_for, GenerateConfig, OutputFormat, ScanOptions};
use minos::navmesh::build::build;
use minos::navmesh::NavParams;
use minos::pipeline::ingest::{ingest, DatasetFormat, IngestConfig};
use minos::progress::NoProgress;
use minos::scene::formats::mp3d::ply::read_ply;

const TRIANGLES: u64 = 60_000;

fn scan_config(houses: usize, seed: u64) -> (GenerateConfig, OutputFormat) {
    (
        GenerateConfig {
            houses,
            seed,
            rooms: (9, 12),
            levels: (3, 3),
            closed_door_prob: 0.0,
            ..Default::default()
        },
        OutputFormat::Mp3dScan(ScanOptions {
            triangles: TRIANGLES,
            noise: 0.003,
        }),
    )
}

#[test]
fn scan_houses_ingest_with_their_triangles_labels_and_connected_levels() {
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("scans"), dir.path().join("DATA"));
    let (cfg, format) = scan_config(2, 8);
    generate(&cfg, format, &root, false, &NoProgress).unwrap();
    let report = ingest(
        &IngestConfig {
            format: DatasetFormat::Mp3d,
            root: root.clone(),
            data: minos::store::DataDir::new(&data),
            ids: None,
            force: false,
            categories: None,
            models: None,
        },
        &NoProgress,
    )
    .unwrap();
    assert_eq!(report.scenes.len(), 2);
    for i in 0..cfg.houses {
        let id = house_id_for(&cfg, format, i);
        // The mesh as written: at most the budget, holes taking a few per cent at most.
        let ply = std::fs::read(
            root.join(&id)
                .join("house_segmentations")
                .join(format!("{id}.ply")),
        )
        .unwrap();
        let mesh = read_ply(&ply).unwrap();
        let n = mesh.triangles.len() as u64;
        assert!(
            (TRIANGLES * 9 / 10..=TRIANGLES).contains(&n),
            "{id}: {n} triangles for a budget of {TRIANGLES}"
        );
        let (_, scene) = minos::store::DataDir::new(&data).read_scene(&id).unwrap();
        assert_eq!(scene.levels.len(), 3, "{id}");
        // Every written face is in the scene (none lost or added by ingest).
        assert_eq!(scene.triangle_count(), n, "{id}");
        // Labels survive: the clutter and furniture classes are materials of room meshes,
        // and clutter objects carry their categories.
        let materials: BTreeSet<&str> = scene
            .meshes
            .iter()
            .flat_map(|m| m.materials.iter().map(|x| x.name.as_str()))
            .collect();
        for class in ["wall", "floor", "ceiling", "stairs", "door", "objects"] {
            assert!(
                materials.contains(class),
                "{id}: no {class} in {materials:?}"
            );
        }
        let fine: BTreeSet<String> = scene
            .objects()
            .filter_map(|o| o.categories.fine.clone())
            .collect();
        assert!(
            CLUTTER_CATEGORIES.iter().any(|c| fine.contains(*c)),
            "{id}: no clutter among {fine:?}"
        );
        // After the bake, walkable floor on each level, and one island spans all three.
        let grid = build(
            &scene,
            &NavParams::for_body(minos::body::AgentBody::HABITAT),
        )
        .unwrap();
        let islands_on = |level: u16| -> BTreeSet<u32> {
            grid.spans
                .iter()
                .filter(|s| s.walkable && s.level == level)
                .map(|s| s.island)
                .collect()
        };
        let common: BTreeSet<u32> = islands_on(0)
            .intersection(&islands_on(1))
            .copied()
            .collect::<BTreeSet<u32>>()
            .intersection(&islands_on(2))
            .copied()
            .collect();
        assert!(!common.is_empty(), "{id}: no island joins the three levels");
        let path_ok = {
            let island = *common.iter().next().unwrap();
            let on = |level: u16| {
                grid.spans
                    .iter()
                    .position(|s| s.walkable && s.level == level && s.island == island)
                    .unwrap() as u32
            };
            minos::navmesh::path::shortest_path(&grid, on(0), on(2))
                .length()
                .is_some()
        };
        assert!(path_ok, "{id}: no path from level 0 to level 2");
    }
}

#[test]
fn scan_houses_are_deterministic_and_bad_options_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let (cfg, format) = scan_config(1, 3);
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    generate(&cfg, format, &a, false, &NoProgress).unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    pool.install(|| generate(&cfg, format, &b, false, &NoProgress))
        .unwrap();
    assert_eq!(common::tree_bytes(&a), common::tree_bytes(&b));
    // Another density is another house id.
    let other = OutputFormat::Mp3dScan(ScanOptions {
        triangles: TRIANGLES / 2,
        noise: 0.003,
    });
    assert_ne!(house_id_for(&cfg, format, 0), house_id_for(&cfg, other, 0));
    for args in [
        vec!["--scan", "--scan-triangles", "12"],
        vec!["--scan", "--levels", "4"],
        vec!["--format", "suncg", "--scan"],
    ] {
        let out = minos()
            .arg("generate")
            .args(&args)
            .arg("--out")
            .arg(dir.path().join("bad"))
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
    }
}
