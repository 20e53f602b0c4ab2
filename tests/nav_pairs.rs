//! `minos nav query --pairs` on a generated house: every row equals the single-query answer
//! (the library's `route` and the command's own `--from/--to`), CSV, JSON lines and Parquet
//! agree, the bytes do not depend on the thread count, and a bad row is a one-line error
//! naming the file, the row and the column.

use crate::common;

use std::path::PathBuf;
use std::sync::Arc;

use arrow::array::{
    Array, ArrayRef, BooleanArray, Float32Array, Float64Array, ListArray, RecordBatch,
};
use common::{baked_houses, minos, RunOk};
use glam::Vec3;
use minos::generate::GenerateConfig;
use minos::navmesh::route::route;
use minos::navmesh::{NavGrid, NONE};
use minos::parquet_io::{read_batches, write_batches, writer_properties};

struct Fixture {
    dir: tempfile::TempDir,
    scene: String,
    grid: NavGrid,
    pairs: Vec<(Vec3, Vec3)>,
}

/// One baked two-level house with closed doors, and pairs of points on it: walkable points
/// (off their span centres) paired across the house, and one pair far from any floor.
fn fixture() -> &'static Fixture {
    static F: std::sync::OnceLock<Fixture> = std::sync::OnceLock::new();
    F.get_or_init(|| {
        let dir = common::shared_tempdir();
        let cfg = GenerateConfig {
            houses: 1,
            seed: 21,
            rooms: (5, 8),
            levels: (2, 2),
            closed_door_prob: 0.3,
            ..Default::default()
        };
        let (data, ids) = baked_houses(dir.path(), &cfg);
        let scene = ids[0].clone();
        let grid = data
            .read_grid(&minos::scene::SceneRef::parse(&scene))
            .unwrap();
        let spans: Vec<u32> = grid
            .walkable_spans(None)
            .into_iter()
            .filter(|&s| grid.spans[s as usize].room != NONE)
            .collect();
        let step = (spans.len() / 60).max(1);
        let points: Vec<Vec3> = spans
            .iter()
            .step_by(step)
            .map(|&s| grid.span_position(s as usize) + Vec3::new(0.03, 0.0, -0.02))
            .collect();
        let n = points.len();
        let mut pairs: Vec<(Vec3, Vec3)> = (0..n)
            .map(|i| (points[i], points[(i * 7 + n / 2) % n]))
            .collect();
        pairs.insert(3, (Vec3::new(500.0, 0.0, 500.0), points[0]));
        // One pair from the first point to a walkable span of each other island.
        let home = grid.spans[grid.snap(points[0]).unwrap() as usize].island;
        for island in 0..grid.islands.len() as u32 {
            if island != home {
                if let Some(&s) = grid.walkable_spans(Some(island)).first() {
                    pairs.push((points[0], grid.span_position(s as usize)));
                }
            }
        }
        assert!(
            grid.islands.len() > 1,
            "the house has one island: no unreachable pair"
        );
        Fixture {
            dir,
            scene,
            grid,
            pairs,
        }
    })
}

fn data_dir() -> PathBuf {
    fixture().dir.path().join("DATA")
}

fn pairs_csv(name: &str, rows: &[String]) -> PathBuf {
    let path = fixture().dir.path().join(name);
    let mut text = String::from("id,from_x,from_y,from_z,to_x,to_y,to_z\n");
    for (i, r) in rows.iter().enumerate() {
        text.push_str(&format!("p{i},{r}\n"));
    }
    std::fs::write(&path, text).unwrap();
    path
}

fn pair_rows() -> Vec<String> {
    fixture()
        .pairs
        .iter()
        .map(|(a, b)| format!("{},{},{},{},{},{}", a.x, a.y, a.z, b.x, b.y, b.z))
        .collect()
}

fn query(threads: &str, extra: &[&str]) -> std::process::Output {
    let f = fixture();
    minos()
        .args(["--threads", threads, "nav", "query", "--data"])
        .arg(data_dir())
        .args(["--scene", &f.scene])
        .args(extra)
        .ok_output()
}

fn parse_f32(s: &str) -> Option<f32> {
    (!s.is_empty()).then(|| s.parse().unwrap())
}

#[test]
fn every_row_equals_the_single_query_answer_whatever_the_threads() {
    let f = fixture();
    let csv = pairs_csv("pairs.csv", &pair_rows());
    let one = query("1", &["--pairs", csv.to_str().unwrap()]);
    let two = query("2", &["--pairs", csv.to_str().unwrap()]);
    assert_eq!(one.stdout, two.stdout, "output depends on the thread count");
    assert!(String::from_utf8_lossy(&two.stderr).contains("queries/s on 2 threads"));
    let text = String::from_utf8(one.stdout).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("from_x,from_y,from_z,to_x,to_y,to_z,reachable,geodesic,euclidean,rooms,room_classes,doors,error")
    );
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), f.pairs.len());
    let (mut reachable, mut unreachable) = (0, 0);
    for (row, &(from, to)) in rows.iter().zip(&f.pairs) {
        let cols: Vec<&str> = row.splitn(13, ',').collect();
        let got: Vec<f32> = cols[..6].iter().map(|c| c.parse().unwrap()).collect();
        assert_eq!(got, [from.x, from.y, from.z, to.x, to.y, to.z]);
        assert_eq!(parse_f32(cols[8]), Some(from.distance(to)));
        match route(&f.grid, from, to) {
            Ok(r) => {
                assert_eq!(cols[6], r.reachable.to_string(), "{row}");
                assert_eq!(parse_f32(cols[7]), r.geodesic, "{row}");
                let rooms: Vec<&str> = r
                    .rooms
                    .iter()
                    .map(|&i| f.grid.rooms[i as usize].id.as_str())
                    .collect();
                assert_eq!(cols[9], rooms.join(";"), "{row}");
                let doors: Vec<&str> = r
                    .doors
                    .iter()
                    .map(|&i| f.grid.objects[i as usize].id.as_str())
                    .collect();
                assert_eq!(cols[11], doors.join(";"), "{row}");
                assert_eq!(cols[12], "");
                if r.reachable {
                    reachable += 1;
                } else {
                    unreachable += 1;
                }
            }
            Err(e) => {
                assert_eq!(cols[6], "false");
                assert_eq!(cols[12], format!("\"{e}\""), "{row}");
            }
        }
    }
    assert!(reachable > 10, "{reachable} reachable pairs");
    assert!(unreachable > 0, "no unreachable pair");
    assert!(rows[3].contains("not within 2 m"), "{}", rows[3]);
    println!("{reachable} reachable, {unreachable} unreachable pairs");

    // The command's own single queries give the same numbers.
    for (row, &(from, to)) in rows
        .iter()
        .zip(&f.pairs)
        .filter(|(r, _)| r.contains(",true,"))
        .take(4)
    {
        let p = |v: Vec3| format!("{},{},{}", v.x, v.y, v.z);
        let out = query("1", &["--from", &p(from), "--to", &p(to), "--json"]);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let cols: Vec<&str> = row.splitn(13, ',').collect();
        assert_eq!(v["geodesic"].as_f64().map(|g| g as f32), parse_f32(cols[7]));
        let rooms: Vec<&str> = v["rooms"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["id"].as_str().unwrap())
            .collect();
        assert_eq!(rooms.join(";"), cols[9]);
    }

    // JSON lines carry the same answers.
    let json = query("2", &["--pairs", csv.to_str().unwrap(), "--json"]);
    let json = String::from_utf8(json.stdout).unwrap();
    let objs: Vec<serde_json::Value> = json
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(objs.len(), rows.len());
    for (o, row) in objs.iter().zip(&rows) {
        let cols: Vec<&str> = row.splitn(13, ',').collect();
        assert_eq!(o["reachable"].as_bool().unwrap().to_string(), cols[6]);
        assert_eq!(o["geodesic"].as_f64().map(|g| g as f32), parse_f32(cols[7]));
    }

    // --out FILE.csv holds exactly what stdout showed.
    let out_csv = f.dir.path().join("answers.csv");
    query(
        "2",
        &[
            "--pairs",
            csv.to_str().unwrap(),
            "--out",
            out_csv.to_str().unwrap(),
        ],
    );
    assert_eq!(std::fs::read_to_string(&out_csv).unwrap(), text);
}

#[test]
fn parquet_pairs_give_a_parquet_table_of_the_same_answers() {
    let f = fixture();
    let col = |k: usize| -> ArrayRef {
        let v: Vec<f64> = f
            .pairs
            .iter()
            .map(|(a, b)| f64::from([a.x, a.y, a.z, b.x, b.y, b.z][k]))
            .collect();
        if k.is_multiple_of(2) {
            Arc::new(Float64Array::from(v))
        } else {
            Arc::new(Float32Array::from(
                v.iter().map(|&x| x as f32).collect::<Vec<_>>(),
            ))
        }
    };
    let names = ["from_x", "from_y", "from_z", "to_x", "to_y", "to_z"];
    let batch =
        RecordBatch::try_from_iter(names.iter().enumerate().map(|(k, n)| (*n, col(k)))).unwrap();
    let input = f.dir.path().join("pairs.parquet");
    let schema = batch.schema();
    write_batches(
        &input,
        schema.clone(),
        writer_properties(1, None, &schema),
        [Ok(batch)],
    )
    .unwrap();
    let out = f.dir.path().join("answers.parquet");
    let said = query(
        "2",
        &[
            "--pairs",
            input.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert!(String::from_utf8_lossy(&said.stdout).contains("queries/s"));
    let mut n = 0;
    for batch in read_batches(&out).unwrap() {
        let batch = batch.unwrap();
        let get = |name: &str| batch.column_by_name(name).unwrap().clone();
        let reach = get("reachable");
        let reach = reach.as_any().downcast_ref::<BooleanArray>().unwrap();
        let geo = get("geodesic");
        let geo = geo.as_any().downcast_ref::<Float32Array>().unwrap();
        let rooms = get("rooms");
        let rooms = rooms.as_any().downcast_ref::<ListArray>().unwrap();
        for i in 0..batch.num_rows() {
            let (from, to) = f.pairs[n];
            let want = route(&f.grid, from, to).ok();
            assert_eq!(reach.value(i), want.as_ref().is_some_and(|r| r.reachable));
            let g = (!geo.is_null(i)).then(|| geo.value(i));
            assert_eq!(g, want.as_ref().and_then(|r| r.geodesic));
            assert_eq!(rooms.value(i).len(), want.map_or(0, |r| r.rooms.len()));
            n += 1;
        }
    }
    assert_eq!(n, f.pairs.len());
}

#[test]
fn a_bad_row_is_a_one_line_error_naming_file_row_and_column() {
    let mut rows = pair_rows();
    let mut fields: Vec<&str> = rows[2].split(',').collect();
    fields[2] = "zz";
    rows[2] = fields.join(",");
    let csv = pairs_csv("bad.csv", &rows);
    let f = fixture();
    let out = minos()
        .args(["nav", "query", "--data"])
        .arg(data_dir())
        .args(["--scene", &f.scene, "--pairs", csv.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    let want = format!("{}: row 3: from_z: `zz", csv.display());
    assert!(err.contains(&want), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(out.stdout.is_empty());
}
