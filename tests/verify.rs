//! `minos verify` and `minos diff` on real outputs: a DATA folder, an episode file, a run
//! folder with its LeRobot copy, made by the binary as a user would. Each check is proven by
//! corrupting one kind of thing once (a flipped byte, a dropped row, a broken index, a changed
//! statistic, a truncated image, a damaged Parquet footer, a start moved off the grid, a
//! missing or unlisted file) and asserting the exact problem line; `diff` by changing one
//! value and asserting the line that names its episode, step, column and both values.

use crate::common;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow::array::{
    Array, ArrayRef, BinaryArray, BooleanArray, Float32Array, Int64Array, RecordBatch, StringArray,
    StructArray,
};
use common::{cli_ingested, minos, RunOk};
use minos::progress::NoProgress;
use minos::verify::{verify, VerifyOptions};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::ArrowWriter;
use sha2::Digest;

struct Fixture {
    dir: tempfile::TempDir,
}

/// DATA (2 generated houses, ingested, split, baked), `eps.parquet` (PointGoal, 3 per
/// scene) and `RUN` (the oracle, colour + depth at 16², with its LeRobot copy).
fn fixture() -> &'static Fixture {
    static F: std::sync::OnceLock<Fixture> = std::sync::OnceLock::new();
    F.get_or_init(|| {
        let dir = common::shared_tempdir();
        let data = cli_ingested(dir.path(), 2, 8);
        let d = data.to_str().unwrap().to_string();
        minos()
            .args([
                "-q", "split", "--name", "all", "--ratios", "1,0,0", "--data", &d,
            ])
            .ok_output();
        minos().args(["-q", "bake", "--data", &d]).ok_output();
        let eps = dir.path().join("eps.parquet");
        minos()
            .args(["-q", "episodes", "--task", "pointgoal", "--split", "all"])
            .args(["--per-scene", "3", "--seed", "5", "--data", &d, "--out"])
            .arg(&eps)
            .ok_output();
        minos()
            .args([
                "-q",
                "run",
                "--agent",
                "oracle",
                "--max-steps",
                "30",
                "--size",
                "16",
            ])
            .args(["--format", "lerobot", "--data", &d, "--episodes"])
            .arg(&eps)
            .arg("--out")
            .arg(dir.path().join("RUN"))
            .ok_output();
        Fixture { dir }
    })
}

/// A fresh copy of the fixture's `name` (folder or episode file with its sidecars).
fn copy(name: &str) -> (tempfile::TempDir, PathBuf) {
    let f = fixture();
    let to = tempfile::tempdir().unwrap();
    let mut from: Vec<PathBuf> = vec![f.dir.path().join(name)];
    if name.ends_with(".parquet") {
        for s in [".stats.json", ".provenance.json"] {
            from.push(f.dir.path().join(format!("{name}{s}")));
        }
    }
    for p in from {
        let ok = std::process::Command::new("cp")
            .arg("-a")
            .arg(&p)
            .arg(to.path())
            .status()
            .unwrap();
        assert!(ok.success());
    }
    let base = Path::new(name).file_name().unwrap();
    let path = to.path().join(base);
    (to, path)
}

fn problems(path: &Path, data: Option<&Path>) -> Vec<String> {
    let options = VerifyOptions {
        data: data.map(Path::to_path_buf),
    };
    let report = verify(path, &options, &NoProgress).expect("verify");
    report.problems.iter().map(|p| p.to_string()).collect()
}

fn assert_has(lines: &[String], want: &str) {
    assert!(
        lines.iter().any(|l| l == want),
        "no line\n  {want}\namong\n  {}",
        lines.join("\n  ")
    );
}

fn sha256(path: &Path) -> String {
    let bytes = std::fs::read(path).unwrap();
    sha2::Sha256::digest(&bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

fn table(path: &Path) -> RecordBatch {
    let r = ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(path).unwrap())
        .unwrap()
        .build()
        .unwrap();
    let schema = arrow::array::RecordBatchReader::schema(&r);
    let all: Vec<RecordBatch> = r.map(|b| b.unwrap()).collect();
    arrow::compute::concat_batches(&schema, &all).unwrap()
}

fn write_table(path: &Path, batch: &RecordBatch) {
    let mut w =
        ArrowWriter::try_new(std::fs::File::create(path).unwrap(), batch.schema(), None).unwrap();
    w.write(batch).unwrap();
    w.close().unwrap();
}

/// `batch` with column `name` replaced.
fn with_column(batch: &RecordBatch, name: &str, column: ArrayRef) -> RecordBatch {
    let i = batch.schema().index_of(name).unwrap();
    let mut columns = batch.columns().to_vec();
    columns[i] = column;
    RecordBatch::try_new(batch.schema(), columns).unwrap()
}

fn strings(b: &RecordBatch, name: &str) -> Vec<String> {
    let c = b.column_by_name(name).unwrap();
    let s = c.as_any().downcast_ref::<StringArray>().unwrap();
    (0..s.len()).map(|i| s.value(i).to_string()).collect()
}

fn cli(args: &[&std::ffi::OsStr]) -> (i32, String, String) {
    let out = minos().args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn every_kind_of_clean_output_verifies_with_one_summary_line() {
    let f = fixture();
    let data = f.dir.path().join("DATA");
    let eps = f.dir.path().join("eps.parquet");
    let run = f.dir.path().join("RUN");
    for (path, with_data, kind) in [
        (&run, false, "run folder"),
        (&run.join("lerobot"), false, "LeRobot dataset"),
        (&eps, true, "episode file"),
        (&data, false, "DATA folder"),
    ] {
        let mut args = vec![std::ffi::OsStr::new("verify"), path.as_os_str()];
        if with_data {
            args.extend([std::ffi::OsStr::new("--data"), data.as_os_str()]);
        }
        let (code, out, err) = cli(&args);
        assert_eq!(code, 0, "{}: {out}{err}", path.display());
        assert_eq!(out.lines().count(), 1, "{out}");
        assert!(
            out.starts_with(&format!("{}: ok: {kind}: ", path.display())),
            "{out}"
        );
    }
    let (code, out, _) = cli(&[
        "verify".as_ref(),
        eps.as_os_str(),
        "--data".as_ref(),
        data.as_os_str(),
    ]);
    assert_eq!(code, 0);
    assert!(
        out.contains(" episodes: starts, goals and geodesic distances re-computed"),
        "{out}"
    );
}

#[test]
fn a_flipped_byte_is_a_checksum_problem_and_exit_status_1() {
    let (_t, run) = copy("RUN");
    let file = run.join("trajectories.parquet");
    let want = sha256(&file);
    let mut bytes = std::fs::read(&file).unwrap();
    let k = bytes.len() / 2;
    bytes[k] ^= 0x01;
    std::fs::write(&file, &bytes).unwrap();
    let got = sha256(&file);
    let lines = problems(&run, None);
    assert_eq!(
        lines[0],
        format!(
            "{}: checksum: sha256 {got} where manifest.json records {want}",
            file.display()
        )
    );
    let (code, out, err) = cli(&["verify".as_ref(), run.as_os_str()]);
    assert_eq!(code, 1);
    assert!(out
        .lines()
        .next()
        .unwrap()
        .ends_with(&format!("records {want}")));
    assert!(err.contains("in this run folder"), "{err}");
}

#[test]
fn a_dropped_trajectory_row_breaks_the_steps_and_the_episode_table() {
    let (_t, run) = copy("RUN");
    let file = run.join("trajectories.parquet");
    let t = table(&file);
    let ids = strings(&t, "episode_id");
    // Drop step 2 of the first episode (rows 0, 1, 2 are its steps 0, 1, 2).
    assert_eq!(ids[0], ids[3]);
    let keep: Vec<u32> = (0..t.num_rows() as u32).filter(|i| *i != 2).collect();
    let idx = arrow::array::UInt32Array::from(keep);
    let columns: Vec<ArrayRef> = t
        .columns()
        .iter()
        .map(|c| arrow::compute::take(c, &idx, None).unwrap())
        .collect();
    write_table(&file, &RecordBatch::try_new(t.schema(), columns).unwrap());
    let n = ids.iter().filter(|i| **i == ids[0]).count();
    let lines = problems(&run, None);
    let id = &ids[0];
    assert_has(
        &lines,
        &format!(
            "{}: row 2 (episode `{id}` step 3): step 3, expected 2",
            file.display()
        ),
    );
    assert_has(
        &lines,
        &format!(
            "{}: row 2 (episode `{id}` step 2): trajectories.parquet has episode `{id}` step 3 there",
            run.join("observations.parquet").display()
        ),
    );
    assert_has(
        &lines,
        &format!(
            "{}: rows: {} rows where trajectories.parquet has {}",
            run.join("observations.parquet").display(),
            t.num_rows(),
            t.num_rows() - 1
        ),
    );
    assert_has(
        &lines,
        &format!(
            "{}: row 0 (episode `{id}`): steps {n} where trajectories.parquet has {} rows",
            run.join("episodes.parquet").display(),
            n - 1
        ),
    );
}

#[test]
fn a_flipped_success_and_a_truncated_image_cell_are_named() {
    let (_t, run) = copy("RUN");
    let eps = run.join("episodes.parquet");
    let t = table(&eps);
    let ok = t
        .column_by_name("success")
        .unwrap()
        .as_any()
        .downcast_ref::<BooleanArray>()
        .unwrap()
        .clone();
    let flipped: BooleanArray = (0..ok.len())
        .map(|i| Some(ok.value(i) != (i == 1)))
        .collect();
    write_table(&eps, &with_column(&t, "success", Arc::new(flipped)));
    let id = &strings(&t, "episode_id")[1];

    let obs = run.join("observations.parquet");
    let o = table(&obs);
    let color = o
        .column_by_name("color")
        .unwrap()
        .as_any()
        .downcast_ref::<BinaryArray>()
        .unwrap();
    let cut: BinaryArray = (0..color.len())
        .map(|i| {
            let v = color.value(i);
            Some(if i == 4 { &v[..v.len() - 5] } else { v })
        })
        .collect();
    write_table(&obs, &with_column(&o, "color", Arc::new(cut)));
    let lines = problems(&run, None);
    assert_has(
        &lines,
        &format!(
            "{}: row 1 (episode `{id}`): success {} where its last trajectory row says {}",
            eps.display(),
            !ok.value(1),
            ok.value(1)
        ),
    );
    let o_ids = strings(&o, "episode_id");
    let step = o
        .column_by_name("step")
        .unwrap()
        .as_any()
        .downcast_ref::<arrow::array::UInt32Array>()
        .unwrap()
        .value(4);
    let full = color.value(4).len();
    assert_has(
        &lines,
        &format!(
            "{}: row 4 (episode `{}` step {step}): `color`: image is {} bytes, the column holds 16×16×3 uint8",
            obs.display(),
            o_ids[4],
            full - 5
        ),
    );
}

fn lerobot_data(root: &Path) -> PathBuf {
    root.join("data/chunk-000/file-000.parquet")
}

#[test]
fn a_broken_lerobot_index_and_a_truncated_image_are_named() {
    let (_t, root) = copy("RUN/lerobot");
    let file = lerobot_data(&root);
    let t = table(&file);
    let index = t
        .column_by_name("index")
        .unwrap()
        .as_any()
        .downcast_ref::<Int64Array>()
        .unwrap()
        .clone();
    let broken: Int64Array = (0..index.len())
        .map(|i| Some(if i == 5 { 99 } else { index.value(i) }))
        .collect();
    let key = "observation.images.color";
    let images = t
        .column_by_name(key)
        .unwrap()
        .as_any()
        .downcast_ref::<StructArray>()
        .unwrap()
        .clone();
    let bytes = images
        .column_by_name("bytes")
        .unwrap()
        .as_any()
        .downcast_ref::<BinaryArray>()
        .unwrap();
    let full = bytes.value(3).len();
    let cut: BinaryArray = (0..bytes.len())
        .map(|i| {
            let v = bytes.value(i);
            Some(if i == 3 { &v[..v.len() - 100] } else { v })
        })
        .collect();
    let (fields, mut columns, nulls) = images.into_parts();
    columns[0] = Arc::new(cut);
    let images = StructArray::new(fields, columns, nulls);
    let t = with_column(&t, "index", Arc::new(broken));
    write_table(&file, &with_column(&t, key, Arc::new(images)));
    let lines = problems(&root, None);
    assert_has(
        &lines,
        &format!(
            "{}: row 5 (episode 0 frame 5): index 99 where 5 comes next",
            file.display()
        ),
    );
    let header = full - 16 * 16 * 3;
    assert_has(
        &lines,
        &format!(
            "{}: row 3 (episode 0 frame 3): `{key}`: truncated: {} pixel bytes where a 16×16 PPM needs 768",
            file.display(),
            full - 100 - header
        ),
    );
}

#[test]
fn a_changed_statistic_is_recomputed_from_the_frames() {
    let (_t, root) = copy("RUN/lerobot");
    let path = root.join("meta/stats.json");
    let mut stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let mean = stats["observation.state"]["mean"][0].as_f64().unwrap();
    stats["observation.state"]["mean"][0] = serde_json::json!(mean + 0.5);
    std::fs::write(&path, serde_json::to_vec_pretty(&stats).unwrap()).unwrap();
    // The per-episode statistics in meta/episodes, recomputed bit for bit.
    let meta = root.join("meta/episodes/chunk-000/file-000.parquet");
    let t = table(&meta);
    let col = "stats/observation.state/max";
    let max = t.column_by_name(col).unwrap().clone();
    let list = max
        .as_any()
        .downcast_ref::<arrow::array::ListArray>()
        .unwrap();
    let values = list
        .values()
        .as_any()
        .downcast_ref::<arrow::array::Float64Array>()
        .unwrap();
    let was = values.value(0);
    let mut changed: Vec<f64> = values.values().to_vec();
    changed[0] = was + 1.0;
    let new = arrow::array::ListArray::new(
        Arc::new(arrow::datatypes::Field::new(
            "item",
            arrow::datatypes::DataType::Float64,
            true,
        )),
        list.offsets().clone(),
        Arc::new(arrow::array::Float64Array::from(changed)),
        list.nulls().cloned(),
    );
    write_table(&meta, &with_column(&t, col, Arc::new(new)));
    let lines = problems(&root, None);
    assert_has(
        &lines,
        &format!(
            "{}: observation.state.mean: [0] is {} where the frames give {mean}",
            path.display(),
            mean + 0.5
        ),
    );
    assert_has(
        &lines,
        &format!(
            "{}: row 0 (episode 0): `{col}`[0] is {} where the frames give {was}",
            meta.display(),
            was + 1.0
        ),
    );
}

#[test]
fn a_damaged_parquet_footer_and_files_missing_or_unlisted_are_named() {
    let (_t, root) = copy("RUN/lerobot");
    let file = lerobot_data(&root);
    let mut bytes = std::fs::read(&file).unwrap();
    let n = bytes.len();
    bytes[n - 4..].copy_from_slice(b"XXXX");
    std::fs::write(&file, &bytes).unwrap();
    std::fs::write(root.join("extra.txt"), b"hello").unwrap();
    std::fs::remove_file(root.join("meta/tasks.parquet")).unwrap();
    let lines = problems(&root, None);
    assert_has(
        &lines,
        &format!(
            "{}: file: Parquet error: Invalid Parquet file. Corrupt footer",
            file.display()
        ),
    );
    assert_has(
        &lines,
        &format!(
            "{}: file: missing (listed in meta/provenance.json)",
            root.join("meta/tasks.parquet").display()
        ),
    );
    assert_has(
        &lines,
        &format!(
            "{}: file: not listed in meta/provenance.json",
            root.join("extra.txt").display()
        ),
    );
    assert!(lines.iter().all(|l| !l.contains('\n')));
}

#[test]
fn a_start_off_the_grid_and_a_wrong_geodesic_are_found_on_the_baked_grids() {
    let (_t, eps) = copy("eps.parquet");
    let data = fixture().dir.path().join("DATA");
    let mut episodes = minos::episode::format::read_episodes(&eps).unwrap();
    episodes[0].start_position = [1000.0, 0.0, 1000.0];
    let stored = episodes[1].geodesic_distance;
    episodes[1].geodesic_distance = stored + 1.0;
    minos::episode::format::write_episodes(&eps, &episodes).unwrap();
    let lines = problems(&eps, Some(&data));
    assert_has(
        &lines,
        &format!(
            "{}: row 0 (episode `{}`): start (1000.000, 0.000, 1000.000) is not on the navigable grid of scene `{}`",
            eps.display(),
            episodes[0].episode_id,
            episodes[0].scene_id
        ),
    );
    let prefix = format!(
        "{}: row 1 (episode `{}`): geodesic_distance {} m where the grid gives ",
        eps.display(),
        episodes[1].episode_id,
        stored + 1.0
    );
    let line = lines
        .iter()
        .find(|l| l.starts_with(&prefix))
        .unwrap_or_else(|| panic!("{lines:#?}"));
    let d: f32 = line[prefix.len()..].trim_end_matches(" m").parse().unwrap();
    assert!(
        (d - stored).abs() <= minos::verify::GEODESIC_TOLERANCE,
        "{line}"
    );
    // Rewritten, so its checksum no longer matches the sidecar.
    assert!(
        lines[0].starts_with(&format!("{}: checksum: sha256 ", eps.display())),
        "{lines:#?}"
    );
    // The clean episodes are not flagged.
    assert_eq!(lines.len(), 3, "{lines:#?}");
}

#[test]
fn a_data_folder_with_a_missing_grid_and_a_damaged_manifest_is_named() {
    let (_t, data) = copy("DATA");
    let nav = std::fs::read_dir(data.join("nav"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|e| e == "nav"))
        .unwrap();
    std::fs::remove_file(&nav).unwrap();
    let rel = format!("nav/{}", nav.file_name().unwrap().to_string_lossy());
    let lines = problems(&data, None);
    assert_eq!(
        lines,
        [format!(
            "{}: file: missing (listed in provenance.json)",
            data.join(&rel).display()
        )]
    );
}

#[test]
fn diff_names_the_episode_step_column_and_both_values() {
    let f = fixture();
    let (_t, run) = copy("RUN");
    let same = minos::diff::diff(&f.dir.path().join("RUN"), &run).unwrap();
    assert!(same.identical(), "{:?}", same.differences);
    let file = run.join("trajectories.parquet");
    let t = table(&file);
    let x = t
        .column_by_name("x")
        .unwrap()
        .as_any()
        .downcast_ref::<Float32Array>()
        .unwrap()
        .clone();
    let changed: Float32Array = (0..x.len())
        .map(|i| Some(if i == 7 { x.value(i) + 0.5 } else { x.value(i) }))
        .collect();
    write_table(&file, &with_column(&t, "x", Arc::new(changed)));
    let mut metrics: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run.join("metrics.json")).unwrap()).unwrap();
    let spl = metrics["groups"]["all"]["spl"].clone();
    metrics["groups"]["all"]["spl"] = serde_json::json!(0.125);
    std::fs::write(
        run.join("metrics.json"),
        serde_json::to_vec_pretty(&metrics).unwrap(),
    )
    .unwrap();
    let ids = strings(&t, "episode_id");
    let steps = t
        .column_by_name("step")
        .unwrap()
        .as_any()
        .downcast_ref::<arrow::array::UInt32Array>()
        .unwrap()
        .value(7);
    let report = minos::diff::diff(&f.dir.path().join("RUN"), &run).unwrap();
    let lines: Vec<String> = report.differences.iter().map(|d| d.to_string()).collect();
    assert_eq!(
        lines,
        [
            format!("metrics.json: `groups.all.spl`: {spl} vs 0.125"),
            format!(
                "trajectories.parquet: row 7 (episode `{}` step {steps}): column `x`: {} vs {}",
                ids[7],
                x.value(7),
                x.value(7) + 0.5
            ),
        ]
    );
    let (code, out, _) = cli(&[
        "diff".as_ref(),
        f.dir.path().join("RUN").as_os_str(),
        run.as_os_str(),
    ]);
    assert_eq!(code, 1);
    assert!(
        out.contains("\n2 of ") && out.ends_with(" files differ\n"),
        "{out}"
    );
}
