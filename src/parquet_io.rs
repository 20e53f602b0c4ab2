//! Parquet plumbing shared by every table minos writes or reads — the manifest, episode files
//! and a run's tables: writer properties, writing record batches atomically, reading every
//! batch, and typed columns, with errors that name the file.

use crate::file_error::FileError;
use std::fs::File;
use std::path::Path;

use arrow::array::{Array, RecordBatch};
use std::sync::Arc;

use arrow::datatypes::{DataType, Field, Schema, SchemaRef};
use parquet::arrow::arrow_reader::{ParquetRecordBatchReader, ParquetRecordBatchReaderBuilder};
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::{EnabledStatistics, WriterProperties};
use parquet::schema::types::ColumnPath;

use crate::atomic::write_atomic;
use crate::invalid::Invalid;

/// A Parquet file that could not be read or written; the message names the file.
#[derive(Debug, thiserror::Error)]
pub enum ParquetFileError {
    /// File system error.
    #[error(transparent)]
    Io(#[from] FileError),
    /// Parquet / Arrow error, or a column missing or of the wrong type.
    #[error("{path}")]
    Format {
        /// The file.
        path: String,
        /// What is wrong.
        #[source]
        cause: FormatCause,
    },
}

impl ParquetFileError {
    /// A format error of `path`: a Parquet or Arrow error, or a table rule broken (an
    /// [`Invalid`] or its text).
    pub fn format(path: &Path, cause: impl Into<FormatCause>) -> Self {
        ParquetFileError::Format {
            path: path.display().to_string(),
            cause: cause.into(),
        }
    }
}

/// What is wrong inside a Parquet file, or with the batches written to one: the Parquet or
/// Arrow library's error (kept, to match on), or a rule of minos's tables broken (a column
/// missing or of the wrong type). Shown with control characters escaped — a column name or
/// value quoted from a damaged file may hold a newline — so the error stays one line; the
/// shown text is the whole of it (no further `source()`).
#[derive(Debug)]
pub enum FormatCause {
    /// The Parquet reader or writer failed.
    Parquet(Box<parquet::errors::ParquetError>),
    /// An Arrow operation failed (building, casting or joining batches).
    Arrow(Box<arrow::error::ArrowError>),
    /// A rule of minos's tables is broken, or a reader panicked on a damaged file.
    Table(Box<Invalid>),
}

impl std::fmt::Display for FormatCause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let text = match self {
            FormatCause::Parquet(e) => e.to_string(),
            FormatCause::Arrow(e) => e.to_string(),
            FormatCause::Table(e) => e.to_string(),
        };
        f.write_str(&crate::escape::escape_controls(&text))
    }
}

impl std::error::Error for FormatCause {}

impl From<parquet::errors::ParquetError> for FormatCause {
    fn from(e: parquet::errors::ParquetError) -> Self {
        FormatCause::Parquet(Box::new(e))
    }
}

impl From<arrow::error::ArrowError> for FormatCause {
    fn from(e: arrow::error::ArrowError) -> Self {
        FormatCause::Arrow(Box::new(e))
    }
}

impl From<Invalid> for FormatCause {
    fn from(e: Invalid) -> Self {
        FormatCause::Table(Box::new(e))
    }
}

impl From<String> for FormatCause {
    fn from(problem: String) -> Self {
        FormatCause::Table(Box::new(Invalid::new(problem)))
    }
}

impl From<&str> for FormatCause {
    fn from(problem: &str) -> Self {
        FormatCause::Table(Box::new(Invalid::new(problem)))
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
        WriteErr::Io(source) => ParquetFileError::Io(FileError::new(path, source)),
        WriteErr::Parquet(e) => ParquetFileError::format(path, e),
        WriteErr::Arrow(e) => ParquetFileError::format(path, e),
    })
}

/// Opens `path` for reading its record batches (each batch error still needs the file's name:
/// see [`ParquetFileError::format`]).
///
/// Files written by other tools read as minos's own: every standard compression (snappy,
/// gzip, lz4, brotli, zstd), and the type variants pandas, polars, duckdb and pyarrow write
/// are normalised batch by batch to the types minos writes — `large_string` and `string_view`
/// (and dictionary-encoded strings) to `utf8`, `large_binary` and `binary_view` to `binary`,
/// `large_list` and `list_view` to `list`, at any depth (see [`normal_type`]). A panic inside
/// the Parquet or Arrow readers (arrow-ipc panics on some damaged embedded Arrow schemas) is an
/// error naming the file, when opening and for every batch.
pub fn read_batches(path: &Path) -> Result<Batches, ParquetFileError> {
    read_batches_with(path, Ok)
}

/// [`read_batches`] with the reader builder set up by `configure` first (batch size,
/// projection, row groups); `configure` runs guarded too.
pub fn read_batches_with(
    path: &Path,
    configure: impl FnOnce(
        ParquetRecordBatchReaderBuilder<File>,
    ) -> Result<
        ParquetRecordBatchReaderBuilder<File>,
        parquet::errors::ParquetError,
    >,
) -> Result<Batches, ParquetFileError> {
    let file =
        File::open(path).map_err(|source| ParquetFileError::Io(FileError::new(path, source)))?;
    let inner = crate::escape::catch_quietly(|| {
        ParquetRecordBatchReaderBuilder::try_new(file)
            .and_then(configure)
            .and_then(|b| b.build())
    })
    .map_err(|what| {
        ParquetFileError::format(
            path,
            format!("the Parquet reader failed (damaged embedded Arrow schema?): {what}"),
        )
    })?
    .map_err(|e| ParquetFileError::format(path, e))?;
    let found = arrow::array::RecordBatchReader::schema(&inner);
    let schema = Arc::new(Schema::new_with_metadata(
        found
            .fields()
            .iter()
            .map(|f| normal_field(f))
            .collect::<Vec<_>>(),
        found.metadata().clone(),
    ));
    Ok(Batches { inner, schema })
}

/// The record batches of a Parquet file ([`read_batches`]), with their columns normalised to
/// the types minos writes; an iterator of `Result<RecordBatch, ArrowError>`.
#[derive(Debug)]
pub struct Batches {
    inner: ParquetRecordBatchReader,
    /// The schema every batch is given.
    schema: SchemaRef,
}

impl Batches {
    /// Also converts the columns that `expected` names to the types it gives them where the
    /// file's type is a known variant of it: a `list` where a `fixed_size_list` is expected
    /// (pandas and duckdb do not keep fixed sizes; a list of another length is an error), an
    /// all-null column (pyarrow's type for empty lists), another integer width or signedness
    /// (pandas' `int64` for a column a user assigned; a value out of range is an error), and
    /// `float64` for `float32`. Other columns are left as they are, for the caller to refuse.
    pub fn conform_to(mut self, expected: &Schema) -> Self {
        let fields: Vec<Field> = self
            .schema
            .fields()
            .iter()
            .map(|f| match expected.field_with_name(f.name()) {
                Ok(want)
                    if f.data_type() != want.data_type()
                        && castable(f.data_type(), want.data_type()) =>
                {
                    f.as_ref().clone().with_data_type(want.data_type().clone())
                }
                _ => f.as_ref().clone(),
            })
            .collect();
        self.schema = Arc::new(Schema::new_with_metadata(
            fields,
            self.schema.metadata().clone(),
        ));
        self
    }

    fn normalise(&self, batch: RecordBatch) -> Result<RecordBatch, arrow::error::ArrowError> {
        if batch.schema().fields() == self.schema.fields() {
            return Ok(batch);
        }
        let options = arrow::compute::CastOptions {
            safe: false,
            ..Default::default()
        };
        let columns = batch
            .columns()
            .iter()
            .zip(self.schema.fields())
            .map(|(c, f)| {
                if c.data_type() == f.data_type() {
                    Ok(c.clone())
                } else {
                    arrow::compute::cast_with_options(c, f.data_type(), &options).map_err(|e| {
                        arrow::error::ArrowError::CastError(format!("column `{}`: {e}", f.name()))
                    })
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        RecordBatch::try_new(self.schema.clone(), columns)
    }
}

impl Iterator for Batches {
    type Item = Result<RecordBatch, arrow::error::ArrowError>;

    fn next(&mut self) -> Option<Self::Item> {
        let next = crate::escape::catch_quietly(|| self.inner.next()).unwrap_or_else(|what| {
            Some(Err(arrow::error::ArrowError::ParquetError(format!(
                "the Parquet reader failed: {what}"
            ))))
        })?;
        Some(next.and_then(|b| self.normalise(b)))
    }
}

impl arrow::array::RecordBatchReader for Batches {
    fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }
}

/// The type minos writes for values of type `t`: the string, binary and list variants other
/// writers use (large, view and dictionary-encoded) become `utf8`, `binary` and `list`, inside
/// lists and structs too; every other type is kept.
pub fn normal_type(t: &DataType) -> DataType {
    match t {
        DataType::LargeUtf8 | DataType::Utf8View => DataType::Utf8,
        DataType::LargeBinary | DataType::BinaryView => DataType::Binary,
        DataType::Dictionary(_, values) => normal_type(values),
        DataType::List(f)
        | DataType::LargeList(f)
        | DataType::ListView(f)
        | DataType::LargeListView(f) => DataType::List(Arc::new(normal_field(f))),
        DataType::FixedSizeList(f, n) => DataType::FixedSizeList(Arc::new(normal_field(f)), *n),
        DataType::Struct(fields) => {
            DataType::Struct(fields.iter().map(|f| normal_field(f)).collect())
        }
        other => other.clone(),
    }
}

fn normal_field(f: &Field) -> Field {
    f.clone().with_data_type(normal_type(f.data_type()))
}

/// Whether values of (normalised) type `from` convert to `to` as [`Batches::conform_to`] does.
fn castable(from: &DataType, to: &DataType) -> bool {
    use DataType as D;
    match (from, to) {
        _ if from == to => true,
        (D::Null, _) => true,
        (D::List(a), D::List(b) | D::FixedSizeList(b, _))
        | (D::FixedSizeList(a, _), D::List(b)) => castable(a.data_type(), b.data_type()),
        (D::FixedSizeList(a, n), D::FixedSizeList(b, m)) => {
            n == m && castable(a.data_type(), b.data_type())
        }
        (D::Float64, D::Float32) => true,
        _ => from.is_integer() && to.is_integer(),
    }
}

/// Column `name` of `batch` as the array type `T`; the error says which column and why.
pub fn column<'a, T: Array + 'static>(
    batch: &'a RecordBatch,
    name: &str,
) -> Result<&'a T, Invalid> {
    batch
        .column_by_name(name)
        .ok_or_else(|| Invalid::new(format!("column `{name}` is missing")))?
        .as_any()
        .downcast_ref::<T>()
        .ok_or_else(|| {
            let found = batch
                .column_by_name(name)
                .map(|c| c.data_type().to_string())
                .unwrap_or_default();
            Invalid::new(format!("column `{name}` has an unexpected type ({found})"))
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use arrow::array::{BinaryArray, ListArray, StringArray, UInt32Array};

    #[test]
    fn format_errors_escape_control_characters() {
        let e = ParquetFileError::format(Path::new("t.parquet"), "field `a\nb\u{1}c` é");
        assert_eq!(
            crate::escape::error_line(&e),
            "t.parquet: field `a\\nb\\u{1}c` é"
        );
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
            "column `id` has an unexpected type (Utf8)".into()
        );
        assert_eq!(
            column::<UInt32Array>(&back[0], "m").unwrap_err(),
            "column `m` is missing".into()
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
        let junk_err = read_batches(&junk).unwrap_err();
        assert!(junk_err.to_string().contains("junk.parquet"));
        // The Parquet reader's own error is kept as the cause, printed once by error_line.
        let ParquetFileError::Format {
            cause: FormatCause::Parquet(cause),
            ..
        } = &junk_err
        else {
            panic!("{junk_err:?}")
        };
        let source = std::error::Error::source(&junk_err)
            .expect("a cause")
            .to_string();
        assert_eq!(source, cause.to_string());
        let line = crate::escape::error_line(&junk_err);
        assert_eq!(line.matches(&source).count(), 1, "{line}");
        // A batch that fails midway: no file, no temporary file.
        let (schema, batch) = table();
        let out = dir.path().join("out.parquet");
        let props = writer_properties(1, None, &schema);
        let bad = Err(arrow::error::ArrowError::ComputeError("boom".into()));
        let err = write_batches(&out, schema, props, [Ok(batch), bad]).unwrap_err();
        assert!(crate::escape::error_line(&err).contains("boom"), "{err}");
        assert!(
            matches!(
                &err,
                ParquetFileError::Format {
                    cause: FormatCause::Arrow(_),
                    ..
                }
            ),
            "{err:?}"
        );
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["junk.parquet"], "{names:?}");
    }

    #[test]
    fn other_writers_compressions_and_type_variants_read_as_minos_types() {
        use arrow::array::{
            DictionaryArray, LargeBinaryArray, LargeListArray, LargeStringArray, StringViewArray,
            UInt64Array,
        };
        use arrow::datatypes::Int32Type;
        use parquet::basic::{BrotliLevel, GzipLevel};
        let dir = tempfile::tempdir().unwrap();
        let schema = Arc::new(Schema::new(vec![
            Field::new("large", DataType::LargeUtf8, false),
            Field::new("view", DataType::Utf8View, true),
            Field::new(
                "dict",
                DataType::Dictionary(Box::new(DataType::Int32), Box::new(DataType::Utf8)),
                false,
            ),
            Field::new("blob", DataType::LargeBinary, false),
            Field::new("blobs", DataType::BinaryView, false),
            Field::new(
                "ids",
                DataType::LargeList(Arc::new(Field::new("element", DataType::LargeUtf8, true))),
                false,
            ),
            Field::new("n", DataType::Int64, false),
        ]));
        let ids = LargeListArray::new(
            Arc::new(Field::new("element", DataType::LargeUtf8, true)),
            arrow::buffer::OffsetBuffer::from_lengths([2, 0]),
            Arc::new(LargeStringArray::from(vec![Some("p"), None])),
            None,
        );
        let columns: Vec<arrow::array::ArrayRef> = vec![
            Arc::new(LargeStringArray::from(vec!["a", "bc"])),
            Arc::new(StringViewArray::from(vec![
                Some("a long string over twelve bytes"),
                None,
            ])),
            Arc::new(
                vec!["x", "x"]
                    .into_iter()
                    .collect::<DictionaryArray<Int32Type>>(),
            ),
            Arc::new(LargeBinaryArray::from(vec![&b"xy"[..], &b""[..]])),
            Arc::new(arrow::array::BinaryViewArray::from(vec![
                &b"z"[..],
                &b"w"[..],
            ])),
            Arc::new(ids),
            Arc::new(arrow::array::Int64Array::from(vec![7, 5_000_000_000])),
        ];
        let batch = RecordBatch::try_new(schema.clone(), columns).unwrap();
        let compressions = [
            Compression::UNCOMPRESSED,
            Compression::SNAPPY,
            Compression::GZIP(GzipLevel::default()),
            Compression::LZ4,
            Compression::LZ4_RAW,
            Compression::BROTLI(BrotliLevel::default()),
            Compression::ZSTD(ZstdLevel::default()),
        ];
        for (i, compression) in compressions.into_iter().enumerate() {
            let path = dir.path().join(format!("{i}.parquet"));
            let props = WriterProperties::builder()
                .set_compression(compression)
                .build();
            write_batches(&path, schema.clone(), props, [Ok(batch.clone())]).unwrap();
            let reader = read_batches(&path).unwrap();
            let normal = arrow::array::RecordBatchReader::schema(&reader);
            let back: Vec<RecordBatch> = reader.map(|b| b.unwrap()).collect();
            assert_eq!(back[0].schema(), normal, "{compression:?}");
            let s = |name| column::<StringArray>(&back[0], name).unwrap();
            assert_eq!((s("large").value(1), s("dict").value(0)), ("bc", "x"));
            assert_eq!(s("view").value(0), "a long string over twelve bytes");
            assert!(s("view").is_null(1));
            let b = |name| column::<BinaryArray>(&back[0], name).unwrap();
            assert_eq!(
                (b("blob").value(0), b("blobs").value(1)),
                (&b"xy"[..], &b"w"[..])
            );
            let ids = column::<ListArray>(&back[0], "ids").unwrap();
            let values = ids.values().as_any().downcast_ref::<StringArray>().unwrap();
            assert_eq!((ids.value_length(0), values.value(0)), (2, "p"));
            assert!(values.is_null(1) && ids.value_length(1) == 0);
            // Integers are kept unless a schema to conform to says otherwise.
            assert!(column::<arrow::array::Int64Array>(&back[0], "n").is_ok());
        }
        // Conforming: int64 to the expected uint32, with a value out of range an error
        // naming the column; a fixed-size list from a plain list of the right length.
        let want = Schema::new(vec![Field::new("n", DataType::UInt32, false)]);
        let path = dir.path().join("0.parquet");
        let err = read_batches(&path)
            .unwrap()
            .conform_to(&want)
            .next()
            .unwrap()
            .unwrap_err();
        assert!(err.to_string().contains("column `n`"), "{err}");
        let want = Schema::new(vec![Field::new("n", DataType::UInt64, false)]);
        let back = read_batches(&path)
            .unwrap()
            .conform_to(&want)
            .next()
            .unwrap()
            .unwrap();
        assert_eq!(
            column::<UInt64Array>(&back, "n").unwrap().value(1),
            5_000_000_000
        );
        let want = Schema::new(vec![Field::new("large", DataType::Float32, false)]);
        let back = read_batches(&path)
            .unwrap()
            .conform_to(&want)
            .next()
            .unwrap()
            .unwrap();
        assert!(
            column::<StringArray>(&back, "large").is_ok(),
            "strings never become numbers"
        );
    }

    #[test]
    fn plain_lists_conform_to_fixed_size_lists_of_the_same_length_only() {
        let dir = tempfile::tempdir().unwrap();
        let point = Arc::new(Field::new("item", DataType::Float32, true));
        let want = Schema::new(vec![Field::new(
            "p",
            DataType::List(Arc::new(Field::new(
                "item",
                DataType::FixedSizeList(point.clone(), 3),
                true,
            ))),
            false,
        )]);
        let write = |lengths: [usize; 2]| {
            let inner = ListArray::new(
                Arc::new(Field::new("element", DataType::Float32, true)),
                arrow::buffer::OffsetBuffer::from_lengths(lengths),
                Arc::new(arrow::array::Float32Array::from(vec![1.0; 6])),
                None,
            );
            let outer = ListArray::new(
                Arc::new(Field::new("element", inner.data_type().clone(), true)),
                arrow::buffer::OffsetBuffer::from_lengths([2]),
                Arc::new(inner),
                None,
            );
            let schema = Arc::new(Schema::new(vec![Field::new(
                "p",
                outer.data_type().clone(),
                false,
            )]));
            let batch = RecordBatch::try_new(schema.clone(), vec![Arc::new(outer)]).unwrap();
            let path = dir.path().join(format!("{lengths:?}.parquet"));
            write_batches(&path, schema, WriterProperties::default(), [Ok(batch)]).unwrap();
            read_batches(&path)
                .unwrap()
                .conform_to(&want)
                .next()
                .unwrap()
        };
        let back = write([3, 3]).unwrap();
        assert_eq!(
            back.schema().field(0).data_type(),
            want.field(0).data_type()
        );
        let err = write([2, 4]).unwrap_err().to_string();
        assert!(err.contains("column `p`"), "{err}");
    }
}
