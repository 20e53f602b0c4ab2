//! The command line as a user meets it: bad input, resuming, help, the demo.

use crate::common;

use std::path::Path;

use common::{minos, RunOk};
use minos::generate::{house_id, GenerateConfig};
use minos::store::manifest::read_manifest;

fn gen(root: &Path, houses: usize) -> GenerateConfig {
    minos()
        .args([
            "generate",
            "--houses",
            &houses.to_string(),
            "--seed",
            "5",
            "--rooms",
            "2..5",
            "--out",
        ])
        .arg(root)
        .ok_output();
    GenerateConfig {
        houses,
        seed: 5,
        rooms: (2, 5),
        ..GenerateConfig::default()
    }
}

fn edit(path: &Path, f: impl FnOnce(String) -> String) {
    let text = std::fs::read_to_string(path).unwrap();
    std::fs::write(path, f(text)).unwrap();
}

#[test]
fn bad_houses_get_one_line_errors_and_the_batch_finishes() {
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    let cfg = gen(&root, 5);
    let json = |i: usize| {
        root.join("house")
            .join(house_id(&cfg, i))
            .join("house.json")
    };
    // 0: malformed JSON.
    edit(&json(0), |t| t[..t.len() / 2].to_string());
    // 1: an object whose mesh does not exist.
    edit(&json(1), |t| {
        t.replacen("\"modelId\":\"g_", "\"modelId\":\"missing_", 1)
    });
    // 2: a NaN in a transform, as Python's json module writes it.
    edit(&json(2), |t| {
        let start = t.find("\"transform\":[").unwrap() + "\"transform\":[".len();
        let end = start + t[start..].find(',').unwrap();
        format!("{}NaN{}", &t[..start], &t[end..])
    });
    let out = minos()
        .args(["ingest", "--root"])
        .arg(&root)
        .arg("--out")
        .arg(&data)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let errors: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("error: "))
        .collect();
    assert_eq!(errors.len(), 3, "{stderr}");
    assert!(errors.iter().all(|l| l.contains("house.json")), "{stderr}");
    let id = |i: usize| house_id(&cfg, i);
    let line = |i: usize| *errors.iter().find(|l| l.contains(&id(i))).unwrap();
    assert!(line(0).contains("line 1 column"), "{}", line(0));
    assert!(
        line(1).contains("node ")
            && line(1).contains("missing mesh")
            && line(1).contains("missing_"),
        "{}",
        line(1)
    );
    assert!(
        line(2).contains("node ") && line(2).contains("transform[0]"),
        "{}",
        line(2)
    );
    let rows = read_manifest(&data.join("houses.parquet")).unwrap();
    assert_eq!(rows.len(), 5);
    assert_eq!(rows.iter().filter(|r| r.error.is_some()).count(), 3);
    for i in 3..5 {
        assert!(data
            .join("scenes")
            .join(format!("{}.mscene", id(i)))
            .is_file());
    }
    assert!(!data
        .join("scenes")
        .join(format!("{}.mscene", id(0)))
        .exists());
}

#[test]
fn wrong_number_of_transform_values_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    let cfg = gen(&root, 1);
    let json = root
        .join("house")
        .join(house_id(&cfg, 0))
        .join("house.json");
    edit(&json, |t| {
        t.replacen("\"transform\":[", "\"transform\":[1,", 1)
    });
    let out = minos()
        .args(["ingest", "--root"])
        .arg(&root)
        .arg("--out")
        .arg(&data)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr.contains("17 values, expected 16"), "{stderr}");
}

#[test]
fn a_root_without_scenes_is_an_error_saying_what_was_looked_for() {
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("empty"), dir.path().join("DATA"));
    std::fs::create_dir_all(root.join("house")).unwrap();
    for (dataset, looked_for) in [
        ("suncg", "house/<id>/house.json"),
        ("mp3d", "<scan>/house_segmentations/<scan>.house"),
        ("3dfront", "<scene uid>.json"),
        ("gltf", ".glb, .gltf"),
    ] {
        let out = minos()
            .args(["ingest", "--dataset", dataset, "--root"])
            .arg(&root)
            .arg("--out")
            .arg(&data)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{dataset}: {stderr}");
        let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error")).collect();
        assert_eq!(errors.len(), 1, "{dataset}: {stderr}");
        assert!(
            errors[0].contains(&format!("no {dataset} scenes found"))
                && errors[0].contains(looked_for)
                && errors[0].contains(&root.display().to_string()),
            "{dataset}: {stderr}"
        );
        assert!(!data.join("houses.parquet").exists(), "{dataset}");
    }
}

#[test]
fn thread_counts_are_checked_and_logs_are_plain_when_stderr_is_not_a_terminal() {
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    gen(&root, 1);
    // Without its category table, ingest warns (through the logger).
    std::fs::remove_file(root.join("metadata/ModelCategoryMapping.csv")).unwrap();
    let ingest = |threads: &str| {
        minos()
            .args(["--threads", threads, "ingest", "--root"])
            .arg(&root)
            .arg("--out")
            .arg(&data)
            .output()
            .unwrap()
    };
    let absurd = ingest("100000");
    let stderr = String::from_utf8_lossy(&absurd.stderr);
    assert_eq!(absurd.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("100000") && stderr.contains("1024"),
        "{stderr}"
    );
    assert!(!data.exists(), "nothing ran");
    // 0 is all cores.
    let all = ingest("0");
    let stderr = String::from_utf8_lossy(&all.stderr);
    assert!(all.status.success(), "{stderr}");
    assert!(stderr.contains("ModelCategoryMapping.csv"), "{stderr}");
    assert!(
        !stderr.contains('\x1b'),
        "ANSI escapes in a pipe: {stderr:?}"
    );
    let help = minos().arg("--help").ok_output();
    assert!(String::from_utf8_lossy(&help.stdout).contains("0 or unset means all cores"));
}

/// Fails where lavapipe or a Mesa Vulkan driver is installed (its device-select layer asks
/// libwayland for a display) unless minos keeps the probe quiet; passes trivially elsewhere.
#[test]
fn looking_for_a_gpu_prints_nothing_without_a_desktop_session() {
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    gen(&root, 1);
    minos()
        .args(["-q", "ingest", "--root"])
        .arg(&root)
        .arg("--out")
        .arg(&data)
        .ok_output();
    minos()
        .args(["-q", "bake", "--data"])
        .arg(&data)
        .ok_output();
    let id = &read_manifest(&data.join("houses.parquet")).unwrap()[0].id;
    let out = minos()
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("NODEVICE_SELECT")
        .env_remove("MESA_VK_DEVICE_SELECT")
        .args([
            "render",
            "--renderer",
            "auto",
            "--size",
            "16",
            "--pose",
            "1,0,1,0",
        ])
        .args(["--scene", id, "--data"])
        .arg(&data)
        .arg("--out")
        .arg(dir.path().join("frames"))
        .ok_output();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("XDG_RUNTIME_DIR"), "{stderr}");
    assert!(dir.path().join("frames/color.png").is_file());
}

#[test]
fn rerun_skips_up_to_date_scenes_and_rebuilds_changed_ones() {
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    let cfg = gen(&root, 3);
    let ingest = |extra: &[&str]| {
        let out = minos()
            .args(["ingest", "--root"])
            .arg(&root)
            .arg("--out")
            .arg(&data)
            .args(extra)
            .output()
            .unwrap();
        assert!(out.status.success());
        String::from_utf8_lossy(&out.stdout).to_string()
    };
    assert!(ingest(&[]).contains("3 compiled, 0 up to date"));
    let manifest = std::fs::read(data.join("houses.parquet")).unwrap();
    assert!(ingest(&[]).contains("0 compiled, 3 up to date"));
    assert_eq!(
        std::fs::read(data.join("houses.parquet")).unwrap(),
        manifest
    );
    std::thread::sleep(std::time::Duration::from_millis(20));
    let json = root
        .join("house")
        .join(house_id(&cfg, 1))
        .join("house.json");
    edit(&json, |t| t);
    assert!(ingest(&[]).contains("1 compiled, 2 up to date"));
    assert!(ingest(&["--force"]).contains("3 compiled, 0 up to date"));
    // No temporary files are left behind.
    let leftovers: Vec<_> = std::fs::read_dir(data.join("scenes"))
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty());
}

#[test]
fn every_subcommand_documents_its_flags_with_examples() {
    for cmd in [
        "generate",
        "ingest",
        "split",
        "stats",
        "export",
        "demo",
        "bake",
        "episodes",
        "nav query",
        "episodes import",
    ] {
        let out = minos().args(cmd.split(' ')).arg("--help").output().unwrap();
        let help = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success());
        assert!(
            help.contains("Examples:"),
            "{cmd} --help has no examples:\n{help}"
        );
        assert!(
            help.contains(&format!("minos {cmd}")),
            "{cmd}: examples do not run {cmd}"
        );
    }
    let out = minos().arg("--help").output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    for flag in ["--quiet", "--verbose", "--threads"] {
        assert!(help.contains(flag), "{flag} missing");
    }
}

#[test]
fn demo_leaves_a_manifest_splits_and_statistics() {
    let dir = tempfile::tempdir().unwrap();
    let out = minos()
        .args(["demo", "--houses", "12", "--out"])
        .arg(dir.path())
        .ok_output();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let data = dir.path().join("data");
    let rows = read_manifest(&data.join("houses.parquet")).unwrap();
    assert_eq!(rows.len(), 12);
    assert!(rows.iter().all(|r| r.error.is_none()));
    let listed: usize = ["train", "val", "test"]
        .iter()
        .map(|s| {
            std::fs::read_to_string(data.join("splits/all").join(format!("{s}.txt")))
                .unwrap()
                .lines()
                .count()
        })
        .sum();
    assert_eq!(listed, 12);
    assert!(
        stdout.contains("houses") && stdout.contains("living_room"),
        "{stdout}"
    );
    // It ends with the command that serves its episodes in a browser.
    let last = stdout.lines().last().unwrap_or_default();
    assert!(
        last.contains("minos serve --data") && last.contains("pointgoal.parquet"),
        "{last}"
    );
    // The oracle demonstrated validation episodes of all three tasks and reached every goal.
    let metrics: serde_json::Value = serde_json::from_slice(
        &std::fs::read(dir.path().join("runs/oracle/metrics.json")).unwrap(),
    )
    .unwrap();
    let groups = &metrics["groups"];
    for task in ["pointgoal", "objectgoal", "roomgoal"] {
        let g = &groups[format!("task={task}")];
        assert!(
            g["episodes"].as_u64().unwrap_or(0) > 0,
            "no {task} rollouts"
        );
        assert_eq!(g["success"].as_f64(), Some(1.0), "{task}: {g}");
    }
    assert!(groups["all"]["spl"].as_f64().unwrap() >= 0.9, "{groups}");
    assert_eq!(metrics["failures"].as_array().map(Vec::len), Some(0));
    // The run folder says what the run was, as docs/FORMATS.md promises.
    let manifest: serde_json::Value = serde_json::from_slice(
        &std::fs::read(dir.path().join("runs/oracle/manifest.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(manifest["agent"], "oracle", "{manifest}");
    assert_eq!(manifest["preset"], "habitat", "{manifest}");
    let episodes_file = manifest["episodes_file"]
        .as_str()
        .expect("the episodes run");
    let episodes = minos::episode::format::read_episodes(Path::new(episodes_file)).unwrap();
    assert_eq!(
        Some(episodes.len() as u64),
        groups["all"]["episodes"].as_u64(),
        "{episodes_file} holds the episodes the oracle ran"
    );
    for file in [
        "episodes/pointgoal.parquet",
        "runs/oracle/trajectories.parquet",
        "runs/oracle/observations.parquet",
        "runs/oracle/lerobot/meta/info.json",
        "runs/oracle/lerobot/data/chunk-000/file-000.parquet",
        "episode.rrd",
    ] {
        let len = std::fs::metadata(dir.path().join(file)).map_or(0, |m| m.len());
        assert!(len > 0, "{file} missing or empty");
    }
    // Its episode files carry what `minos episodes` writes beside one: the statistics (the
    // same count as the file) and the provenance record naming the command that made them.
    for task in ["pointgoal", "objectgoal", "roomgoal"] {
        let file = dir.path().join(format!("episodes/{task}.parquet"));
        let stats: serde_json::Value = serde_json::from_slice(
            &std::fs::read(format!("{}.stats.json", file.display())).unwrap(),
        )
        .unwrap();
        let count = minos::episode::format::read_episodes(&file).unwrap().len();
        assert_eq!(
            stats["total"].as_u64(),
            Some(count as u64),
            "{task}: {stats}"
        );
        let provenance: serde_json::Value = serde_json::from_slice(
            &std::fs::read(format!("{}.provenance.json", file.display())).unwrap(),
        )
        .unwrap();
        let command = provenance["command"].to_string();
        assert!(command.contains("\"demo\""), "{task}: {command}");
    }
}

#[test]
fn bake_nav_query_and_episodes_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    let cfg = gen(&root, 3);
    let ok = |args: &[&str]| {
        let out = minos().args(args).output().unwrap();
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).to_string()
    };
    let d = data.to_str().unwrap();
    ok(&["ingest", "--root", root.to_str().unwrap(), "--out", d]);
    ok(&[
        "split",
        "--data",
        d,
        "--name",
        "s",
        "--ratios",
        "0.4,0.3,0.3",
    ]);
    assert!(ok(&["bake", "--data", d]).contains("3 baked"));
    assert!(ok(&["bake", "--data", d]).contains("3 up to date"));
    let id = house_id(&cfg, 0);
    assert!(data.join("nav").join(format!("{id}.L0.png")).is_file());
    // DATA's provenance record: rewritten by the bake, it lists every file with its sha256.
    let record: serde_json::Value =
        serde_json::from_slice(&std::fs::read(data.join("provenance.json")).unwrap()).unwrap();
    assert_eq!(record["kind"], "data");
    let files = record["files"].as_object().unwrap();
    for f in [
        "houses.parquet".to_string(),
        "splits/s/train.txt".to_string(),
        format!("nav/{id}.nav"),
        format!("scenes/{id}.mscene"),
    ] {
        let sum = minos::provenance::sha256_file(&data.join(&f)).unwrap();
        assert_eq!(files[&f]["sha256"], sum.sha256.as_str(), "{f}");
    }
    assert!(!files.contains_key("provenance.json"));
    // Two walkable points of the main island, from the grid itself.
    let grid = minos::navmesh::file::read_nav(&data.join("nav").join(format!("{id}.nav"))).unwrap();
    let indoor = |i: u32| {
        grid.walkable_spans(Some(i))
            .into_iter()
            .filter(|&s| grid.spans[s as usize].room != minos::navmesh::NONE)
            .collect::<Vec<_>>()
    };
    let main = (0..grid.islands.len() as u32)
        .max_by_key(|&i| indoor(i).len())
        .unwrap();
    let spans = indoor(main);
    let (a, b) = (
        grid.span_position(spans[0] as usize),
        grid.span_position(spans[spans.len() - 1] as usize),
    );
    let p = |v: glam::Vec3| format!("{},{},{}", v.x, v.y, v.z);
    let json = ok(&[
        "nav",
        "query",
        "--data",
        d,
        "--scene",
        &id,
        "--from",
        &p(a),
        "--to",
        &p(b),
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(json.trim()).unwrap();
    assert_eq!(v["reachable"], true);
    let (geo, euc) = (
        v["geodesic"].as_f64().unwrap(),
        v["euclidean"].as_f64().unwrap(),
    );
    assert!(geo + 1e-4 >= euc && geo < 4.0 * euc + 1.0, "{geo} vs {euc}");
    assert!((v["path"][0][0].as_f64().unwrap() - f64::from(a.x)).abs() < 1e-4);
    assert!(v["rooms"].as_array().is_some_and(|r| !r.is_empty()));
    let far = minos()
        .args([
            "nav",
            "query",
            "--data",
            d,
            "--scene",
            &id,
            "--from",
            "500,0,500",
            "--to",
            &p(b),
        ])
        .output()
        .unwrap();
    assert_eq!(far.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&far.stderr).contains("not within 2 m"));
    // Episodes, their statistics, a Habitat export and its import.
    let eps = dir.path().join("eps/point.parquet");
    let hab = dir.path().join("hab");
    ok(&[
        "episodes",
        "--data",
        d,
        "--task",
        "pointgoal",
        "--split",
        "s",
        "--per-scene",
        "3",
        "--out",
        eps.to_str().unwrap(),
        "--export",
        "habitat",
        hab.to_str().unwrap(),
    ]);
    let episodes = minos::episode::format::read_episodes(&eps).unwrap();
    assert!(!episodes.is_empty());
    // A category no scene has: one error line naming it and some known ones, no file and no
    // warning per scene; beside a found category, one warning line. An out-of-range
    // --per-scene is refused before any work.
    let typo = dir.path().join("eps/typo.parquet");
    let objectgoal = |categories: &str| {
        minos()
            .args([
                "episodes",
                "--data",
                d,
                "--task",
                "objectgoal",
                "--per-scene",
                "2",
            ])
            .args(["--categories", categories, "--out"])
            .arg(&typo)
            .output()
            .unwrap()
    };
    let out = objectgoal("door,no_such_thing");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains("WARN")).collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(warnings[0].contains("category `no_such_thing`"), "{stderr}");
    std::fs::remove_file(&typo).unwrap();
    let out = objectgoal("no_such_thing");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with("error: --categories: ")
            && stderr.contains("`no_such_thing`")
            && stderr.contains("known: ")
            && stderr.contains("door"),
        "{stderr}"
    );
    assert!(!typo.exists());
    let out = minos()
        .args(["episodes", "--data", d, "--task", "pointgoal"])
        .args(["--per-scene", "4294967296", "--out"])
        .arg(&typo)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.starts_with("error: invalid value '4294967296' for '--per-scene")
            && stderr.contains("not in 1..=4294967295"),
        "{stderr}"
    );

    let stats: serde_json::Value = serde_json::from_slice(
        &std::fs::read(dir.path().join("eps/point.parquet.stats.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(stats["total"].as_u64(), Some(episodes.len() as u64));
    // The provenance sidecar: the checksums of both files, the scenes of the split.
    let record: serde_json::Value = serde_json::from_slice(
        &std::fs::read(dir.path().join("eps/point.parquet.provenance.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(record["kind"], "episodes");
    for f in ["point.parquet", "point.parquet.stats.json"] {
        let sum = minos::provenance::sha256_file(&dir.path().join("eps").join(f)).unwrap();
        assert_eq!(record["files"][f]["sha256"], sum.sha256.as_str(), "{f}");
    }
    let scenes: std::collections::BTreeSet<&str> =
        episodes.iter().map(|e| e.scene_id.as_str()).collect();
    let recorded = record["scenes"].as_array().unwrap();
    assert!(recorded.len() >= scenes.len(), "{record}");
    assert!(recorded
        .iter()
        .all(|s| s["compiled_sha256"].as_str().is_some_and(|h| h.len() == 64)));
    assert!(record["command"][1] == "episodes", "{record}");
    let subset = &episodes[0].split;
    let content = std::fs::read_dir(hab.join(subset).join("content"))
        .unwrap()
        .flatten()
        .next()
        .unwrap()
        .path();
    let said = ok(&[
        "episodes",
        "import",
        "--from",
        "habitat",
        content.to_str().unwrap(),
    ]);
    assert!(said.starts_with("read "), "{said}");
    // Written out, the imported file carries a provenance record (its source and checksums),
    // so `minos verify` checks it like a sampled one.
    let imported = dir.path().join("eps/imported.parquet");
    ok(&[
        "episodes",
        "import",
        "--from",
        "habitat",
        content.to_str().unwrap(),
        "--out",
        imported.to_str().unwrap(),
    ]);
    let record: serde_json::Value = serde_json::from_slice(
        &std::fs::read(dir.path().join("eps/imported.parquet.provenance.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(record["imported"]["from"], "habitat", "{record}");
    assert_eq!(
        record["imported"]["checksum"]["sha256"],
        minos::provenance::sha256_file(&content)
            .unwrap()
            .sha256
            .as_str()
    );
    let count = minos::episode::format::read_episodes(&imported)
        .unwrap()
        .len();
    assert_eq!(record["imported"]["episodes"].as_u64(), Some(count as u64));
    assert!(record["imported"].get("task").is_none(), "{record}");
    // A MINOS table read as RoomGoal records it; a Habitat file holds its own task.
    let table = dir.path().join("eps/states.csv");
    std::fs::write(
        &table,
        "split,sceneId,roomId,roomType,startX,startY,startZ,startAngle,goalObjectId,goalX,goalY,goalZ\n\
         test,h,0_2,Kitchen,1,0.545,1,0,,3,0,3\n",
    )
    .unwrap();
    let rooms = dir.path().join("eps/rooms.parquet");
    let table_arg = table.to_str().unwrap();
    ok(&[
        "episodes",
        "import",
        "--from",
        "minos-csv",
        table_arg,
        "--task",
        "roomgoal",
        "--out",
        rooms.to_str().unwrap(),
    ]);
    let read = minos::episode::format::read_episodes(&rooms).unwrap();
    assert_eq!(read[0].task, minos::episode::Task::RoomGoal);
    let record: serde_json::Value = serde_json::from_slice(
        &std::fs::read(dir.path().join("eps/rooms.parquet.provenance.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(record["imported"]["task"], "roomgoal", "{record}");
    // An episode the oracle cannot plan (its goal far off the house) fails alone, named once.
    let e = &episodes[0];
    let [x, y, z] = e.start_position;
    std::fs::write(
        &table,
        format!(
            "split,sceneId,startX,startY,startZ,startAngle,goalX,goalY,goalZ\n\
             test,{},{x},{},{z},0,500,{y},500\n",
            e.scene_id,
            y + minos::episode::minos_csv::MINOS_AGENT_ORIGIN_HEIGHT
        ),
    )
    .unwrap();
    let lost = dir.path().join("eps/lost.parquet");
    ok(&[
        "episodes",
        "import",
        "--from",
        "minos-csv",
        table_arg,
        "--out",
        lost.to_str().unwrap(),
    ]);
    let said = minos()
        .args([
            "run",
            "--data",
            d,
            "--agent",
            "oracle",
            "--size",
            "16",
            "--episodes",
        ])
        .arg(&lost)
        .arg("--out")
        .arg(dir.path().join("lost-run"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&said.stderr);
    assert!(!said.status.success(), "{stderr}");
    let id = format!("{}:minos:00000", e.scene_id);
    let line = format!("error: episode {id}: no plan found");
    assert_eq!(
        stderr
            .lines()
            .filter(|l| l.starts_with("error:"))
            .collect::<Vec<_>>(),
        [line.as_str()],
        "{stderr}"
    );
    let line = minos()
        .args([
            "episodes",
            "import",
            "--from",
            "habitat",
            content.to_str().unwrap(),
            "--task",
            "roomgoal",
        ])
        .failed_stderr();
    assert!(
        line.contains("cannot be read as roomgoal episodes"),
        "{line}"
    );
    let verified = ok(&["verify", imported.to_str().unwrap()]);
    assert!(!verified.contains("missing"), "{verified}");
    // Without --split, every ingested scene is used and the episodes have no split.
    let all = dir.path().join("eps/all.parquet");
    ok(&[
        "episodes",
        "--data",
        d,
        "--task",
        "pointgoal",
        "--per-scene",
        "2",
        "--out",
        all.to_str().unwrap(),
        "--export",
        "habitat",
        hab.to_str().unwrap(),
    ]);
    assert!(hab.join("all/all.json.gz").is_file(), "Habitat split `all`");
    let episodes = minos::episode::format::read_episodes(&all).unwrap();
    let scenes: std::collections::BTreeSet<&str> =
        episodes.iter().map(|e| e.scene_id.as_str()).collect();
    assert_eq!(scenes.len(), 3, "{scenes:?}");
    assert!(episodes.iter().all(|e| e.split.is_empty()));
    // --shard auto: a Slurm array task (--array=1-3, task 2) samples what --shard 1/3 does.
    let shard_out = |name: &str, shard: &str, env: &[(&str, &str)]| {
        let path = dir.path().join("eps").join(name);
        let out = minos()
            .args([
                "episodes",
                "--data",
                d,
                "--task",
                "pointgoal",
                "--per-scene",
                "2",
            ])
            .args(["--shard", shard, "--out", path.to_str().unwrap()])
            .env_remove("MINOS_SHARD")
            .env_remove("SLURM_ARRAY_TASK_ID")
            .env_remove("JOB_COMPLETION_INDEX")
            .envs(env.iter().copied())
            .output()
            .unwrap();
        (out, path)
    };
    let (fixed, fixed_path) = shard_out("fixed.parquet", "1/3", &[]);
    assert!(fixed.status.success());
    let (slurm, slurm_path) = shard_out(
        "slurm.parquet",
        "auto",
        &[
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
        ],
    );
    assert!(
        slurm.status.success(),
        "{}",
        String::from_utf8_lossy(&slurm.stderr)
    );
    let one_scene = minos::episode::format::read_episodes(&fixed_path).unwrap();
    assert!(!one_scene.is_empty() && one_scene.len() < episodes.len());
    assert_eq!(
        std::fs::read(&fixed_path).unwrap(),
        std::fs::read(&slurm_path).unwrap()
    );
    let (k8s, k8s_path) = shard_out(
        "k8s.parquet",
        "auto",
        &[("JOB_COMPLETION_INDEX", "1"), ("MINOS_SHARD_COUNT", "3")],
    );
    assert!(k8s.status.success());
    assert_eq!(
        std::fs::read(&fixed_path).unwrap(),
        std::fs::read(&k8s_path).unwrap()
    );
    let (none, none_path) = shard_out("none.parquet", "auto", &[]);
    assert!(!none.status.success());
    let err = String::from_utf8_lossy(&none.stderr);
    assert!(err.contains("no scheduler environment"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(!none_path.exists());
}

/// Runs `minos args` expecting a one-line error (exit 1, no panic) and returns it.
fn one_line_failure(args: &[&std::ffi::OsStr]) -> String {
    let out = minos().args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    let shown: String = format!("{args:?}").chars().take(200).collect();
    assert_eq!(out.status.code(), Some(1), "{shown}: {stderr}");
    assert_eq!(stderr.lines().count(), 1, "{shown}: {stderr}");
    assert!(stderr.starts_with("error: "), "{shown}: {stderr}");
    stderr
}

#[test]
fn deep_filter_expressions_and_empty_sensor_files_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("DATA");
    let os = |s: &str| std::ffi::OsString::from(s);
    // Stack overflows (exit 134) before: the nesting is bounded while parsing.
    for expr in [
        format!("{}nrooms > 1", "!".repeat(30_000)),
        format!("{}nrooms > 1{}", "(".repeat(50_000), ")".repeat(50_000)),
    ] {
        let args = [
            os("split"),
            os("--data"),
            data.clone().into(),
            os("--name"),
            os("s"),
        ]
        .into_iter()
        .chain([
            os("--ratios"),
            os("0.5,0.25,0.25"),
            os("--where"),
            os(&expr),
        ])
        .collect::<Vec<_>>();
        let e = one_line_failure(&args.iter().map(|a| a.as_os_str()).collect::<Vec<_>>());
        assert!(
            e.contains("--where: at column 257: the expression nests more than 256 levels"),
            "{e}"
        );
    }
    // An empty sensor file (exit 0 before, rendering nothing).
    let e = one_line_failure(&[
        "render".as_ref(),
        "--data".as_ref(),
        data.as_os_str(),
        "--scene".as_ref(),
        "x".as_ref(),
        "--pose".as_ref(),
        "0,0,0,0".as_ref(),
        "--sensors".as_ref(),
        "/dev/null".as_ref(),
        "--out".as_ref(),
        dir.path().join("frames").as_os_str(),
    ]);
    assert!(e.contains("/dev/null: the sensor file is empty"), "{e}");
}

#[test]
fn stats_on_a_manifest_whose_embedded_arrow_schema_is_damaged_is_an_error() {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    gen(&root, 2);
    minos()
        .args(["ingest", "--root"])
        .arg(&root)
        .arg("--out")
        .arg(&data)
        .ok_output();
    let houses = data.join("houses.parquet");
    let bytes = std::fs::read(&houses).unwrap();
    let encoded = SerializedFileReader::new(std::fs::File::open(&houses).unwrap())
        .unwrap()
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .and_then(|kv| kv.iter().find(|k| k.key == "ARROW:schema").cloned())
        .and_then(|k| k.value)
        .expect("minos embeds the Arrow schema");
    let at = bytes
        .windows(encoded.len())
        .position(|w| w == encoded.as_bytes())
        .unwrap();
    // The schema with one byte set to 252, re-encoded to the same length (so the footer stays
    // valid): the first such byte with which the parquet crate itself panics (arrow-ipc's
    // "not implemented: Type <UNKNOWN 252> not supported", the case) or fails.
    use base64::Engine as _;
    let b64 = base64::engine::general_purpose::STANDARD;
    let schema = b64.decode(&encoded).unwrap();
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let damaged = (0..schema.len()).find_map(|i| {
        let mut s = schema.clone();
        s[i] = 252;
        let text = b64.encode(&s);
        let mut file = bytes.clone();
        file[at..at + text.len()].copy_from_slice(text.as_bytes());
        let probe = dir.path().join("probe.parquet");
        std::fs::write(&probe, &file).unwrap();
        let panics = std::panic::catch_unwind(|| {
            parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(
                std::fs::File::open(&probe).unwrap(),
            )
            .map(|_| ())
        })
        .is_err();
        panics.then_some(file)
    });
    std::panic::set_hook(hook);
    let damaged = damaged.expect("some damaged byte makes arrow-ipc panic");
    std::fs::write(&houses, damaged).unwrap();
    let e = one_line_failure(&["stats".as_ref(), "--data".as_ref(), data.as_os_str()]);
    assert!(
        e.contains("houses.parquet") && e.contains("the Parquet reader failed"),
        "{e}"
    );
}

/// A log (stderr not a terminal, as under Slurm or nohup) gets plain progress lines while the
/// work runs and a last line with the total; `-q` silences them.
#[test]
fn progress_reaches_a_log_as_plain_lines() {
    let dir = tempfile::tempdir().unwrap();
    let generate = |quiet: bool, out: &Path| {
        let mut cmd = minos();
        if quiet {
            cmd.arg("-q");
        }
        let out = cmd
            .env("MINOS_PROGRESS_SECONDS", "0")
            .args([
                "generate", "--houses", "3", "--seed", "5", "--rooms", "2..3",
            ])
            .arg("--out")
            .arg(out)
            .output()
            .unwrap();
        assert!(out.status.success());
        String::from_utf8(out.stderr).unwrap()
    };
    let stderr = generate(false, &dir.path().join("a"));
    let lines: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("generate: "))
        .collect();
    // Lines count up (interval 0: a line whenever the count grew) to all three houses,
    // then the closing line.
    let (closing, counting) = lines.split_last().unwrap();
    let mut shown = Vec::new();
    for line in counting {
        let (count, rest) = line["generate: ".len()..].split_once("/3 (").unwrap();
        let count: u64 = count.parse().unwrap();
        let percent = format!("{:.0}%), ", 100.0 * count as f64 / 3.0);
        assert!(rest.starts_with(&percent) && rest.contains("/s"), "{line}");
        shown.push(count);
    }
    assert!(shown.windows(2).all(|w| w[0] < w[1]), "{stderr}");
    assert_eq!(shown.last(), Some(&3), "{stderr}");
    assert!(closing.starts_with("generate: 3 done in "), "{stderr}");
    assert!(
        !stderr.contains('\u{1b}'),
        "no terminal escapes in a log: {stderr:?}"
    );
    let quiet = generate(true, &dir.path().join("b"));
    assert!(!quiet.contains("generate: "), "{quiet}");
}

/// Without `--pose`, `render` stands where the view is most open and says where, exactly:
/// the printed pose renders the same images again, and the view does not face a wall.
#[test]
fn render_without_a_pose_picks_an_open_view_it_can_repeat() {
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("suncg"), dir.path().join("DATA"));
    gen(&root, 1);
    for args in [
        vec!["-q", "ingest", "--root", root.to_str().unwrap()],
        vec!["-q", "bake", "--no-preview"],
    ] {
        let mut c = minos();
        c.args(&args);
        if args[1] == "ingest" {
            c.arg("--out").arg(&data);
        } else {
            c.arg("--data").arg(&data);
        }
        c.ok_output();
    }
    let id = read_manifest(&data.join("houses.parquet")).unwrap()[0]
        .id
        .clone();
    let render = |pose: Option<&str>, out: &Path| {
        let mut c = minos();
        c.args([
            "render",
            "--renderer",
            "cpu",
            "--size",
            "48",
            "--scene",
            &id,
        ])
        .arg("--data")
        .arg(&data)
        .arg("--out")
        .arg(out);
        if let Some(p) = pose {
            c.args(["--pose", p]);
        }
        String::from_utf8(c.ok_output().stdout).unwrap()
    };
    let said = render(None, &dir.path().join("open"));
    assert!(said.contains("(the most open view)"), "{said}");
    let pose = said
        .split("--pose ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .unwrap_or_else(|| panic!("no pose in {said:?}"));
    assert_eq!(pose.split(',').count(), 4, "{said}");
    let again = render(Some(pose), &dir.path().join("again"));
    assert!(!again.contains("most open"), "{again}");
    for f in ["color.png", "depth.png", "semantic.png"] {
        assert!(
            std::fs::read(dir.path().join("open").join(f)).unwrap()
                == std::fs::read(dir.path().join("again").join(f)).unwrap(),
            "{f} differs when rendered again at the printed pose"
        );
    }
    // Depth is 16-bit millimetres (0: nothing hit, farther than anything): the typical pixel
    // sees more than 1.5 m, and the view is not blocked (fewer than a tenth of the pixels
    // nearer than 0.5 m).
    let depth = image::open(dir.path().join("open/depth.png"))
        .unwrap()
        .into_luma16();
    let mut mm: Vec<u16> = depth
        .pixels()
        .map(|p| if p.0[0] == 0 { u16::MAX } else { p.0[0] })
        .collect();
    let near = mm.iter().filter(|&&d| d < 500).count();
    mm.sort_unstable();
    let median = mm[mm.len() / 2];
    assert!(median > 1500, "median depth {median} mm");
    assert!(
        near * 10 < mm.len(),
        "{near} of {} pixels nearer than 0.5 m",
        mm.len()
    );
}
