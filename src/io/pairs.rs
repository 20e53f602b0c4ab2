//! The tables of batch navigation queries (`minos nav query --pairs`): reading the point pairs
//! and writing one answer row per pair.
//!
//! Pairs come from a CSV file with a header or a Parquet file (told apart by the `.parquet`
//! extension) with the columns `from_x, from_y, from_z, to_x, to_y, to_z` (other columns are
//! ignored; Parquet columns may be float32 or float64). Rows are numbered from 1 in the order
//! of the file (for CSV, row `n` is line `n + 1`; blank lines count but hold no pair). A bad
//! value is an error naming the file, the row and the column
//! (`pairs.csv: row 7: from_y: `a` is not a number`).
//!
//! Answers ([`PairAnswer`]) are written in the pairs' order as CSV (a header, then one line
//! per pair; lists joined by `;`), JSON lines, or Parquet (`--out FILE.parquet`); files are
//! written atomically.

use crate::file_error::FileError;
use std::io::Write;
use std::path::Path;
use std::sync::Arc;

use arrow::array::{
    Array, ArrayRef, BooleanArray, Float32Array, Float32Builder, Float64Array, ListBuilder,
    RecordBatch, StringArray, StringBuilder,
};
use arrow::datatypes::{DataType, Field, Schema, SchemaRef};
use glam::Vec3;
use serde_json::json;

use crate::atomic::write_atomic;
use crate::navmesh::route::{NotWalkable, Route};
use crate::navmesh::NavGrid;
use crate::parquet_io::{read_batches, write_batches, writer_properties, ParquetFileError};

/// The six input columns, in the order of a pair's coordinates.
pub const PAIR_COLUMNS: [&str; 6] = ["from_x", "from_y", "from_z", "to_x", "to_y", "to_z"];

/// The output columns of CSV and Parquet answers.
pub const ANSWER_COLUMNS: [&str; 13] = [
    "from_x",
    "from_y",
    "from_z",
    "to_x",
    "to_y",
    "to_z",
    "reachable",
    "geodesic",
    "euclidean",
    "rooms",
    "room_classes",
    "doors",
    "error",
];

/// A pairs file that cannot be read, or an answers file that cannot be written.
#[derive(Debug, thiserror::Error)]
pub enum PairsError {
    /// File system error.
    #[error(transparent)]
    Io(#[from] FileError),
    /// The file as a whole is wrong (no header, a column missing, not Parquet).
    #[error("{path}: {message}")]
    Shape {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// A bad value in one row.
    #[error("{path}: row {row}: {field}: {message}")]
    Row {
        /// The file.
        path: String,
        /// The row, from 1.
        row: usize,
        /// The column.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A Parquet file that cannot be read or written.
    #[error(transparent)]
    Parquet(#[from] ParquetFileError),
}

/// The answer to one pair.
#[derive(Debug, Clone, PartialEq)]
pub struct PairAnswer {
    /// The start point as given.
    pub from: Vec3,
    /// The goal point as given.
    pub to: Vec3,
    /// A path exists.
    pub reachable: bool,
    /// Its length (m); `None` when unreachable.
    pub geodesic: Option<f32>,
    /// Straight-line distance between the points as given (m).
    pub euclidean: f32,
    /// Rooms passed, in order: `(id, class name)`.
    pub rooms: Vec<(String, String)>,
    /// Doors passed, in order (object ids).
    pub doors: Vec<String>,
    /// Why there is no answer (a point far from walkable floor), if so.
    pub error: Option<String>,
}

impl PairAnswer {
    /// The answer row of the pair `(from, to)` on `grid` from its route, or from why it has
    /// none.
    pub fn new(grid: &NavGrid, from: Vec3, to: Vec3, route: Result<Route, NotWalkable>) -> Self {
        let euclidean = from.distance(to);
        match route {
            Ok(r) => PairAnswer {
                from,
                to,
                reachable: r.reachable,
                geodesic: r.geodesic,
                euclidean,
                rooms: r.room_names(grid),
                doors: r.door_ids(grid),
                error: None,
            },
            Err(e) => PairAnswer {
                from,
                to,
                reachable: false,
                geodesic: None,
                euclidean,
                rooms: Vec::new(),
                doors: Vec::new(),
                error: Some(crate::escape::error_line(&e)),
            },
        }
    }
}

fn is_parquet(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("parquet"))
}

/// Reads the `(from, to)` pairs of a CSV or Parquet file.
pub fn read_pairs(path: &Path) -> Result<Vec<(Vec3, Vec3)>, PairsError> {
    if is_parquet(path) {
        read_parquet_pairs(path)
    } else {
        let text = std::fs::read_to_string(path)
            .map_err(|source| PairsError::Io(FileError::new(path, source)))?;
        parse_csv_pairs(path, &text)
    }
}

fn pair_from(c: [f32; 6]) -> (Vec3, Vec3) {
    (Vec3::new(c[0], c[1], c[2]), Vec3::new(c[3], c[4], c[5]))
}

/// Parses CSV text (header first) into pairs; `path` names the file in errors.
fn parse_csv_pairs(path: &Path, text: &str) -> Result<Vec<(Vec3, Vec3)>, PairsError> {
    let p = path.display().to_string();
    let mut lines = text.lines();
    let header: Vec<&str> = lines
        .next()
        .map(|h| h.split(',').map(str::trim).collect())
        .unwrap_or_default();
    let mut index = [0usize; 6];
    for (slot, name) in index.iter_mut().zip(PAIR_COLUMNS) {
        *slot = header
            .iter()
            .position(|h| *h == name)
            .ok_or_else(|| PairsError::Shape {
                path: p.clone(),
                message: format!(
                    "the header has no column `{name}` (expected {})",
                    PAIR_COLUMNS.join(",")
                ),
            })?;
    }
    let mut pairs = Vec::new();
    for (i, line) in lines.enumerate() {
        let row = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != header.len() {
            return Err(PairsError::Row {
                path: p,
                row,
                field: "(row)".into(),
                message: format!("{} fields, the header has {}", fields.len(), header.len()),
            });
        }
        let mut c = [0f32; 6];
        for (k, (&col, name)) in index.iter().zip(PAIR_COLUMNS).enumerate() {
            let text = fields[col];
            c[k] = text
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| PairsError::Row {
                    path: p.clone(),
                    row,
                    field: name.into(),
                    message: format!("`{text}` is not a finite number"),
                })?;
        }
        pairs.push(pair_from(c));
    }
    Ok(pairs)
}

fn read_parquet_pairs(path: &Path) -> Result<Vec<(Vec3, Vec3)>, PairsError> {
    let p = path.display().to_string();
    let mut pairs = Vec::new();
    for batch in read_batches(path)? {
        let batch = batch.map_err(|e| ParquetFileError::format(path, e))?;
        let mut cols: Vec<Vec<Option<f64>>> = Vec::with_capacity(6);
        for name in PAIR_COLUMNS {
            let col = batch
                .column_by_name(name)
                .ok_or_else(|| PairsError::Shape {
                    path: p.clone(),
                    message: format!("column `{name}` is missing"),
                })?;
            let values: Vec<Option<f64>> =
                if let Some(a) = col.as_any().downcast_ref::<Float32Array>() {
                    a.iter().map(|v| v.map(f64::from)).collect()
                } else if let Some(a) = col.as_any().downcast_ref::<Float64Array>() {
                    a.iter().collect()
                } else {
                    return Err(PairsError::Shape {
                        path: p,
                        message: format!(
                            "column `{name}` is {}, expected float32 or float64",
                            col.data_type()
                        ),
                    });
                };
            cols.push(values);
        }
        for i in 0..batch.num_rows() {
            let row = pairs.len() + 1;
            let mut c = [0f32; 6];
            for (k, name) in PAIR_COLUMNS.iter().enumerate() {
                let v = cols[k].get(i).copied().flatten();
                c[k] = v
                    .map(|v| v as f32)
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| PairsError::Row {
                        path: p.clone(),
                        row,
                        field: (*name).into(),
                        message: match v {
                            None => "null".into(),
                            Some(v) => format!("{v} is not a finite float32"),
                        },
                    })?;
            }
            pairs.push(pair_from(c));
        }
    }
    Ok(pairs)
}

/// A CSV field, quoted when it holds a comma, a quote or a line break.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The CSV header line of answers (without the line break).
pub fn csv_header() -> String {
    ANSWER_COLUMNS.join(",")
}

/// One answer as a CSV line (without the line break). Numbers are written in the shortest
/// form that reads back to the same float32; an unknown geodesic is an empty field.
pub fn csv_line(a: &PairAnswer) -> String {
    let ids: Vec<&str> = a.rooms.iter().map(|r| r.0.as_str()).collect();
    let classes: Vec<&str> = a.rooms.iter().map(|r| r.1.as_str()).collect();
    let fields = [
        a.from.x.to_string(),
        a.from.y.to_string(),
        a.from.z.to_string(),
        a.to.x.to_string(),
        a.to.y.to_string(),
        a.to.z.to_string(),
        a.reachable.to_string(),
        a.geodesic.map(|g| g.to_string()).unwrap_or_default(),
        a.euclidean.to_string(),
        csv_field(&ids.join(";")),
        csv_field(&classes.join(";")),
        csv_field(&a.doors.join(";")),
        csv_field(a.error.as_deref().unwrap_or("")),
    ];
    fields.join(",")
}

/// One answer as a JSON object: `from`, `to`, and the fields of `minos nav query --json`
/// (`reachable`, `geodesic`, `euclidean`, `rooms` as `{id, class}`, `doors`) without the path,
/// plus `error` (null when answered).
pub fn json_line(a: &PairAnswer) -> serde_json::Value {
    json!({
        "from": [a.from.x, a.from.y, a.from.z],
        "to": [a.to.x, a.to.y, a.to.z],
        "reachable": a.reachable,
        "geodesic": a.geodesic,
        "euclidean": a.euclidean,
        "rooms": a.rooms.iter().map(|(id, class)| json!({"id": id, "class": class})).collect::<Vec<_>>(),
        "doors": a.doors,
        "error": a.error,
    })
}

/// Writes answers as CSV (header first) to `w`.
pub fn write_csv(w: &mut dyn Write, answers: &[PairAnswer]) -> std::io::Result<()> {
    writeln!(w, "{}", csv_header())?;
    for a in answers {
        writeln!(w, "{}", csv_line(a))?;
    }
    Ok(())
}

/// Writes answers as JSON lines to `w`.
pub fn write_json_lines(w: &mut dyn Write, answers: &[PairAnswer]) -> std::io::Result<()> {
    for a in answers {
        writeln!(w, "{}", json_line(a))?;
    }
    Ok(())
}

fn answer_schema() -> SchemaRef {
    let list = || DataType::List(Arc::new(Field::new("item", DataType::Utf8, false)));
    let mut fields: Vec<Field> = ANSWER_COLUMNS[..6]
        .iter()
        .map(|n| Field::new(*n, DataType::Float32, false))
        .collect();
    fields.extend([
        Field::new("reachable", DataType::Boolean, false),
        Field::new("geodesic", DataType::Float32, true),
        Field::new("euclidean", DataType::Float32, false),
        Field::new("rooms", list(), false),
        Field::new("room_classes", list(), false),
        Field::new("doors", list(), false),
        Field::new("error", DataType::Utf8, true),
    ]);
    Arc::new(Schema::new(fields))
}

fn answer_batch(
    schema: &SchemaRef,
    answers: &[PairAnswer],
) -> Result<RecordBatch, arrow::error::ArrowError> {
    let coord = |f: fn(&PairAnswer) -> f32| -> ArrayRef {
        Arc::new(answers.iter().map(f).collect::<Float32Array>())
    };
    let list = |f: &dyn Fn(&PairAnswer) -> Vec<&str>| -> ArrayRef {
        let field = Arc::new(Field::new("item", DataType::Utf8, false));
        let mut b = ListBuilder::new(StringBuilder::new()).with_field(field);
        for a in answers {
            for s in f(a) {
                b.values().append_value(s);
            }
            b.append(true);
        }
        Arc::new(b.finish())
    };
    let mut geodesic = Float32Builder::with_capacity(answers.len());
    for a in answers {
        geodesic.append_option(a.geodesic);
    }
    let columns: Vec<ArrayRef> = vec![
        coord(|a| a.from.x),
        coord(|a| a.from.y),
        coord(|a| a.from.z),
        coord(|a| a.to.x),
        coord(|a| a.to.y),
        coord(|a| a.to.z),
        Arc::new(
            answers
                .iter()
                .map(|a| Some(a.reachable))
                .collect::<BooleanArray>(),
        ),
        Arc::new(geodesic.finish()),
        coord(|a| a.euclidean),
        list(&|a| a.rooms.iter().map(|r| r.0.as_str()).collect()),
        list(&|a| a.rooms.iter().map(|r| r.1.as_str()).collect()),
        list(&|a| a.doors.iter().map(String::as_str).collect()),
        Arc::new(
            answers
                .iter()
                .map(|a| a.error.as_deref())
                .collect::<StringArray>(),
        ),
    ];
    RecordBatch::try_new(schema.clone(), columns)
}

/// Writes answers to `path` atomically: Parquet for a `.parquet` name, else CSV.
pub fn write_answers(path: &Path, answers: &[PairAnswer]) -> Result<(), PairsError> {
    if is_parquet(path) {
        let schema = answer_schema();
        let props = writer_properties(3, Some(65_536), &schema);
        let batches = answers
            .chunks(65_536)
            .map(|chunk| answer_batch(&schema, chunk));
        write_batches(path, schema.clone(), props, batches)?;
        Ok(())
    } else {
        write_atomic(path, |w| write_csv(w, answers))
            .map_err(|source| PairsError::Io(FileError::new(path, source)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn answer(k: f32, reachable: bool) -> PairAnswer {
        PairAnswer {
            from: Vec3::new(k, 0.0, -1.0 - k),
            to: Vec3::new(1.0, 0.5, 0.1 + k),
            reachable,
            geodesic: reachable.then_some(2.5 + k),
            euclidean: 1.25,
            rooms: vec![
                ("0_1".into(), "kitchen".into()),
                ("0_2".into(), "hallway".into()),
            ],
            doors: if reachable {
                vec!["0_9".into()]
            } else {
                vec![]
            },
            error: (!reachable).then(|| "goal point (1.00, 0.50, 0.10) is far".to_string()),
        }
    }

    #[test]
    fn csv_pairs_parse_by_header_name_and_bad_rows_name_row_and_field() {
        let path = Path::new("p.csv");
        let text = "id,to_x,to_y,to_z,from_x,from_y,from_z\na,4,0,5,1,0.5,-2\n\nb,1e1,0,0,0,0,0\n";
        let pairs = parse_csv_pairs(path, text).unwrap();
        assert_eq!(
            pairs,
            vec![
                (Vec3::new(1.0, 0.5, -2.0), Vec3::new(4.0, 0.0, 5.0)),
                (Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)),
            ]
        );
        let err = parse_csv_pairs(path, "from_x,from_y,from_z,to_x,to_y\n").unwrap_err();
        assert!(
            err.to_string()
                .starts_with("p.csv: the header has no column `to_z`"),
            "{err}"
        );
        let bad = "from_x,from_y,from_z,to_x,to_y,to_z\n1,2,3,4,5,6\n1,2,3,4,x,6\n";
        let err = parse_csv_pairs(path, bad).unwrap_err().to_string();
        assert_eq!(err, "p.csv: row 2: to_y: `x` is not a finite number");
        let err = parse_csv_pairs(path, &bad.replace("4,x,6", "4,nan,6")).unwrap_err();
        assert!(
            err.to_string().starts_with("p.csv: row 2: to_y: `nan`"),
            "{err}"
        );
        let err = parse_csv_pairs(path, &bad.replace("4,x,6", "4,5")).unwrap_err();
        assert_eq!(
            err.to_string(),
            "p.csv: row 2: (row): 5 fields, the header has 6"
        );
    }

    #[test]
    fn parquet_pairs_read_float32_and_float64_and_name_null_rows() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.parquet");
        let write = |cols: Vec<(&str, ArrayRef)>| {
            let batch = RecordBatch::try_from_iter(cols).unwrap();
            let schema = batch.schema();
            let props = writer_properties(1, None, &schema);
            write_batches(&path, schema, props, [Ok(batch)]).unwrap();
        };
        let f32s = |v: Vec<Option<f32>>| -> ArrayRef { Arc::new(Float32Array::from(v)) };
        let f64s = |v: Vec<Option<f64>>| -> ArrayRef { Arc::new(Float64Array::from(v)) };
        write(vec![
            ("from_x", f32s(vec![Some(1.0), Some(2.0)])),
            ("from_y", f64s(vec![Some(0.0), Some(0.5)])),
            ("from_z", f32s(vec![Some(3.0), Some(-1.0)])),
            ("to_x", f32s(vec![Some(4.0), Some(0.0)])),
            ("to_y", f32s(vec![Some(0.0), Some(0.0)])),
            ("to_z", f64s(vec![Some(6.0), Some(7.0)])),
        ]);
        let pairs = read_pairs(&path).unwrap();
        assert_eq!(
            pairs[1],
            (Vec3::new(2.0, 0.5, -1.0), Vec3::new(0.0, 0.0, 7.0))
        );
        write(vec![
            ("from_x", f32s(vec![Some(1.0), Some(2.0)])),
            ("from_y", f64s(vec![Some(0.0), Some(0.5)])),
            ("from_z", f32s(vec![Some(3.0), None])),
            ("to_x", f32s(vec![Some(4.0), Some(0.0)])),
            ("to_y", f32s(vec![Some(0.0), Some(0.0)])),
            ("to_z", f64s(vec![Some(6.0), Some(7.0)])),
        ]);
        let err = read_pairs(&path).unwrap_err().to_string();
        assert_eq!(err, format!("{}: row 2: from_z: null", path.display()));
    }

    #[test]
    fn answers_write_as_csv_json_and_parquet_in_order() {
        let answers = vec![answer(0.0, true), answer(1.0, false)];
        let mut csv = Vec::new();
        write_csv(&mut csv, &answers).unwrap();
        let csv = String::from_utf8(csv).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], csv_header());
        assert_eq!(
            lines[1],
            "0,0,-1,1,0.5,0.1,true,2.5,1.25,0_1;0_2,kitchen;hallway,0_9,"
        );
        assert!(
            lines[2].starts_with("1,0,-2,1,0.5,1.1,false,,1.25,"),
            "{}",
            lines[2]
        );
        assert!(lines[2].ends_with(",\"goal point (1.00, 0.50, 0.10) is far\""));
        let j = json_line(&answers[0]);
        assert_eq!(j["rooms"][1], json!({"id": "0_2", "class": "hallway"}));
        assert_eq!(j["geodesic"], json!(2.5));
        assert!(json_line(&answers[1])["geodesic"].is_null());

        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.parquet");
        write_answers(&path, &answers).unwrap();
        let batch = read_batches(&path).unwrap().next().unwrap().unwrap();
        assert_eq!(batch.num_rows(), 2);
        let geo = batch.column_by_name("geodesic").unwrap();
        let geo = geo.as_any().downcast_ref::<Float32Array>().unwrap();
        assert_eq!((geo.value(0), geo.is_null(1)), (2.5, true));
        let names: Vec<String> = batch
            .schema()
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .collect();
        assert_eq!(names, ANSWER_COLUMNS);
        let csv_path = dir.path().join("a.csv");
        write_answers(&csv_path, &answers).unwrap();
        assert_eq!(std::fs::read_to_string(&csv_path).unwrap(), csv);
    }
}
