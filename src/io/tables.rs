//! The Parquet tables a run writes: trajectories (one row per step), observations (one row
//! per step, one binary column per sensor, streamed in row groups so an episode is never held
//! whole in memory) and episodes with their metrics. Each episode is written to its own part
//! files; `merge` concatenates parts in episode order into the final tables.

use std::collections::HashMap;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow::array::{
    Array, ArrayRef, BinaryBuilder, BooleanArray, BooleanBuilder, Float32Array, Float32Builder,
    ListBuilder, RecordBatch, StringArray, UInt32Array,
};
use arrow::datatypes::{DataType, Field, Schema, SchemaRef};
use parquet::arrow::{add_encoded_arrow_schema_to_metadata, ArrowSchemaConverter, ArrowWriter};
use parquet::column::writer::ColumnCloseResult;
use parquet::file::properties::WriterProperties;
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::file::writer::SerializedFileWriter;

use crate::atomic::temp_path;
use crate::escape::Panicked;
use crate::io::image_codec::ImageEncoding;
use crate::io::image_codec::{encode_cell, CellFormat, CodecError};
use crate::parquet_io::{self, writer_properties, ParquetFileError};
use crate::render::Image;
use crate::run::agents::Decision;
use crate::run::step_features::StepFeatures;
use crate::scene::RoomClass;
use crate::sim::CameraSensor;

/// Observation rows per row group.
pub const ROW_GROUP: usize = 32;

/// A run table that could not be written or read (the message names the file).
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    /// A file of the table failed.
    #[error("{}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: TableCause,
    },
    /// A Parquet file could not be opened, read or written.
    #[error(transparent)]
    Parquet(#[from] ParquetFileError),
}

/// Why a table file failed.
#[derive(Debug, thiserror::Error)]
pub enum TableCause {
    /// File system error.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// Arrow error (building, reading or joining batches).
    #[error(transparent)]
    Arrow(#[from] arrow::error::ArrowError),
    /// Parquet error (writing, or copying row groups).
    #[error(transparent)]
    Parquet(#[from] parquet::errors::ParquetError),
    /// The Parquet reader panicked on the file (a corrupt file; the panic was caught).
    #[error("the Parquet reader failed")]
    Reader(#[from] Panicked),
    /// A camera image could not be encoded into its column.
    #[error("step {step}: sensor `{sensor}`")]
    Encode {
        /// The step.
        step: u32,
        /// The camera.
        sensor: String,
        /// Why.
        #[source]
        source: CodecError,
    },
    /// The file holds something other than the table needs: what.
    #[error("{0}")]
    Content(String),
}

/// `cause` as the error of table file `path`.
fn file_error(path: &Path, cause: impl Into<TableCause>) -> TableError {
    TableError::File {
        path: path.to_path_buf(),
        source: cause.into(),
    }
}

/// What is wrong with the content of table file `path`.
fn content_error(path: &Path, what: impl ToString) -> TableError {
    file_error(path, TableCause::Content(what.to_string()))
}

/// Writer settings for a table: zstd level 1, row groups of at most `ROW_GROUP * 8` rows;
/// binary (image) columns without dictionary encoding or statistics.
fn props(schema: &Schema) -> WriterProperties {
    writer_properties(1, Some(ROW_GROUP * 8), schema)
}

/// Schema of the trajectory table.
pub fn trajectory_schema() -> SchemaRef {
    let f32_list = DataType::List(Arc::new(Field::new("item", DataType::Float32, true)));
    let bool_list = DataType::List(Arc::new(Field::new("item", DataType::Boolean, true)));
    Arc::new(Schema::new(vec![
        Field::new("episode_id", DataType::Utf8, false),
        Field::new("step", DataType::UInt32, false),
        Field::new("x", DataType::Float32, false),
        Field::new("y", DataType::Float32, false),
        Field::new("z", DataType::Float32, false),
        Field::new("yaw", DataType::Float32, false),
        Field::new("tilt", DataType::Float32, false),
        Field::new("action", DataType::Utf8, false),
        Field::new("action_strengths", f32_list, false),
        Field::new("reward", DataType::Float32, false),
        Field::new("collision", DataType::Boolean, false),
        Field::new("contacts", bool_list, false),
        Field::new("euclidean_distance", DataType::Float32, true),
        Field::new("geodesic_distance", DataType::Float32, true),
        Field::new("done", DataType::Boolean, false),
        Field::new("success", DataType::Boolean, false),
        Field::new("goal_right", DataType::Float32, true),
        Field::new("goal_forward", DataType::Float32, true),
        Field::new("goal_room", DataType::Utf8, true),
        Field::new("goal_object", DataType::Utf8, true),
        Field::new("at_goal", DataType::Boolean, false),
        Field::new("previous_action", DataType::Utf8, true),
        Field::new("previous_collision", DataType::Boolean, false),
        Field::new("steps_left", DataType::UInt32, false),
    ]))
}

/// One trajectory row.
#[derive(Debug, Clone, PartialEq)]
pub struct StepRow {
    /// Step index.
    pub step: u32,
    /// Pose before the action: x, y, z, yaw, tilt.
    pub pose: [f32; 5],
    /// Action name.
    pub action: String,
    /// Action strengths.
    pub strengths: [f32; 8],
    /// Reward received.
    pub reward: f32,
    /// The action's motion collided.
    pub collision: bool,
    /// What the agent was given with the observation before the action (goal measurements,
    /// contacts, the previous step's collision and action, steps left): the columns
    /// `contacts`, `euclidean_distance`, `geodesic_distance`, `goal_*`, `at_goal`,
    /// `previous_*` and `steps_left`.
    pub seen: StepFeatures,
    /// The episode ended after this action.
    pub done: bool,
    /// The episode succeeded (set on its last row).
    pub success: bool,
}

/// Writes an episode's trajectory rows.
pub fn write_trajectory(path: &Path, episode: &str, rows: &[StepRow]) -> Result<(), TableError> {
    let n = rows.len();
    let f = |g: &dyn Fn(&StepRow) -> f32| -> ArrayRef {
        Arc::new(rows.iter().map(g).collect::<Float32Array>())
    };
    let mut strengths = ListBuilder::new(Float32Builder::new());
    let mut contacts = ListBuilder::new(BooleanBuilder::new());
    for r in rows {
        strengths.values().append_slice(&r.strengths);
        strengths.append(true);
        for c in &r.seen.contacts {
            contacts.values().append_value(*c);
        }
        contacts.append(true);
    }
    let columns: Vec<ArrayRef> = vec![
        Arc::new(StringArray::from_iter_values(std::iter::repeat_n(
            episode, n,
        ))),
        Arc::new(rows.iter().map(|r| r.step).collect::<UInt32Array>()),
        f(&|r| r.pose[0]),
        f(&|r| r.pose[1]),
        f(&|r| r.pose[2]),
        f(&|r| r.pose[3]),
        f(&|r| r.pose[4]),
        Arc::new(StringArray::from_iter_values(
            rows.iter().map(|r| r.action.as_str()),
        )),
        Arc::new(strengths.finish()),
        f(&|r| r.reward),
        Arc::new(
            rows.iter()
                .map(|r| Some(r.collision))
                .collect::<BooleanArray>(),
        ),
        Arc::new(contacts.finish()),
        Arc::new(
            rows.iter()
                .map(|r| r.seen.euclidean)
                .collect::<Float32Array>(),
        ),
        Arc::new(
            rows.iter()
                .map(|r| r.seen.geodesic)
                .collect::<Float32Array>(),
        ),
        Arc::new(rows.iter().map(|r| Some(r.done)).collect::<BooleanArray>()),
        Arc::new(
            rows.iter()
                .map(|r| Some(r.success))
                .collect::<BooleanArray>(),
        ),
        Arc::new(
            rows.iter()
                .map(|r| r.seen.euclidean.map(|_| r.seen.goal[1]))
                .collect::<Float32Array>(),
        ),
        Arc::new(
            rows.iter()
                .map(|r| r.seen.euclidean.map(|_| r.seen.goal[2]))
                .collect::<Float32Array>(),
        ),
        Arc::new(
            rows.iter()
                .map(|r| r.seen.goal_room.map(RoomClass::name))
                .collect::<StringArray>(),
        ),
        Arc::new(
            rows.iter()
                .map(|r| r.seen.goal_object.as_deref())
                .collect::<StringArray>(),
        ),
        Arc::new(
            rows.iter()
                .map(|r| Some(r.seen.at_goal))
                .collect::<BooleanArray>(),
        ),
        Arc::new(
            rows.iter()
                .map(|r| r.seen.previous_action.map(|d| d.name()))
                .collect::<StringArray>(),
        ),
        Arc::new(
            rows.iter()
                .map(|r| Some(r.seen.collision))
                .collect::<BooleanArray>(),
        ),
        Arc::new(
            rows.iter()
                .map(|r| r.seen.steps_left)
                .collect::<UInt32Array>(),
        ),
    ];
    let batch =
        RecordBatch::try_new(trajectory_schema(), columns).map_err(|e| file_error(path, e))?;
    write_batches(path, trajectory_schema(), std::iter::once(batch))
}

fn write_batches(
    path: &Path,
    schema: SchemaRef,
    batches: impl Iterator<Item = RecordBatch>,
) -> Result<(), TableError> {
    let props = props(&schema);
    parquet_io::write_batches(path, schema, props, batches.map(Ok)).map_err(TableError::from)
}

/// Schema of the observation table for a sensor suite: each camera's column metadata is its
/// [`CellFormat::metadata`], plus `depth_range` and `unit` for quantised depth.
pub fn observation_schema(cameras: &[CameraSensor], encoding: ImageEncoding) -> SchemaRef {
    let mut fields = vec![
        Field::new("episode_id", DataType::Utf8, false),
        Field::new("step", DataType::UInt32, false),
    ];
    for c in cameras {
        let mut meta = CellFormat::for_camera(c, encoding).metadata(c.modality);
        if let Some(unit) = quantised_depth_unit(c) {
            meta.insert("depth_range".into(), format!("{:?}", c.depth_range));
            meta.insert("unit".into(), unit);
        }
        fields.push(Field::new(&c.name, DataType::Binary, false).with_metadata(meta));
    }
    Arc::new(Schema::new(fields))
}

/// How a quantised depth sensor's values map to metres (`None` for other sensors).
fn quantised_depth_unit(c: &CameraSensor) -> Option<String> {
    use crate::sim::DepthEncoding;
    let max = match (c.modality, c.depth_encoding) {
        (crate::render::Modality::Depth, DepthEncoding::U8) => 255,
        (crate::render::Modality::Depth, DepthEncoding::U16) => 65535,
        _ => return None,
    };
    let [lo, hi] = c.depth_range;
    Some(format!(
        "m = {lo} + value / {max} × {} (0 = no return; clipped to depth_range)",
        hi - lo
    ))
}

/// Streams one episode's observations into a part file, a row group at a time: compressed
/// and written on the calling thread, or, after [`ObservationWriter::write_behind`], on a
/// thread of its own (the same bytes either way).
pub struct ObservationWriter {
    path: std::path::PathBuf,
    tmp: std::path::PathBuf,
    sink: Sink,
    schema: SchemaRef,
    /// How each camera's images are stored, in camera order.
    formats: Vec<CellFormat>,
    cameras: Vec<CameraSensor>,
    episode: String,
    /// Steps of the pending rows.
    steps: Vec<u32>,
    /// Pending images, one builder per camera.
    pending: Vec<BinaryBuilder>,
    /// Reused buffer for one image's bytes.
    buf: Vec<u8>,
}

/// Where an [`ObservationWriter`]'s row groups are compressed and written.
enum Sink {
    /// On the thread that pushes the observations.
    Here(Box<ArrowWriter<File>>),
    /// On a thread of its own, fed one row group at a time; it hands the writer back (or
    /// the first error) when the feed ends.
    Behind {
        feed: std::sync::mpsc::SyncSender<RecordBatch>,
        thread: std::thread::JoinHandle<Result<Box<ArrowWriter<File>>, TableError>>,
    },
    /// Between the two, or after the writing thread failed (its error was returned).
    Gone,
}

/// Row groups a writing thread may have waiting before [`ObservationWriter::push`] waits for
/// it: one being written, one queued.
const BEHIND: usize = 1;

/// What a writer says when written to after one of its writes failed (it wrote nothing
/// since).
const AFTER_A_FAILED_WRITE: &str = "written after a failed write";

impl ObservationWriter {
    /// Starts the part file of `episode`.
    pub fn create(
        path: &Path,
        episode: &str,
        cameras: &[CameraSensor],
        encoding: ImageEncoding,
    ) -> Result<Self, TableError> {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| file_error(path, e))?;
        }
        let tmp = temp_path(path);
        let file = File::create(&tmp).map_err(|e| file_error(path, e))?;
        Self::over(file, path, tmp, episode, cameras, encoding)
    }

    /// The writer of `episode`'s part file `path`, writing into `file`, opened at `tmp`.
    fn over(
        file: File,
        path: &Path,
        tmp: PathBuf,
        episode: &str,
        cameras: &[CameraSensor],
        encoding: ImageEncoding,
    ) -> Result<Self, TableError> {
        let schema = observation_schema(cameras, encoding);
        let writer = ArrowWriter::try_new(file, schema.clone(), Some(props(&schema)))
            .map_err(|e| file_error(path, e))?;
        Ok(ObservationWriter {
            path: path.to_path_buf(),
            tmp,
            sink: Sink::Here(Box::new(writer)),
            schema,
            formats: cameras
                .iter()
                .map(|c| CellFormat::for_camera(c, encoding))
                .collect(),
            cameras: cameras.to_vec(),
            episode: episode.to_string(),
            steps: Vec::with_capacity(ROW_GROUP),
            pending: cameras.iter().map(|_| BinaryBuilder::new()).collect(),
            buf: Vec::new(),
        })
    }

    /// Adds the images of one step.
    pub fn push(&mut self, step: u32, images: &[(String, Image)]) -> Result<(), TableError> {
        for ((((_, img), cam), format), b) in images
            .iter()
            .zip(&self.cameras)
            .zip(&self.formats)
            .zip(&mut self.pending)
        {
            self.buf.clear();
            encode_cell(img, format, &mut self.buf).map_err(|source| {
                file_error(
                    &self.path,
                    TableCause::Encode {
                        step,
                        sensor: cam.name.clone(),
                        source,
                    },
                )
            })?;
            b.append_value(&self.buf);
        }
        self.steps.push(step);
        if self.steps.len() >= ROW_GROUP {
            self.flush()?;
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), TableError> {
        if self.steps.is_empty() {
            return Ok(());
        }
        let n = self.steps.len();
        let mut columns: Vec<ArrayRef> = vec![
            Arc::new(StringArray::from_iter_values(std::iter::repeat_n(
                self.episode.as_str(),
                n,
            ))),
            Arc::new(UInt32Array::from(std::mem::take(&mut self.steps))),
        ];
        for b in &mut self.pending {
            columns.push(Arc::new(b.finish()));
        }
        let batch = RecordBatch::try_new(self.schema.clone(), columns)
            .map_err(|e| file_error(&self.path, e))?;
        match &mut self.sink {
            Sink::Here(writer) => write_row_group(writer, &batch, &self.path),
            Sink::Behind { feed, .. } => match feed.send(batch) {
                Ok(()) => Ok(()),
                // The writing thread stopped: it failed, and its error says why.
                Err(_) => match self.take_writer() {
                    Err(e) => Err(e),
                    Ok(_) => Err(content_error(&self.path, "the writing thread stopped")),
                },
            },
            Sink::Gone => Err(content_error(&self.path, AFTER_A_FAILED_WRITE)),
        }
    }

    /// From now on, compresses and writes the row groups on a thread of its own, so that
    /// [`ObservationWriter::push`] returns without waiting for them (unless a row group is
    /// still waiting to be written when the next is full). For a run whose agent waits on
    /// someone else (a person, another process), whose wait the writes then overlap. The
    /// thread runs at a lower priority where the platform allows, so rendering the next
    /// frame goes first. Bytes written are the same.
    pub fn write_behind(&mut self) -> Result<(), TableError> {
        let Sink::Here(mut writer) = std::mem::replace(&mut self.sink, Sink::Gone) else {
            return Ok(());
        };
        let (feed, row_groups) = std::sync::mpsc::sync_channel::<RecordBatch>(BEHIND);
        let path = self.path.clone();
        let thread = std::thread::Builder::new()
            .name("minos-obs-writer".into())
            .spawn(move || {
                lower_this_threads_priority();
                for batch in row_groups {
                    write_row_group(&mut writer, &batch, &path)?;
                }
                Ok(writer)
            })
            .map_err(|e| file_error(&self.path, e))?;
        self.sink = Sink::Behind { feed, thread };
        Ok(())
    }

    /// The Parquet writer back from wherever it writes (waiting for a writing thread to
    /// write what it was given); the writing thread's error if it failed.
    fn take_writer(&mut self) -> Result<Box<ArrowWriter<File>>, TableError> {
        match std::mem::replace(&mut self.sink, Sink::Gone) {
            Sink::Here(writer) => Ok(writer),
            Sink::Behind { feed, thread } => {
                drop(feed);
                thread.join().unwrap_or_else(|_| {
                    Err(content_error(&self.path, "the thread writing it panicked"))
                })
            }
            Sink::Gone => Err(content_error(&self.path, AFTER_A_FAILED_WRITE)),
        }
    }

    /// Finishes the part file (renamed into place).
    pub fn finish(mut self) -> Result<(), TableError> {
        self.flush()?;
        let writer = self.take_writer()?;
        let path = self.path.clone();
        writer.close().map_err(|e| file_error(&path, e))?;
        crate::atomic::rename_durably(&self.tmp, &path).map_err(|e| file_error(&path, e))
    }
}

/// Lowers the calling thread's scheduling priority (nice 10) on Linux, where a thread has
/// its own; elsewhere, and where it is not allowed, nothing.
fn lower_this_threads_priority() {
    #[cfg(target_os = "linux")]
    if let Err(e) = rustix::process::setpriority_process(None, 10) {
        tracing::debug!("could not lower a writing thread's priority: {e}");
    }
}

/// Writes `batch` to `writer` as a row group of its own (compressed now) and flushes it.
fn write_row_group(
    writer: &mut ArrowWriter<File>,
    batch: &RecordBatch,
    path: &Path,
) -> Result<(), TableError> {
    writer.write(batch).map_err(|e| file_error(path, e))?;
    writer.flush().map_err(|e| file_error(path, e))
}

/// Concatenates part files (in the order given) into `out`. Tables with binary (image)
/// columns have their row groups copied as they are (compressed column chunks, no decoding:
/// re-encoding images would cost as much as writing them); small tables are re-batched into
/// row groups of up to `ROW_GROUP * 8` rows.
pub fn merge(
    parts: &[std::path::PathBuf],
    schema: SchemaRef,
    out: &Path,
) -> Result<(), TableError> {
    if schema
        .fields()
        .iter()
        .any(|f| f.data_type() == &DataType::Binary)
    {
        copy_row_groups(parts, schema, out)
    } else {
        rebatch(parts, schema, out)
    }
}

/// [`merge`] batch by batch (decoding and re-encoding).
fn rebatch(parts: &[std::path::PathBuf], schema: SchemaRef, out: &Path) -> Result<(), TableError> {
    let mut readers = Vec::new();
    for p in parts {
        let r = parquet_io::read_batches_with(p, |b| Ok(b.with_batch_size(ROW_GROUP)))?
            .conform_to(&schema);
        readers.push(r);
    }
    let mut failure = None;
    let batches = readers.into_iter().flatten().map_while(|b| match b {
        Ok(b) => Some(b),
        Err(e) => {
            failure = Some(e);
            None
        }
    });
    let result = write_batches(out, schema, batches);
    match failure {
        Some(e) => Err(file_error(out, e)),
        None => result,
    }
}

/// [`merge`] by copying the parts' compressed row groups, under `schema`'s Arrow metadata.
fn copy_row_groups(
    parts: &[std::path::PathBuf],
    schema: SchemaRef,
    out: &Path,
) -> Result<(), TableError> {
    let mut groups = Vec::new();
    for p in parts {
        let n = row_group_count(p)?;
        groups.extend((0..n).map(|g| (p.as_path(), g)));
    }
    copy_row_groups_from(&groups, schema, out)
}

/// How many row groups the Parquet file `path` has.
pub fn row_group_count(path: &Path) -> Result<usize, TableError> {
    let f = File::open(path).map_err(|e| file_error(path, e))?;
    let reader = crate::escape::catch_quietly(|| SerializedFileReader::new(f))
        .map_err(|e| file_error(path, e))?
        .map_err(|e| file_error(path, e))?;
    Ok(reader.metadata().num_row_groups())
}

/// Writes `out` (atomically) from row groups of other files, `(file, row group index)` in
/// the order given, copied as they are (compressed column chunks, no decoding), under
/// `schema`'s Arrow metadata. Every file must have the table's schema.
pub fn copy_row_groups_from(
    groups: &[(&Path, usize)],
    schema: SchemaRef,
    out: &Path,
) -> Result<(), TableError> {
    let tmp = temp_path(out);
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir).map_err(|e| file_error(out, e))?;
    }
    let mut props = props(&schema);
    add_encoded_arrow_schema_to_metadata(&schema, &mut props);
    let descr = ArrowSchemaConverter::new()
        .convert(&schema)
        .map_err(|e| file_error(out, e))?;
    let file = File::create(&tmp).map_err(|e| file_error(out, e))?;
    let result = (|| {
        let mut w = SerializedFileWriter::new(file, descr.root_schema_ptr(), Arc::new(props))
            .map_err(|e| file_error(out, e))?;
        let mut open: HashMap<&Path, (File, SerializedFileReader<File>)> = HashMap::new();
        for &(p, g) in groups {
            if !open.contains_key(p) {
                let f = File::open(p).map_err(|e| file_error(p, e))?;
                let copy = f.try_clone().map_err(|e| file_error(p, e))?;
                let reader = crate::escape::catch_quietly(|| SerializedFileReader::new(copy))
                    .map_err(|e| file_error(p, e))?
                    .map_err(|e| file_error(p, e))?;
                if reader
                    .metadata()
                    .file_metadata()
                    .schema_descr()
                    .root_schema()
                    != descr.root_schema()
                {
                    return Err(content_error(p, "schema differs from the table's"));
                }
                open.insert(p, (f, reader));
            }
            let (f, reader) = &open[p];
            let meta = reader.metadata();
            let rg = meta
                .row_groups()
                .get(g)
                .ok_or_else(|| content_error(p, format!("no row group {g}")))?;
            let mut group = w.next_row_group().map_err(|e| file_error(out, e))?;
            for col in rg.columns() {
                let chunk = ColumnCloseResult {
                    bytes_written: col.compressed_size().max(0) as u64,
                    rows_written: rg.num_rows().max(0) as u64,
                    metadata: col.clone(),
                    bloom_filter: None,
                    column_index: None,
                    offset_index: None,
                };
                group
                    .append_column(f, chunk)
                    .map_err(|e| file_error(p, e))?;
            }
            group.close().map_err(|e| file_error(out, e))?;
        }
        w.close().map_err(|e| file_error(out, e))?;
        crate::atomic::rename_durably(&tmp, out).map_err(|e| file_error(out, e))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// The `episode_id` of each row group of a run table (`observations.parquet`,
/// `trajectories.parquet`), in file order; a row group holding rows of two episodes is an
/// error (a run writes every episode's rows into row groups of their own).
pub fn row_group_episodes(path: &Path) -> Result<Vec<String>, TableError> {
    let mut shape = None;
    parquet_io::read_batches_with(path, |b| {
        let column = b
            .schema()
            .index_of("episode_id")
            .map_err(|_| parquet::errors::ParquetError::General("no episode_id column".into()))?;
        let mask = parquet::arrow::ProjectionMask::roots(b.parquet_schema(), [column]);
        shape = Some((b.metadata().num_row_groups(), mask));
        Ok(b.with_row_groups(vec![]))
    })?;
    let (groups, mask) = shape.ok_or_else(|| content_error(path, "no row groups"))?;
    let mut ids = Vec::with_capacity(groups);
    for g in 0..groups {
        let batches = parquet_io::read_batches_with(path, |b| {
            Ok(b.with_projection(mask.clone()).with_row_groups(vec![g]))
        })?;
        let mut id: Option<String> = None;
        for batch in batches {
            let batch = batch.map_err(|e| file_error(path, e))?;
            let col = batch
                .column(0)
                .as_any()
                .downcast_ref::<StringArray>()
                .ok_or_else(|| content_error(path, "episode_id is not a string column"))?;
            for v in col.iter() {
                let v = v.ok_or_else(|| {
                    content_error(path, format!("row group {g}: episode_id is null"))
                })?;
                match &id {
                    None => id = Some(v.to_string()),
                    Some(known) if known != v => {
                        return Err(content_error(
                            path,
                            format!("row group {g} holds rows of episodes `{known}` and `{v}`"),
                        ))
                    }
                    Some(_) => {}
                }
            }
        }
        ids.push(id.ok_or_else(|| content_error(path, format!("row group {g} is empty")))?);
    }
    Ok(ids)
}

/// Reads a whole run table into one batch (the small tables: trajectories, episodes).
pub fn read_table(path: &Path) -> Result<RecordBatch, TableError> {
    let reader = parquet_io::read_batches(path)?;
    let schema = arrow::array::RecordBatchReader::schema(&reader);
    let batches: Vec<RecordBatch> = reader
        .collect::<Result<_, _>>()
        .map_err(|e| file_error(path, e))?;
    arrow::compute::concat_batches(&schema, &batches).map_err(|e| file_error(path, e))
}

/// Writes a trajectory table from episodes' rows, each piece one episode's rows in step
/// order, re-batched exactly as [`merge`] re-batches episode part files: the same rows in
/// the same order give the same bytes whichever files they came from.
pub fn write_trajectory_pieces(
    out: &Path,
    pieces: impl IntoIterator<Item = RecordBatch>,
) -> Result<(), TableError> {
    let batches = pieces.into_iter().flat_map(|piece| {
        let rows = piece.num_rows();
        (0..rows)
            .step_by(ROW_GROUP)
            .map(move |at| piece.slice(at, ROW_GROUP.min(rows - at)))
            .collect::<Vec<_>>()
    });
    write_batches(out, trajectory_schema(), batches)
}

/// Writes the episode table: the episodes' own columns that matter for analysis, their
/// metrics, and the task in words (`instruction`).
pub fn write_episode_table(
    path: &Path,
    rows: &[(crate::episode::Episode, crate::run::metrics::EpisodeMetrics)],
) -> Result<(), TableError> {
    let schema = Arc::new(Schema::new(vec![
        Field::new("episode_id", DataType::Utf8, false),
        Field::new("scene_id", DataType::Utf8, false),
        Field::new("task", DataType::Utf8, false),
        Field::new("split", DataType::Utf8, false),
        Field::new("difficulty", DataType::Utf8, false),
        Field::new("geodesic_distance", DataType::Float32, false),
        Field::new("success", DataType::Boolean, false),
        Field::new("spl", DataType::Float32, false),
        Field::new("soft_spl", DataType::Float32, false),
        Field::new("speed", DataType::Float32, false),
        Field::new("path_length", DataType::Float32, false),
        Field::new("steps", DataType::UInt32, false),
        Field::new("collisions", DataType::UInt32, false),
        Field::new("final_geodesic", DataType::Float32, true),
        Field::new("ndtw", DataType::Float32, true),
        Field::new("instruction", DataType::Utf8, false),
    ]));
    let s = |f: &dyn Fn(&crate::episode::Episode) -> String| -> ArrayRef {
        Arc::new(StringArray::from_iter_values(
            rows.iter().map(|(e, _)| f(e)),
        ))
    };
    let m = |f: &dyn Fn(&crate::run::metrics::EpisodeMetrics) -> f32| -> ArrayRef {
        Arc::new(rows.iter().map(|(_, m)| f(m)).collect::<Float32Array>())
    };
    let columns: Vec<ArrayRef> = vec![
        s(&|e| e.episode_id.clone()),
        s(&|e| e.scene_id.clone()),
        s(&|e| e.task.name().to_string()),
        s(&|e| e.split.clone()),
        s(&|e| e.difficulty.name().to_string()),
        Arc::new(
            rows.iter()
                .map(|(e, _)| e.geodesic_distance)
                .collect::<Float32Array>(),
        ),
        Arc::new(
            rows.iter()
                .map(|(_, m)| Some(m.success))
                .collect::<BooleanArray>(),
        ),
        m(&|m| m.spl),
        m(&|m| m.soft_spl),
        m(&|m| m.speed),
        m(&|m| m.path_length),
        Arc::new(rows.iter().map(|(_, m)| m.steps).collect::<UInt32Array>()),
        Arc::new(
            rows.iter()
                .map(|(_, m)| m.collisions)
                .collect::<UInt32Array>(),
        ),
        Arc::new(
            rows.iter()
                .map(|(_, m)| m.final_geodesic.is_finite().then_some(m.final_geodesic))
                .collect::<Float32Array>(),
        ),
        Arc::new(
            rows.iter()
                .map(|(_, m)| m.ndtw.is_finite().then_some(m.ndtw))
                .collect::<Float32Array>(),
        ),
        s(&crate::episode::instruction::instruction),
    ];
    let batch = RecordBatch::try_new(schema, columns).map_err(|e| file_error(path, e))?;
    write_episode_batch(path, batch)
}

/// Writes the episode table from its rows in one batch (as [`write_episode_table`] does):
/// `minos merge` writes the rows of its shards' tables with it.
pub fn write_episode_batch(path: &Path, batch: RecordBatch) -> Result<(), TableError> {
    write_batches(path, batch.schema(), std::iter::once(batch))
}

/// Reads the decisions of every episode of a trajectory table (`trajectories.parquet` of a
/// run), in step order: what `--agent replay:FILE` replays.
pub fn read_replay(path: &Path) -> Result<HashMap<String, Vec<Decision>>, TableError> {
    let fail = |m: String| content_error(path, m);
    let reader = parquet_io::read_batches(path)?;
    let mut rows: HashMap<String, Vec<(u32, Decision)>> = HashMap::new();
    for batch in reader {
        let batch = batch.map_err(|e| file_error(path, e))?;
        let column = |name: &str| {
            batch
                .column_by_name(name)
                .ok_or_else(|| fail(format!("no column `{name}`")))
        };
        let ids = column("episode_id")?
            .as_any()
            .downcast_ref::<StringArray>()
            .ok_or_else(|| fail("episode_id: not text".into()))?;
        let steps = column("step")?
            .as_any()
            .downcast_ref::<UInt32Array>()
            .ok_or_else(|| fail("step: not uint32".into()))?;
        let actions = column("action")?
            .as_any()
            .downcast_ref::<StringArray>()
            .ok_or_else(|| fail("action: not text".into()))?;
        for i in 0..batch.num_rows() {
            if ids.is_null(i) || steps.is_null(i) || actions.is_null(i) {
                return Err(fail(format!("row {i}: a null episode_id, step or action")));
            }
            let d = Decision::from_name(actions.value(i))
                .ok_or_else(|| fail(format!("row {i}: unknown action `{}`", actions.value(i))))?;
            rows.entry(ids.value(i).to_string())
                .or_default()
                .push((steps.value(i), d));
        }
    }
    Ok(rows
        .into_iter()
        .map(|(k, mut v)| {
            v.sort_by_key(|(s, _)| *s);
            (k, v.into_iter().map(|(_, d)| d).collect())
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::DepthEncoding;
    use crate::sim::SensorSuite;

    #[test]
    fn quantised_depth_columns_say_how_values_map_to_metres() {
        let mut suite = SensorSuite::minos(8);
        suite.cameras[1].depth_encoding = DepthEncoding::U16;
        suite.cameras[1].depth_range = [0.0, 10.0];
        let schema = observation_schema(&suite.cameras, ImageEncoding::Raw);
        let depth = schema.field_with_name("depth").expect("depth").metadata();
        assert_eq!(depth["dtype"], "uint16");
        assert_eq!(depth["depth_range"], "[0.0, 10.0]");
        assert!(depth["unit"].contains("/ 65535 × 10"), "{}", depth["unit"]);
        // Float depth is already metres: no mapping to state.
        let plain = observation_schema(&SensorSuite::minos(8).cameras, ImageEncoding::Raw);
        let depth = plain.field_with_name("depth").expect("depth").metadata();
        assert!(!depth.contains_key("unit") && depth["dtype"] == "float32");
        let color = plain.field_with_name("color").expect("color").metadata();
        assert_eq!(color["modality"], "color");
        assert_eq!(color["lossless"], "true");
    }

    /// Step `v`'s images of the MINOS cameras at 8² (different for each step).
    fn observation(v: usize) -> Vec<(String, Image)> {
        vec![
            (
                "color".to_string(),
                Image::U8 {
                    channels: 3,
                    data: (0..8 * 8 * 3).map(|i| (i * 7 + v) as u8).collect(),
                },
            ),
            (
                "depth".to_string(),
                Image::F32 {
                    channels: 1,
                    data: (0..64).map(|i| (i + v) as f32 * 0.01).collect(),
                },
            ),
            (
                "semantic".to_string(),
                Image::U16((0..64).map(|i| (i * v % 40) as u16).collect()),
            ),
        ]
    }

    /// Writes `steps` observations of the MINOS cameras at 8² into `path`, behind (on the
    /// writer's own thread) or not.
    fn write_observations(path: &Path, steps: u32, behind: bool) {
        let cams = SensorSuite::minos(8).cameras;
        let mut w =
            ObservationWriter::create(path, "ep", &cams, ImageEncoding::Raw).expect("create");
        if behind {
            w.write_behind().expect("write behind");
        }
        for t in 0..steps {
            let images = observation(t as usize);
            w.push(t, &images).expect("push");
        }
        w.finish().expect("finish");
    }

    #[test]
    fn observations_written_behind_are_the_same_bytes() {
        let dir = tempfile::tempdir().expect("tempdir");
        let steps = ROW_GROUP as u32 * 3 + 5;
        let (here, behind) = (
            dir.path().join("here.parquet"),
            dir.path().join("behind.parquet"),
        );
        write_observations(&here, steps, false);
        write_observations(&behind, steps, true);
        let (a, b) = (
            std::fs::read(&here).expect("here"),
            std::fs::read(&behind).expect("behind"),
        );
        assert_eq!(a, b, "the writing thread changed the bytes");
        // Four row groups (3 full, one of 5 rows), every step in order.
        assert_eq!(row_group_count(&behind).expect("row groups"), 4);
        let table = read_table(&behind).expect("read");
        let step = table.column_by_name("step").expect("step");
        let step = step.as_any().downcast_ref::<UInt32Array>().expect("u32");
        assert_eq!(step.values().to_vec(), (0..steps).collect::<Vec<_>>());
        // Nothing but the finished file.
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .expect("dir")
            .map(|e| e.expect("entry").file_name())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
    }

    /// A writing thread that fails (a full disk: Linux's `/dev/full`) hands its error to
    /// the next `push` or to `finish`, naming the file; nothing panics or hangs.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_failed_write_behind_is_the_error_of_push_or_finish() {
        let full = std::fs::OpenOptions::new().write(true).open("/dev/full");
        let Ok(full) = full else {
            eprintln!("skipped: no /dev/full to write into");
            return;
        };
        let cams = SensorSuite::minos(8).cameras;
        let path = Path::new("obs.parquet");
        let mut w = ObservationWriter::over(
            full,
            path,
            "obs.tmp".into(),
            "ep",
            &cams,
            ImageEncoding::Raw,
        )
        .expect("writer");
        w.write_behind().expect("write behind");
        let images = observation(1);
        let mut errors = Vec::new();
        for t in 0..ROW_GROUP as u32 * 4 {
            if let Err(e) = w.push(t, &images) {
                errors.push(crate::escape::error_line(&e));
            }
        }
        if let Err(e) = w.finish() {
            errors.push(crate::escape::error_line(&e));
        }
        assert!(
            !errors.is_empty(),
            "writes to a full disk reported no error"
        );
        assert!(errors[0].starts_with("obs.parquet: "), "{errors:?}");
        assert!(errors[0].to_lowercase().contains("space"), "{errors:?}");
    }
}
