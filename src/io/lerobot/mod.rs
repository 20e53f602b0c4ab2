//! A run as a LeRobot v3.0 dataset (`minos run --format lerobot`, `minos export-dataset`),
//! the layout `lerobot.datasets.lerobot_dataset.LeRobotDataset(repo_id, root=DIR)` loads
//! offline:
//!
//! ```text
//! DIR/meta/info.json                          codebase_version v3.0, fps, features, totals, splits
//! DIR/meta/stats.json                         per-feature statistics of the whole dataset
//! DIR/meta/tasks.parquet                      task_index, task (the instruction) as index
//! DIR/meta/episodes/chunk-000/file-000.parquet  one row per episode: tasks, length,
//!                                             data/chunk_index, data/file_index,
//!                                             dataset_from_index, dataset_to_index,
//!                                             stats/<feature>/<stat>, minos/episode_id, minos/scene_id
//! DIR/data/chunk-000/file-000.parquet         the frames, episodes whole and in order, with
//!                                             the Hugging Face `datasets` features as schema
//!                                             metadata; row groups of whole episodes up to
//!                                             [`ROW_GROUP_BYTES`], numeric columns packed by
//!                                             kind (`compact_columns`); a new file after
//!                                             100 MB
//! DIR/videos/<key>/chunk-000/file-000.mp4     with `video`: each colour camera's frames as
//!                                             H.264 in MP4, episodes whole and in order
//!                                             ([`video`]); a new file after 200 MB
//! DIR/README.md                               the dataset card (Hugging Face YAML header)
//! DIR/meta/provenance.json                    minos version and commit, sha256 of the run
//!                                             tables it was made from and of every file
//! ```
//!
//! The features are described in [`features`]; every episode's task is its instruction in
//! English (`episode::instruction`), so language-conditioned policies get "find a
//! chair" rather than "objectgoal". The copy is made from the run's own tables
//! ([`RunTables`]), so an existing run converts without being run again, and the whole
//! folder is written under a temporary name and renamed into place when complete. Same run
//! tables ⇒ same bytes.

internal! {
    pub mod card;
}
mod data;
pub mod features;
pub mod image_file;
pub mod layout;
mod meta;
pub mod source;
pub mod stats;
pub mod video;
internal! {
    pub mod video_read;
}

use crate::file_error::FileError;
use std::fs::File;
use std::path::{Path, PathBuf};

use parquet::arrow::ArrowWriter;
use parquet::file::metadata::KeyValue;
use parquet::file::properties::{EnabledStatistics, WriterProperties, WriterPropertiesBuilder};

use crate::atomic::{sweep_stale_of, write_bytes_atomic};
use crate::io::run_dir::{RunDir, RunManifest, RunManifestError};
use crate::parquet_io::ParquetFileError;
use crate::progress::Progress;
pub use data::FrameError;
use data::{data_schema, episode_batch, EpisodeFrames};
use features::FeatureError;
use layout::FileIndex;
pub use meta::{video_settings, CODEBASE_VERSION};
use meta::{EpisodeMeta, VideoPlace};
use source::RunTables;

/// The dataset layouts `minos export-dataset` writes, by name (one so far).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DatasetLayout {
    /// LeRobot v3.0 (this module).
    Lerobot,
}

impl crate::vocab::Vocabulary for DatasetLayout {
    const WHAT: &'static str = "dataset format";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[crate::vocab::Term {
        value: DatasetLayout::Lerobot,
        name: "lerobot",
        aliases: &[],
        help: "LeRobot v3.0",
    }];
}

crate::vocab::name_traits!(DatasetLayout);
use source::{read_episodes, read_steps, EpisodeRow, ObservationRows, StepRow};
use video::VideoSettings;
use video::{video_file_path, VideoFile};

/// Why the LeRobot copy could not be written; every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum LerobotError {
    /// A file system error.
    #[error(transparent)]
    Io(#[from] FileError),
    /// A run table that cannot be read, or a bad record in it.
    #[error("{}: {record}", path.display())]
    Read {
        /// The table.
        path: PathBuf,
        /// The record (`row 12`, `column \`depth\``).
        record: String,
        /// What is wrong.
        #[source]
        cause: ReadCause,
    },
    /// A dataset file that could not be written.
    #[error("{}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        #[source]
        cause: WriteCause,
    },
    /// The output path ends in no folder name (`/`, `..`): there is nothing to replace
    /// safely.
    #[error("{}: names no folder to write the dataset into", path.display())]
    NoFolderName {
        /// The output path.
        path: PathBuf,
    },
    /// The run's tables disagree with each other.
    #[error("{}: {message}", path.display())]
    Mismatch {
        /// The table that disagrees.
        path: PathBuf,
        /// How.
        message: String,
    },
    /// A video feature's file could not be written.
    #[error("{}{}", path.display(), episode.as_ref().map(|e| format!(": episode `{e}`")).unwrap_or_default())]
    Video {
        /// The video file.
        path: PathBuf,
        /// The episode being written, when one was.
        episode: Option<String>,
        /// Why.
        #[source]
        source: Box<video::VideoError>,
    },
    /// An episode's frames do not make rows of the dataset's features.
    #[error("{}: episode `{episode}`", path.display())]
    Frames {
        /// The observation table they came from.
        path: PathBuf,
        /// The episode.
        episode: String,
        /// Why.
        #[source]
        source: data::FrameError,
    },
    /// A sensor that cannot become a LeRobot feature.
    #[error("{}", path.display())]
    Feature {
        /// The observation table.
        path: PathBuf,
        /// The cause.
        source: FeatureError,
    },
}

impl From<ParquetFileError> for LerobotError {
    fn from(e: ParquetFileError) -> Self {
        match e {
            ParquetFileError::Io(f) => LerobotError::Io(f),
            ParquetFileError::Format { path, cause } => LerobotError::Read {
                path: path.into(),
                record: "file".into(),
                cause: ReadCause::Table(cause),
            },
        }
    }
}

/// What is wrong with a run table's record: the table itself (its Parquet or Arrow error, or
/// a rule of the run tables broken), or an image cell that does not decode.
#[derive(Debug, thiserror::Error)]
pub enum ReadCause {
    /// The table, or a rule of it.
    #[error(transparent)]
    Table(crate::parquet_io::FormatCause),
    /// An image cell, or an image column's metadata.
    #[error(transparent)]
    Image(#[from] crate::io::image_codec::CodecError),
}

/// Whatever makes a table's cause (a Parquet or Arrow error, an `Invalid`, a rule's text).
impl<T: Into<crate::parquet_io::FormatCause>> From<T> for ReadCause {
    fn from(e: T) -> Self {
        ReadCause::Table(e.into())
    }
}

/// Why a dataset file could not be written: the Parquet or Arrow library's error, a JSON
/// one, or the file system's.
#[derive(Debug, thiserror::Error)]
pub enum WriteCause {
    /// The Parquet writer failed.
    #[error(transparent)]
    Parquet(Box<parquet::errors::ParquetError>),
    /// A record batch could not be built.
    #[error(transparent)]
    Arrow(Box<arrow::error::ArrowError>),
    /// A JSON file could not be made or read back.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// The file system failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

impl From<parquet::errors::ParquetError> for WriteCause {
    fn from(e: parquet::errors::ParquetError) -> Self {
        WriteCause::Parquet(Box::new(e))
    }
}

impl From<arrow::error::ArrowError> for WriteCause {
    fn from(e: arrow::error::ArrowError) -> Self {
        WriteCause::Arrow(Box::new(e))
    }
}

/// A [`LerobotError::Write`] of `path`.
pub(crate) fn write_error(path: &Path, cause: impl Into<WriteCause>) -> LerobotError {
    LerobotError::Write {
        path: path.to_path_buf(),
        cause: cause.into(),
    }
}

/// What the dataset is.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetOptions {
    /// Frames per second (LeRobot requires an integer): the agent's steps per second.
    pub fps: u32,
    /// `robot_type` in `info.json`.
    pub robot_type: String,
    /// The run's configuration as its `manifest.json` records it, without the keys that differ
    /// between the shards of one run or name this copy (see [`RunManifest::configuration`]);
    /// written into `meta/provenance.json` as `run`.
    pub run: Option<serde_json::Value>,
    /// Colour cameras as video features (H.264 in MP4 under `videos/`, lossy, ≈ 10–30×
    /// smaller), encoded so, rather than lossless image files in the data files (`None`).
    pub video: Option<VideoSettings>,
}

/// `robot_type` of a run's LeRobot copy.
pub const ROBOT_TYPE: &str = "minos-agent";

impl DatasetOptions {
    /// The options of the copy of the run whose manifest is `manifest`: `fps` frames per
    /// second, or by default the agent's steps per second (its `body.dt`); the run's
    /// configuration recorded; colour cameras as video with `video`.
    pub fn of_manifest(
        manifest: &RunManifest,
        fps: Option<u32>,
        video: Option<VideoSettings>,
    ) -> Result<Self, RunManifestError> {
        let fps = match fps {
            Some(fps) => fps,
            None => fps_of_step(manifest.step()?),
        };
        Ok(DatasetOptions {
            fps,
            robot_type: ROBOT_TYPE.into(),
            run: Some(manifest.configuration()),
            video,
        })
    }

    /// The options of the copy of the run folder `run`, from its manifest as
    /// [`DatasetOptions::of_manifest`] says; with `fps` given, a manifest that cannot be
    /// read is no error (the copy then records no configuration).
    pub fn of_run(
        run: &RunDir,
        fps: Option<u32>,
        video: Option<VideoSettings>,
    ) -> Result<Self, RunManifestError> {
        match (run.read_manifest(), fps) {
            (Ok(manifest), fps) => Self::of_manifest(&manifest, fps, video),
            (Err(_), Some(fps)) => Ok(DatasetOptions {
                fps,
                robot_type: ROBOT_TYPE.into(),
                run: None,
                video,
            }),
            (Err(e), None) => Err(e),
        }
    }
}

/// What was written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DatasetSummary {
    /// Episodes.
    pub episodes: usize,
    /// Frames.
    pub frames: usize,
    /// Distinct tasks (instructions).
    pub tasks: usize,
    /// Data files.
    pub data_files: usize,
}

/// The frames per second of an agent stepping every `dt` seconds, as LeRobot's integer
/// `fps` (at least 1).
pub fn fps_of_step(dt: f32) -> u32 {
    if dt.is_finite() && dt > 0.0 {
        (1.0 / dt).round().max(1.0) as u32
    } else {
        1
    }
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> LerobotError + '_ {
    move |source| LerobotError::Io(FileError::new(path, source))
}

/// zstd level of the data and `meta/episodes` files. Level 6 against 1 (measured on
/// `minos demo`-sized runs, see docs/PERFORMANCE.md): float32 depth 12 % smaller, 16-bit
/// labels 32 %, 8-bit colour 16 %, at ≈ 120 MB/s of depth on one core.
pub const ZSTD_LEVEL: i32 = 6;

/// Encoded bytes a data file's row group grows to before it is written out; a row group
/// holds whole episodes (one per episode made the footer, page headers and compression
/// frames of every scalar column per episode most of a small dataset's data file).
pub const ROW_GROUP_BYTES: usize = 64 * 1024 * 1024;

/// `builder` with each numeric column of `schema` in the encoding that packs it best:
/// `DELTA_BINARY_PACKED` for integers (indices, counters: consecutive values differ by
/// little), `BYTE_STREAM_SPLIT` for floats (the bytes of each significance together, which
/// zstd then compresses), and no dictionaries. Values are unchanged; pyarrow, and so
/// LeRobot and Hugging Face `datasets`, read both encodings.
pub(crate) fn compact_columns(
    builder: WriterPropertiesBuilder,
    schema: &arrow::datatypes::Schema,
) -> Result<WriterPropertiesBuilder, parquet::errors::ParquetError> {
    use parquet::basic::{Encoding, Type};
    let descr = parquet::arrow::ArrowSchemaConverter::new().convert(schema)?;
    let mut b = builder.set_dictionary_enabled(false);
    for col in descr.columns() {
        let encoding = match col.physical_type() {
            Type::FLOAT | Type::DOUBLE => Encoding::BYTE_STREAM_SPLIT,
            Type::INT32 | Type::INT64 => Encoding::DELTA_BINARY_PACKED,
            _ => continue,
        };
        b = b.set_column_encoding(col.path().clone(), encoding);
    }
    Ok(b)
}

/// zstd at [`ZSTD_LEVEL`].
pub(crate) fn zstd() -> parquet::basic::Compression {
    parquet::basic::Compression::ZSTD(
        parquet::basic::ZstdLevel::try_new(ZSTD_LEVEL).unwrap_or_default(),
    )
}

/// Data-file writer properties: zstd, the numeric columns compacted ([`compact_columns`]),
/// no dictionaries (images and arrays are unique values), chunk statistics truncated so
/// image bytes do not land in the footer, and the schema's `huggingface` metadata also as
/// the file's own key-value metadata, where Hugging Face's writer puts it.
fn data_properties(
    schema: &arrow::datatypes::Schema,
) -> Result<WriterProperties, parquet::errors::ParquetError> {
    let key_values: Vec<KeyValue> = schema
        .metadata()
        .iter()
        .map(|(k, v)| KeyValue::new(k.clone(), v.clone()))
        .collect();
    let b = WriterProperties::builder()
        .set_key_value_metadata(Some(key_values))
        .set_compression(zstd())
        .set_statistics_enabled(EnabledStatistics::Chunk)
        .set_statistics_truncate_length(Some(64));
    Ok(compact_columns(b, schema)?.build())
}

/// The data file being filled.
struct DataFile {
    index: FileIndex,
    path: PathBuf,
    writer: ArrowWriter<File>,
}

impl DataFile {
    fn open(
        root: &Path,
        index: FileIndex,
        schema: arrow::datatypes::SchemaRef,
    ) -> Result<Self, LerobotError> {
        let path = root.join(index.path(layout::DATA));
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(io(dir))?;
        }
        let file = File::create(&path).map_err(io(&path))?;
        let props = data_properties(&schema).map_err(|e| write_error(&path, e))?;
        let writer =
            ArrowWriter::try_new(file, schema, Some(props)).map_err(|e| write_error(&path, e))?;
        Ok(DataFile {
            index,
            path,
            writer,
        })
    }

    fn close(self) -> Result<(), LerobotError> {
        let path = self.path;
        self.writer.close().map_err(|e| write_error(&path, e))?;
        Ok(())
    }
}

/// Writes the LeRobot v3.0 dataset of the run `tables` into `out` (replacing what is there
/// once the new copy is complete).
pub fn write_dataset(
    tables: &RunTables,
    out: &Path,
    options: &DatasetOptions,
    progress: &dyn Progress,
) -> Result<DatasetSummary, LerobotError> {
    let source = DemoSource {
        tables: tables.clone(),
        keep: None,
    };
    write_dataset_of(std::slice::from_ref(&source), out, options, progress)
}

/// One run among those a dataset is made of, and which of its episodes go in.
#[derive(Debug, Clone, PartialEq)]
pub struct DemoSource {
    /// The run's tables.
    pub tables: RunTables,
    /// Only these episode ids (`None`: every episode).
    pub keep: Option<std::collections::BTreeSet<String>>,
}

/// Writes one LeRobot v3.0 dataset of the kept episodes of every run of `sources`, in
/// order (several sessions of `minos serve` merged, or only their accepted
/// demonstrations); the runs must have the same cameras. Replaces `out` once complete.
pub fn write_dataset_of(
    sources: &[DemoSource],
    out: &Path,
    options: &DatasetOptions,
    progress: &dyn Progress,
) -> Result<DatasetSummary, LerobotError> {
    if out.file_name().is_none() {
        return Err(LerobotError::NoFolderName {
            path: out.to_path_buf(),
        });
    }
    if sources.is_empty() {
        return Err(LerobotError::Mismatch {
            path: out.to_path_buf(),
            message: "no run to export".into(),
        });
    }
    let parent = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent).map_err(io(parent))?;
    // What a killed writer of this dataset left beside it.
    sweep_stale_of(out).map_err(io(parent))?;
    let tmp = crate::atomic::temp_path(out);
    if tmp.exists() {
        std::fs::remove_dir_all(&tmp).map_err(io(&tmp))?;
    }
    let all: Vec<&RunTables> = sources.iter().map(|s| &s.tables).collect();
    let result = write_into(sources, &tmp, options, progress).and_then(|summary| {
        card::write_card_and_provenance(&all, &tmp, options.run.as_ref()).map(|()| summary)
    });
    match result {
        Ok(summary) => {
            crate::atomic::replace_dir(&tmp, out).map_err(io(out))?;
            Ok(summary)
        }
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            Err(e)
        }
    }
}

/// The contact count (the same on every row) and the object goals' vocabulary of `steps`.
fn run_shape(steps: &[StepRow], path: &Path) -> Result<features::RunShape, LerobotError> {
    let contacts = steps.first().map_or(0, |s| s.contact.len());
    if let Some((i, s)) = steps
        .iter()
        .enumerate()
        .find(|(_, s)| s.contact.len() != contacts)
    {
        return Err(LerobotError::Mismatch {
            path: path.to_path_buf(),
            message: format!(
                "row {i} (episode `{}`): {} contact bits where the first row has {contacts}",
                s.episode_id,
                s.contact.len()
            ),
        });
    }
    let mut goal_objects: Vec<String> =
        steps.iter().filter_map(|s| s.goal_object.clone()).collect();
    goal_objects.sort();
    goal_objects.dedup();
    Ok(features::RunShape {
        contacts,
        goal_objects,
    })
}

/// Writes the dataset into the (new, empty) folder `root`.
fn write_into(
    sources: &[DemoSource],
    root: &Path,
    options: &DatasetOptions,
    progress: &dyn Progress,
) -> Result<DatasetSummary, LerobotError> {
    // Every run's episodes and steps first: the features cover the goals of them all.
    let mut read = Vec::with_capacity(sources.len());
    for src in sources {
        let tables = &src.tables;
        let episodes = read_episodes(&tables.episodes)?;
        let steps = read_steps(&tables.trajectories)?;
        run_shape(&steps, &tables.trajectories)?;
        read.push((src, episodes, steps));
    }
    let Some((first, ..)) = read.first() else {
        return Err(LerobotError::Mismatch {
            path: root.to_path_buf(),
            message: "no run to export".into(),
        });
    };
    let cameras = ObservationRows::open(&first.tables.observations)?
        .cameras()
        .to_vec();
    let every_step: Vec<StepRow> = read
        .iter()
        .flat_map(|(_, _, steps)| steps.iter().cloned())
        .collect();
    let shape = run_shape(&every_step, &first.tables.trajectories)?;
    drop(every_step);
    let features =
        features::features(&cameras, &shape, options.fps, options.video).map_err(|source| {
            LerobotError::Feature {
                path: first.tables.observations.clone(),
                source,
            }
        })?;
    // One writer per video feature: its key, camera, the file being filled and the next
    // file's place.
    let mut videos: Vec<VideoStream> = features
        .iter()
        .filter_map(|f| match f.kind {
            features::FeatureKind::Video {
                camera, settings, ..
            } => Some(VideoStream {
                key: f.key.clone(),
                camera,
                settings,
                file: None,
                next: FileIndex::default(),
            }),
            _ => None,
        })
        .collect();
    let schema = data_schema(&features, &cameras);
    fn kept(src: &DemoSource, id: &str) -> bool {
        src.keep.as_ref().is_none_or(|k| k.contains(id))
    }
    let total: usize = read
        .iter()
        .map(|(src, eps, _)| eps.iter().filter(|e| kept(src, &e.episode_id)).count())
        .sum();
    progress.set_total(total as u64);

    // Tasks in order of first appearance.
    let mut tasks: Vec<String> = Vec::new();
    let mut metas: Vec<EpisodeMeta> = Vec::with_capacity(total);
    let mut file: Option<DataFile> = None;
    let mut next_index = FileIndex::default();
    let mut data_files = 0;
    let mut frames_total: i64 = 0;
    let limit = meta::DATA_FILE_MB * 1024 * 1024;
    let mut episodes: Vec<EpisodeRow> = Vec::with_capacity(total);
    for (src, run_episodes, steps) in &read {
        let tables = &src.tables;
        let mut observations = ObservationRows::open(&tables.observations)?;
        if observations.cameras() != cameras.as_slice() {
            return Err(LerobotError::Mismatch {
                path: tables.observations.clone(),
                message: format!("other cameras than {}", first.tables.observations.display()),
            });
        }
        let mut rest: &[StepRow] = steps;
        for (row, ep) in run_episodes.iter().enumerate() {
            let n = rest
                .iter()
                .take_while(|s| s.episode_id == ep.episode_id)
                .count();
            let (mine, after) = rest.split_at(n);
            rest = after;
            if n == 0 {
                return Err(LerobotError::Mismatch {
                    path: tables.trajectories.clone(),
                    message: format!(
                        "episode `{}` (row {row} of {}) has no trajectory rows where the table \
                     reaches it (episodes must be in the same order in both tables)",
                        ep.episode_id,
                        tables.episodes.display()
                    ),
                });
            }
            if let Some((i, s)) = mine.iter().enumerate().find(|(i, s)| s.step as usize != *i) {
                return Err(LerobotError::Mismatch {
                    path: tables.trajectories.clone(),
                    message: format!(
                        "episode `{}`: row {i} is step {}, expected {i}",
                        ep.episode_id, s.step
                    ),
                });
            }
            let mut images = Vec::with_capacity(n);
            for i in 0..n {
                let row = observations.next_row()?;
                match row {
                    Some((id, step, imgs)) if id == ep.episode_id && step as usize == i => {
                        images.push(imgs)
                    }
                    other => {
                        let got = other
                            .map(|(id, step, _)| format!("episode `{id}` step {step}"))
                            .unwrap_or_else(|| "the end of the table".into());
                        return Err(LerobotError::Mismatch {
                            path: tables.observations.clone(),
                            message: format!(
                                "expected episode `{}` step {i}, found {got}",
                                ep.episode_id
                            ),
                        });
                    }
                }
            }
            if !kept(src, &ep.episode_id) {
                continue;
            }
            let k = metas.len();
            episodes.push(ep.clone());
            let task_index = match tasks.iter().position(|t| *t == ep.instruction) {
                Some(t) => t,
                None => {
                    tasks.push(ep.instruction.clone());
                    tasks.len() - 1
                }
            };
            let frames = EpisodeFrames {
                steps: mine,
                images,
                episode_index: k as i64,
                first_index: frames_total,
                task_index: task_index as i64,
                fps: options.fps,
            };
            let (batch, stats) =
                episode_batch(&features, &cameras, &schema, &frames).map_err(|source| {
                    LerobotError::Frames {
                        path: tables.observations.clone(),
                        episode: ep.episode_id.clone(),
                        source,
                    }
                })?;
            let mut places = Vec::with_capacity(videos.len());
            for v in &mut videos {
                places.push(v.write_episode(
                    root,
                    &cameras,
                    &frames,
                    options.fps,
                    &ep.episode_id,
                )?);
            }
            let current = match file.take() {
                Some(f)
                    if f.writer.bytes_written() + f.writer.in_progress_size() < limit as usize =>
                {
                    f
                }
                Some(f) => {
                    f.close()?;
                    next_index = next_index.next();
                    data_files += 1;
                    DataFile::open(root, next_index, schema.clone())?
                }
                None => {
                    data_files += 1;
                    DataFile::open(root, next_index, schema.clone())?
                }
            };
            let mut current = current;
            current
                .writer
                .write(&batch)
                .map_err(|e| write_error(&current.path, e))?;
            // Row groups end between episodes only.
            if current.writer.in_progress_size() >= ROW_GROUP_BYTES {
                current
                    .writer
                    .flush()
                    .map_err(|e| write_error(&current.path, e))?;
            }
            metas.push(EpisodeMeta {
                episode_index: k as i64,
                task: ep.instruction.clone(),
                length: n as i64,
                data: current.index,
                from_index: frames_total,
                to_index: frames_total + n as i64,
                episode_id: ep.episode_id.clone(),
                scene_id: ep.scene_id.clone(),
                stats,
                videos: places,
            });
            frames_total += n as i64;
            file = Some(current);
            progress.advance(1);
        }
        if !rest.is_empty() {
            return Err(LerobotError::Mismatch {
                path: tables.trajectories.clone(),
                message: format!(
                    "rows of episode `{}` are not in {}",
                    rest[0].episode_id,
                    tables.episodes.display()
                ),
            });
        }
        if let Some((id, step, _)) = observations.next_row()? {
            return Err(LerobotError::Mismatch {
                path: tables.observations.clone(),
                message: format!("episode `{id}` step {step} has no trajectory row"),
            });
        }
    }
    match file {
        Some(f) => f.close()?,
        None => {
            // No episode: LeRobot still needs a data file to find.
            data_files += 1;
            DataFile::open(root, next_index, schema.clone())?.close()?;
        }
    }
    for v in videos {
        if let Some(f) = v.file {
            let path = f.path.clone();
            f.close().map_err(|source| LerobotError::Video {
                path,
                episode: None,
                source: Box::new(source),
            })?;
        }
    }

    meta::write_tasks(root, &tasks)?;
    meta::write_episodes(root, &metas, &features)?;
    let json_file = |path: PathBuf, value: serde_json::Value| -> Result<(), LerobotError> {
        let bytes = serde_json::to_vec_pretty(&value).map_err(|e| write_error(&path, e))?;
        write_bytes_atomic(&path, &bytes).map_err(io(&path))
    };
    json_file(
        root.join(layout::STATS),
        meta::stats_json(&metas, &features),
    )?;
    let split_of: Vec<(String, usize)> = episodes
        .iter()
        .enumerate()
        .map(|(i, e)| (e.split.clone(), i))
        .collect();
    json_file(
        root.join(layout::INFO),
        meta::info_json(
            &features,
            &cameras,
            &options.robot_type,
            options.fps,
            metas.len(),
            frames_total,
            tasks.len(),
            meta::splits(&split_of, metas.len()),
        ),
    )?;
    Ok(DatasetSummary {
        episodes: metas.len(),
        frames: frames_total as usize,
        tasks: tasks.len(),
        data_files,
    })
}

/// One video feature's files being written.
struct VideoStream {
    key: String,
    camera: usize,
    settings: VideoSettings,
    file: Option<VideoFile>,
    next: FileIndex,
}

impl VideoStream {
    /// Appends the episode's frames of this camera (to a new file once the current one
    /// holds [`video::VIDEO_FILE_MB`]) and says where they are.
    fn write_episode(
        &mut self,
        root: &Path,
        cameras: &[features::Camera],
        frames: &EpisodeFrames,
        fps: u32,
        episode_id: &str,
    ) -> Result<VideoPlace, LerobotError> {
        let limit = video::VIDEO_FILE_MB * 1024 * 1024;
        if let Some(f) = self.file.take_if(|f| f.bytes >= limit) {
            let path = f.path.clone();
            f.close().map_err(|source| LerobotError::Video {
                path,
                episode: None,
                source: Box::new(source),
            })?;
        }
        let format = &cameras[self.camera].format;
        let file = match &mut self.file {
            Some(f) => f,
            None => {
                let index = self.next;
                self.next = index.next();
                let path = video_file_path(root, &self.key, index);
                let f = VideoFile::create(
                    path.clone(),
                    index,
                    format.width,
                    format.height,
                    fps,
                    self.settings,
                )
                .map_err(|source| LerobotError::Video {
                    path,
                    episode: None,
                    source: Box::new(source),
                })?;
                self.file.insert(f)
            }
        };
        let from_timestamp = file.next_timestamp();
        for (i, images) in frames.images.iter().enumerate() {
            let rgb = match images.get(self.camera) {
                Some(crate::render::Image::U8 { data, channels: 3 }) => data.as_slice(),
                _ => {
                    return Err(LerobotError::Mismatch {
                        path: file.path.clone(),
                        message: format!(
                            "episode `{episode_id}` frame {i}: camera `{}` is not 8-bit RGB",
                            cameras[self.camera].name
                        ),
                    })
                }
            };
            file.push(rgb, i == 0)
                .map_err(|source| LerobotError::Video {
                    path: file.path.clone(),
                    episode: Some(episode_id.to_string()),
                    source: Box::new(source),
                })?;
        }
        Ok(VideoPlace {
            file: file.index,
            from_timestamp,
            to_timestamp: file.next_timestamp(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_path_without_a_folder_name_is_refused_before_anything_moves() {
        let options = DatasetOptions {
            fps: 10,
            robot_type: "minos".into(),
            run: None,
            video: None,
        };
        for out in ["/", "..", "a/.."] {
            let e = write_dataset_of(&[], Path::new(out), &options, &crate::progress::NoProgress)
                .unwrap_err();
            assert!(matches!(e, LerobotError::NoFolderName { .. }), "{out}: {e}");
            assert_eq!(
                e.to_string(),
                format!("{out}: names no folder to write the dataset into")
            );
        }
    }

    #[test]
    fn write_errors_keep_their_cause_typed_and_print_it_once() {
        let json = serde_json::from_str::<serde_json::Value>("{").unwrap_err();
        let text = json.to_string();
        let e = write_error(Path::new("meta/info.json"), json);
        assert!(matches!(
            &e,
            LerobotError::Write {
                cause: WriteCause::Json(_),
                ..
            }
        ));
        assert_eq!(e.to_string(), "meta/info.json");
        let source = std::error::Error::source(&e).expect("the cause");
        assert_eq!(source.to_string(), text);
        assert_eq!(
            crate::escape::error_line(&e),
            format!("meta/info.json: {text}")
        );
        // A run table that is no Parquet: the reader's error, typed, behind the record.
        let dir = tempfile::tempdir().unwrap();
        let junk = dir.path().join("observations.parquet");
        std::fs::write(&junk, b"not parquet").unwrap();
        let Err(read) = ObservationRows::open(&junk) else {
            panic!("junk opened")
        };
        let LerobotError::Read {
            record,
            cause: ReadCause::Table(crate::parquet_io::FormatCause::Parquet(_)),
            ..
        } = &read
        else {
            panic!("{read:?}")
        };
        assert_eq!(record, "file");
        assert!(std::error::Error::source(&read).is_some());
        let arrow = arrow::error::ArrowError::ComputeError("boom".into());
        assert!(matches!(
            write_error(Path::new("d.parquet"), arrow),
            LerobotError::Write {
                cause: WriteCause::Arrow(_),
                ..
            }
        ));
    }
}
