//! The first difference of two Parquet tables: a column only one has or typed differently,
//! else the first row where a value differs, named by its episode and step (run tables,
//! episode files: `episode_id`, `step`; LeRobot: `episode_index`, `frame_index`), with the
//! column and both values.

use std::path::Path;

use arrow::array::{Array, ArrayRef, AsArray, RecordBatch};
use arrow::datatypes::DataType;
use arrow::util::display::{ArrayFormatter, FormatOptions};

use super::quote;
use crate::parquet_io::{read_batches, ParquetFileError};

fn read(path: &Path) -> Result<RecordBatch, ParquetFileError> {
    let batches = read_batches(path)?;
    let schema = arrow::array::RecordBatchReader::schema(&batches);
    let all: Vec<RecordBatch> = batches
        .collect::<Result<_, _>>()
        .map_err(|e| ParquetFileError::format(path, e))?;
    arrow::compute::concat_batches(&schema, &all).map_err(|e| ParquetFileError::format(path, e))
}

/// The first difference in user terms, `None` when the tables hold the same values (the
/// caller then reports the bytes).
pub(super) fn first_difference(a: &Path, b: &Path) -> Option<String> {
    let (ta, tb) = match (read(a), read(b)) {
        (Ok(x), Ok(y)) => (x, y),
        (Err(e), _) | (_, Err(e)) => {
            return Some(format!("cannot be read: {}", crate::escape::error_line(&e)))
        }
    };
    let (sa, sb) = (ta.schema(), tb.schema());
    for f in sa.fields() {
        match sb.field_with_name(f.name()) {
            Err(_) => return Some(format!("column `{}` only in {}", f.name(), a.display())),
            Ok(g) if g.data_type() != f.data_type() => {
                return Some(format!(
                    "column `{}` is {} vs {}",
                    f.name(),
                    f.data_type(),
                    g.data_type()
                ))
            }
            Ok(_) => {}
        }
    }
    if let Some(g) = sb
        .fields()
        .iter()
        .find(|g| sa.field_with_name(g.name()).is_err())
    {
        return Some(format!("column `{}` only in {}", g.name(), b.display()));
    }
    let rows = ta.num_rows().min(tb.num_rows());
    // The first row where any column differs, and the first such column in A's order.
    let mut first: Option<(usize, usize)> = None;
    for (c, f) in sa.fields().iter().enumerate() {
        let (ca, cb) = (ta.column(c), tb.column_by_name(f.name())?);
        let (ca, cb) = (ca.slice(0, rows), cb.slice(0, rows));
        if ca.as_ref() == cb.as_ref() {
            continue;
        }
        let limit = first.map_or(rows, |(r, _)| r);
        if let Some(r) = (0..limit).find(|&r| ca.slice(r, 1).as_ref() != cb.slice(r, 1).as_ref()) {
            first = Some((r, c));
        }
    }
    if let Some((r, c)) = first {
        let name = sa.field(c).name();
        let cb = tb.column_by_name(name)?;
        return Some(format!(
            "{}: column `{name}`: {}",
            row_name(&ta, r),
            values(ta.column(c), cb, r)
        ));
    }
    if ta.num_rows() != tb.num_rows() {
        let (longer, n) = if ta.num_rows() > tb.num_rows() {
            (&ta, tb.num_rows())
        } else {
            (&tb, ta.num_rows())
        };
        return Some(format!(
            "{} vs {} rows, the first {n} equal; the first extra row is {}",
            ta.num_rows(),
            tb.num_rows(),
            row_name(longer, n)
        ));
    }
    if sa.metadata() != sb.metadata() {
        let key = sa
            .metadata()
            .keys()
            .chain(sb.metadata().keys())
            .find(|k| sa.metadata().get(*k) != sb.metadata().get(*k))
            .cloned()
            .unwrap_or_default();
        return Some(format!("same rows; the file metadata `{key}` differs"));
    }
    let field_meta = sa.fields().iter().find(|f| {
        sb.field_with_name(f.name())
            .is_ok_and(|g| g.metadata() != f.metadata())
    });
    if let Some(f) = field_meta {
        return Some(format!(
            "same rows; column `{}`'s metadata differs",
            f.name()
        ));
    }
    Some("same columns and values; the bytes differ (compression, encoding or row groups)".into())
}

/// A row in user terms: `episode `id` step 4`, `episode 3 frame 12`, or `row 7`.
fn row_name(t: &RecordBatch, r: usize) -> String {
    let text = |name: &str| -> Option<String> {
        let c = t.column_by_name(name)?;
        let f = ArrayFormatter::try_new(c.as_ref(), &FormatOptions::default()).ok()?;
        Some(f.value(r).to_string())
    };
    match (
        text("episode_id"),
        text("step"),
        text("episode_index"),
        text("frame_index"),
    ) {
        (Some(id), Some(step), _, _) => format!("row {r} (episode `{id}` step {step})"),
        (Some(id), None, _, _) => format!("row {r} (episode `{id}`)"),
        (None, _, Some(e), Some(f)) => format!("row {r} (episode {e} frame {f})"),
        (None, _, Some(e), None) => format!("row {r} (episode {e})"),
        _ => format!("row {r}"),
    }
}

/// `A vs B` for row `r`; binary cells by size and first differing byte.
fn values(a: &ArrayRef, b: &ArrayRef, r: usize) -> String {
    if let (DataType::Binary, DataType::Binary) = (a.data_type(), b.data_type()) {
        let (x, y) = (a.as_binary::<i32>().value(r), b.as_binary::<i32>().value(r));
        let at = x
            .iter()
            .zip(y)
            .position(|(p, q)| p != q)
            .unwrap_or(x.len().min(y.len()));
        return format!(
            "{} vs {} bytes, first difference at byte {at}",
            x.len(),
            y.len()
        );
    }
    let show = |c: &ArrayRef| {
        ArrayFormatter::try_new(c.as_ref(), &FormatOptions::default().with_null("null"))
            .map(|f| quote(&f.value(r).to_string()))
            .unwrap_or_else(|e| e.to_string())
    };
    format!("{} vs {}", show(a), show(b))
}
