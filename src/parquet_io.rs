//! Parquet plumbing shared by every table minos writes or reads — the manifest, episode files
//! and a run's tables: writer properties, writing record batches atomically, reading every
//! batch, and typed columns, with errors that name the file.

use std::fs::File;
use std::path::Path;

use arrow::array::{Array, RecordBatch};
use arrow::datatypes::{DataType, Schema, SchemaRef};
use parquet::arrow::arrow_reader::{ParquetRecordBatchReader, ParquetRecordBatchReaderBuilder};
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::{EnabledStatistics, WriterProperties};
use parquet::schema::types::ColumnPath;

use crate::atomic::write_atomic;

/// A Parquet file that could not be read or written; the message names the file.
#[derive(Debug, thiserror::Error)]
pub enum ParquetFileError {
    /// File system error.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// Parquet / Arrow error, or a column missing or of the wrong type.
    #[error("{path}: {message}")]
    Format {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
}

impl ParquetFileError {
    /// A format error of `path`. Control characters in `message` (a column name or value
    /// quoted from a corrupt file may hold a newline) are escaped: the error stays one line.
    pub fn format(path: &Path, message: impl ToString) -> Self {
        ParquetFileError::Format {
            path: path.display().to_string(),
            message: crate::escape::escape_controls(&message.to_string()),
        }
    }
}

/// Writer properties: zstd at `level`, at most `max_rows` rows per row group (the writer's
/// default when `None`), and binary (image) columns of `schema` without dictionary encoding or
/// statistics, which cost time and buy nothing for unique multi-kilobyte values.
pub fn writer_properties(level: i32, max_rows: Option<usize>, schema: &Schema) -> WriterProperties {
    let mut b = WriterProperties::builder().set_compression(Compression::ZSTD(
        ZstdLevel::try_new(level).unwrap_or_default(),
    ));
    if max_rows.is_some() {
        b = b.set_max_row_group_row_count(max_rows);
    }
    for f in schema.fields() {
        if f.data_type() == &DataType::Binary {
            let col = ColumnPath::from(f.name().as_str());
            b = b
                .set_column_dictionary_enabled(col.clone(), false)
                .set_column_statistics_enabled(col, EnabledStatistics::None);
        }
    }
    b.build()
}

#[derive(Debug, thiserror::Error)]
enum WriteErr {
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Parquet(#[from] parquet::errors::ParquetError),
    #[error(transparent)]
    Arrow(#[from] arrow::error::ArrowError),
}

/// Writes `batches` (in order) to `path` under a temporary name, renamed when complete.
pub fn write_batches(
    path: &Path,
    schema: SchemaRef,
    props: WriterProperties,
    batches: impl IntoIterator<Item = Result<RecordBatch, arrow::error::ArrowError>>,
) -> Result<(), ParquetFileError> {
    write_atomic(path, |w| -> Result<(), WriteErr> {
        let mut writer = ArrowWriter::try_new(w, schema, Some(props))?;
        for batch in batches {
            writer.write(&batch?)?;
        }
        writer.close()?;
        Ok(())
    })
    .map_err(|e| match e {
        WriteErr::Io(source) => ParquetFileError::Io {
            path: path.display().to_string(),
            source,
        },
        other => ParquetFileError::format(path, other),
    })
}

/// Opens `path` for reading its record batches (each batch error still needs the file's name:
/// see [`ParquetFileError::format`]).
pub fn read_batches(path: &Path) -> Result<ParquetRecordBatchReader, ParquetFileError> {
    let file = File::open(path).map_err(|source| ParquetFileError::Io {
        path: path.display().to_string(),
        source,
    })?;
    ParquetRecordBatchReaderBuilder::try_new(file)
        .and_then(|b| b.build())
        .map_err(|e| ParquetFileError::format(path, e))
}

/// Column `name` of `batch` as the array type `T`; the error says which column and why.
pub fn column<'a, T: Array + 'static>(batch: &'a RecordBatch, name: &str) -> Result<&'a T, String> {
    batch
        .column_by_name(name)
        .ok_or_else(|| format!("column `{name}` is missing"))?
        .as_any()
        .downcast_ref::<T>()
        .ok_or_else(|| format!("column `{name}` has an unexpected type"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use arrow::array::{BinaryArray, StringArray, UInt32Array};
    use arrow::datatypes::Field;
    use std::sync::Arc;

    #[test]
    fn format_errors_escape_control_characters() {
        let e = ParquetFileError::format(Path::new("t.parquet"), "field `a\nb\u{1}c` é");
        assert_eq!(e.to_string(), "t.parquet: field `a\\nb\\u{1}c` é");
    }

    fn table() -> (SchemaRef, RecordBatch) {
        let schema = Arc::new(Schema::new(vec![
            Field::new("id", DataType::Utf8, false),
            Field::new("n", DataType::UInt32, false),
            Field::new("image", DataType::Binary, false),
        ]));
        let batch = RecordBatch::try_new(
            schema.clone(),
            vec![
                Arc::new(StringArray::from(vec!["a", "b"])),
                Arc::new(UInt32Array::from(vec![1, 2])),
                Arc::new(BinaryArray::from(vec![&b"xy"[..], &b"z"[..]])),
            ],
        )
        .unwrap();
        (schema, batch)
    }

    #[test]
    fn batches_round_trip_and_columns_are_typed() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub/t.parquet");
        let (schema, batch) = table();
        let props = writer_properties(3, Some(1), &schema);
        write_batches(&path, schema, props, [Ok(batch.clone())]).unwrap();
        assert_eq!(
            std::fs::read_dir(path.parent().unwrap()).unwrap().count(),
            1
        );
        let groups = parquet::file::reader::SerializedFileReader::new(File::open(&path).unwrap())
            .map(|r| parquet::file::reader::FileReader::metadata(&r).num_row_groups())
            .unwrap();
        assert_eq!(groups, 2, "one row per row group");
        let back: Vec<RecordBatch> = read_batches(&path).unwrap().map(|b| b.unwrap()).collect();
        assert_eq!(back.iter().map(RecordBatch::num_rows).sum::<usize>(), 2);
        let ids = column::<StringArray>(&back[0], "id").unwrap();
        assert_eq!((ids.value(0), ids.value(1)), ("a", "b"));
        assert_eq!(
            column::<UInt32Array>(&back[0], "id").unwrap_err(),
            "column `id` has an unexpected type"
        );
        assert_eq!(
            column::<UInt32Array>(&back[0], "m").unwrap_err(),
            "column `m` is missing"
        );
    }

    #[test]
    fn errors_name_the_file_and_leave_nothing_behind() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("none.parquet");
        let err = read_batches(&missing).unwrap_err().to_string();
        assert!(err.starts_with(&missing.display().to_string()), "{err}");
        let junk = dir.path().join("junk.parquet");
        std::fs::write(&junk, b"not parquet").unwrap();
        assert!(read_batches(&junk)
            .unwrap_err()
            .to_string()
            .contains("junk.parquet"));
        // A batch that fails midway: no file, no temporary file.
        let (schema, batch) = table();
        let out = dir.path().join("out.parquet");
        let props = writer_properties(1, None, &schema);
        let bad = Err(arrow::error::ArrowError::ComputeError("boom".into()));
        let err = write_batches(&out, schema, props, [Ok(batch), bad]).unwrap_err();
        assert!(err.to_string().contains("boom"), "{err}");
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["junk.parquet"], "{names:?}");
    }
}
