//! Reading the columns `verify` needs from Parquet tables (through the guarded reader), and
//! the episode/step continuity check the run and LeRobot tables share.

use std::path::Path;

use arrow::array::{
    Array, ArrayRef, AsArray, BooleanArray, Float64Array, RecordBatch, StringArray,
};
use arrow::datatypes::{DataType, Float64Type};

use super::Found;
use crate::invalid::Invalid;
use crate::parquet_io::read_batches;

/// A whole table, its batches concatenated.
pub(super) fn read(path: &Path, found: &mut Found) -> Option<RecordBatch> {
    let batches = match read_batches(path) {
        Ok(b) => b,
        Err(e) => {
            found.problem(
                path,
                "file",
                strip_path(&crate::escape::error_line(&e), path),
            );
            return None;
        }
    };
    let schema = arrow::array::RecordBatchReader::schema(&batches);
    let mut all = Vec::new();
    for b in batches {
        match b {
            Ok(b) => all.push(b),
            Err(e) => {
                found.problem(path, "file", crate::escape::error_line(&e));
                return None;
            }
        }
    }
    match arrow::compute::concat_batches(&schema, &all) {
        Ok(b) => Some(b),
        Err(e) => {
            found.problem(path, "file", crate::escape::error_line(&e));
            None
        }
    }
}

/// An error message without the `path: ` its reader put first (the problem names the file).
pub(super) fn strip_path(message: &str, path: &Path) -> String {
    let prefix = format!("{}: ", path.display());
    message.strip_prefix(&prefix).unwrap_or(message).to_string()
}

/// Column `name` as strings (any string type), or why not.
pub(super) fn strings(batch: &RecordBatch, name: &str) -> Result<Vec<String>, Invalid> {
    let c = column(batch, name)?;
    let c = arrow::compute::cast(c, &DataType::Utf8).map_err(|e| format!("`{name}`: {e}"))?;
    let s: &StringArray = c.as_string();
    Ok((0..s.len())
        .map(|i| {
            if s.is_null(i) {
                String::new()
            } else {
                s.value(i).to_string()
            }
        })
        .collect())
}

/// Column `name` as numbers (integers, floats and booleans as 0/1; null as NaN).
pub(super) fn numbers(batch: &RecordBatch, name: &str) -> Result<Vec<f64>, Invalid> {
    Ok(all_f64(column(batch, name)?))
}

/// Column `name` as booleans (null as false).
pub(super) fn bools(batch: &RecordBatch, name: &str) -> Result<Vec<bool>, Invalid> {
    let c = column(batch, name)?;
    let b: &BooleanArray = c
        .as_any()
        .downcast_ref()
        .ok_or_else(|| format!("column `{name}` is {}, not bool", c.data_type()))?;
    Ok((0..b.len()).map(|i| b.is_valid(i) && b.value(i)).collect())
}

fn column<'a>(batch: &'a RecordBatch, name: &str) -> Result<&'a ArrayRef, Invalid> {
    batch
        .column_by_name(name)
        .ok_or_else(|| Invalid::new(format!("column `{name}` is missing")))
}

/// Every number of `array`, lists flattened in order (nulls as NaN).
pub(super) fn all_f64(array: &dyn Array) -> Vec<f64> {
    let mut out = Vec::new();
    push_f64(array, &mut out);
    out
}

/// The numbers of row `row` of `array` (a list cell flattened).
pub(super) fn cell_f64(array: &dyn Array, row: usize) -> Vec<f64> {
    all_f64(&array.slice(row, 1))
}

fn push_f64(array: &dyn Array, out: &mut Vec<f64>) {
    match array.data_type() {
        DataType::List(_) => {
            let l = array.as_list::<i32>();
            for i in 0..l.len() {
                push_f64(&l.value(i), out);
            }
        }
        DataType::LargeList(_) => {
            let l = array.as_list::<i64>();
            for i in 0..l.len() {
                push_f64(&l.value(i), out);
            }
        }
        DataType::FixedSizeList(_, _) => {
            let l = array.as_fixed_size_list();
            for i in 0..l.len() {
                push_f64(&l.value(i), out);
            }
        }
        _ => match arrow::compute::cast(array, &DataType::Float64) {
            Ok(c) => {
                let f: &Float64Array = c.as_primitive::<Float64Type>();
                out.extend((0..f.len()).map(|i| if f.is_null(i) { f64::NAN } else { f.value(i) }));
            }
            Err(_) => out.extend(std::iter::repeat_n(f64::NAN, array.len())),
        },
    }
}

/// Checks that `rows` (episode id, step) hold each episode's steps `0, 1, …` in one block,
/// episodes in increasing id order; one problem per break.
pub(super) fn check_steps(path: &Path, rows: &[(String, u64)], found: &mut Found) {
    let mut seen = std::collections::HashSet::new();
    let mut prev: Option<&(String, u64)> = None;
    for (i, row) in rows.iter().enumerate() {
        let (id, step) = row;
        let expected = match prev {
            Some((p, s)) if p == id => s + 1,
            _ => 0,
        };
        let record = format!("row {i} (episode `{id}` step {step})");
        if *step != expected {
            found.problem(
                path,
                record.as_str(),
                format!("step {step}, expected {expected}"),
            );
        }
        if prev.is_none_or(|(p, _)| p != id) {
            if !seen.insert(id.as_str()) {
                found.problem(path, record, "the episode's rows are split into two blocks");
            } else if let Some((p, _)) = prev.filter(|(p, _)| p > id) {
                found.problem(
                    path,
                    record,
                    format!("episode after `{p}`: episodes are not in id order"),
                );
            }
        }
        prev = Some(row);
    }
}
