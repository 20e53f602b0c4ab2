//! Corrupt inputs in a batch: one bad scene gives one error row (or one error line) naming the
//! file, and the batch goes on with the others.

use crate::common;

use std::path::{Path, PathBuf};

use common::{generate_into, ingest_into};
use minos::generate::GenerateConfig;
use minos::pipeline::ingest::Outcome;
use minos::store::manifest::read_manifest;

fn config(houses: usize) -> GenerateConfig {
    GenerateConfig {
        houses,
        seed: 11,
        rooms: (1, 4),
        levels: (1, 1),
        closed_door_prob: 0.0,
        ..Default::default()
    }
}

/// The MTL files of one generated house's room meshes (`room/<id>/*.mtl`), sorted.
fn room_mtls(root: &Path, id: &str) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(root.join("room").join(id))
        .expect("room folder")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "mtl"))
        .collect();
    out.sort();
    out
}

#[test]
fn an_mtl_colour_with_two_numbers_fails_its_house_only() {
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    let plans = generate_into(&config(3), &root);
    let bad = &plans[1].id;
    let mtl = room_mtls(&root, bad)
        .into_iter()
        .next()
        .expect("a room MTL");
    // The line: tobj 4.0.5 panics on it (`unwrap()` in `parse_float3`).
    std::fs::write(&mtl, "newmtl bad\nKd 0.55 0.56\n").unwrap();
    let report = ingest_into(&root, &data);
    assert_eq!(report.scenes.len(), 3);
    assert_eq!(report.count(Outcome::Compiled), 2);
    assert_eq!(report.count(Outcome::Failed), 1);
    let rows = read_manifest(&report.manifest).expect("manifest written");
    assert_eq!(rows.len(), 3);
    for row in &rows {
        if &row.id == bad {
            let err = row.error.as_deref().expect("error row for the bad house");
            assert!(
                err.contains(&*mtl.display().to_string())
                    && err.contains("line 2: `Kd` needs 3 numbers, found 2"),
                "{err}"
            );
            assert!(!err.contains('\n'));
        } else {
            assert!(row.error.is_none(), "{}: {:?}", row.id, row.error);
            assert!(data
                .join("scenes")
                .join(format!("{}.mscene", row.id))
                .is_file());
        }
    }
}

#[test]
fn a_corrupt_compiled_scene_fails_its_bake_only_and_an_old_version_is_reingested() {
    use minos::body::{AgentBody, BodyRule};
    use minos::episode::sample::SampleConfig;
    use minos::navmesh::NavParams;
    use minos::pipeline::bake::{bake_scenes, BakeConfig};
    use minos::pipeline::episodes::sample_scenes;
    use minos::progress::NoProgress;
    use minos::shard::Shard;

    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    let plans = generate_into(&config(3), &root);
    ingest_into(&root, &data);
    let ids: Vec<String> = plans.iter().map(|p| p.id.clone()).collect();
    let scene = |id: &str| data.join("scenes").join(format!("{id}.mscene"));
    // Flip one byte in the middle of the second scene's body.
    let bad = scene(&ids[1]);
    let mut bytes = std::fs::read(&bad).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x40;
    std::fs::write(&bad, &bytes).unwrap();
    let report = bake_scenes(
        &BakeConfig {
            data: minos::store::DataDir::new(&data),
            scenes: ids.iter().map(|id| id.parse().unwrap()).collect(),
            params: NavParams::default(),
            force: false,
            previews: false,
        },
        &NoProgress,
    );
    let failures: Vec<(&str, String)> = report.failures().collect();
    assert_eq!(failures.len(), 1, "{failures:?}");
    assert_eq!(failures[0].0, ids[1]);
    assert!(
        failures[0].1.contains(&*bad.display().to_string())
            && failures[0].1.contains("checksum mismatch")
            && !failures[0].1.contains('\n'),
        "{}",
        failures[0].1
    );
    for id in [&ids[0], &ids[2]] {
        assert!(data.join("nav").join(format!("{id}.nav")).is_file(), "{id}");
    }
    // A flipped byte in the grid part of one `.nav` (the issue: `episodes` panicked): that
    // scene's problem names the file; the other scene gets its episodes.
    let nav = data.join("nav").join(format!("{}.nav", ids[2]));
    let mut bytes = std::fs::read(&nav).unwrap();
    bytes[40] ^= 0x08;
    std::fs::write(&nav, &bytes).unwrap();
    let scenes: Vec<(String, String)> = [&ids[0], &ids[2]]
        .iter()
        .map(|id| (id.to_string(), String::new()))
        .collect();
    let batch = sample_scenes(
        &minos::store::DataDir::new(&data),
        &scenes,
        &SampleConfig {
            per_scene: 3,
            seed: 1,
            ..SampleConfig::default()
        },
        BodyRule::strict(AgentBody::HABITAT),
        Shard::ALL,
        &NoProgress,
    );
    let problem = batch.scenes[&ids[2]].problem.clone().unwrap_or_default();
    assert!(
        problem.contains(&*nav.display().to_string()) && problem.contains("corrupt"),
        "{problem}"
    );
    assert!(!problem.contains('\n'));
    assert!(
        batch.scenes[&ids[0]].episodes > 0,
        "{:?}",
        batch.scenes[&ids[0]]
    );
    // A scene of an older format version is rebuilt by a plain re-ingest (and so is the
    // corrupt one, whose header still reads but whose body does not).
    let old = scene(&ids[0]);
    let mut bytes = std::fs::read(&old).unwrap();
    bytes[8..12].copy_from_slice(&1u32.to_le_bytes());
    std::fs::write(&old, &bytes).unwrap();
    let again = ingest_into(&root, &data);
    let outcome = |id: &str| {
        again
            .scenes
            .iter()
            .find(|(r, _)| r.id == id)
            .map(|(_, o)| *o)
            .unwrap()
    };
    assert_eq!(outcome(&ids[0]), Outcome::Compiled);
    assert_eq!(outcome(&ids[1]), Outcome::Compiled);
    assert_eq!(outcome(&ids[2]), Outcome::UpToDate);
    for id in &ids {
        minos::store::DataDir::new(&data)
            .read_scene(id)
            .unwrap_or_else(|e| panic!("{e}"));
    }
}
