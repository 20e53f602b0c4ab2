//! rerun recordings (`.rrd` files) of scenes, navigation grids, episodes and rollouts, for
//! looking at results in the rerun viewer (`rerun FILE.rrd`).
//!
//! [`RrdFile`] encodes one recording with rerun's own encoder (`re_log_encoding`) to a
//! temporary name and renames it into place when [`RrdFile::finish`] succeeds, so a `.rrd`
//! under its final name is always complete. It does not go through the SDK's
//! `RecordingStream`, for two reasons: every write error comes back to the caller (the SDK's
//! file sink logs them on its own thread), and the data are deterministic. The SDK stamps
//! every row and chunk with a wall-clock id, adds `log_time`/`log_tick` timelines and a start
//! time; here row and chunk ids are a counter under a base derived from the recording id, the
//! only timelines are `step` and `sim_time`, and no clock is read, so the same run writes the
//! same data: every message of a recording is byte-identical between runs. The one part that
//! is not is rerun's footer, the index of chunk offsets at the end of the file that the
//! viewer uses to load large files lazily and `rerun rrd verify` checks: rerun's encoder
//! builds it from randomly seeded hash maps, so its bytes (not its content) change from run
//! to run. minos keeps the footer, as rerun's tools expect one.
//!
//! [`scene`] logs what does not change over time (meshes, the navigation grid, an episode's
//! start, goal and shortest path), [`episode`] what does (the agent, its cameras and
//! measurements per step), and [`view`] writes a scene's recording for `minos view`.
//! Several recordings are joined into one file ([`concat()`]); the viewer lists each as a
//! recording of its own. The entity paths are listed in `docs/FORMATS.md`.

pub mod episode;
pub mod scene;
pub mod view;

use std::cell::{Cell, RefCell};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use re_log_encoding::{CrateVersion, Encoder, EncodingOptions};
use rerun::external::re_log_types::external::re_tuid::Tuid;
use rerun::external::re_log_types::{SetStoreInfo, StoreInfo, StoreSource};
use rerun::log::{Chunk, ChunkId, LogMsg, RowId};
use rerun::{EntityPath, StoreId, StoreKind, TimeCell, TimePoint};

use crate::atomic::{temp_path, write_atomic};
use crate::seed::derive_seed;

/// Application id of every minos recording (the viewer groups recordings by it).
pub const APPLICATION_ID: &str = "minos";

/// The sequence timeline of simulation steps.
pub const STEP_TIMELINE: &str = "step";

/// The duration timeline of simulated time (steps × the agent's time step).
pub const SIM_TIME_TIMELINE: &str = "sim_time";

/// The time part of every row and chunk id minos writes (2026-01-01T00:00:00Z in
/// nanoseconds): ids are ordered by their counter, never by a clock.
const ID_EPOCH_NANOS: u64 = 1_767_225_600_000_000_000;

/// Why a recording could not be written.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// Creating, logging to or finishing the file failed.
    #[error("{path}: {message}")]
    File {
        /// The recording's final path.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

/// One recording encoded to a temporary file beside `path`, renamed into place by
/// [`RrdFile::finish`]; dropped unfinished, it removes its temporary file.
pub struct RrdFile {
    encoder: RefCell<Option<Encoder<BufWriter<File>>>>,
    store: StoreId,
    /// High half of every id's counter: the recording's own (from its id), so ids of joined
    /// recordings never collide.
    id_base: u64,
    next_id: Cell<u64>,
    time: RefCell<TimePoint>,
    /// Timed rows not yet written, per entity path.
    pending: RefCell<BTreeMap<EntityPath, Pending>>,
    tmp: PathBuf,
    path: PathBuf,
}

/// One row: its id, time and component batches.
type Row = (RowId, TimePoint, Vec<rerun::SerializedComponentBatch>);

/// Rows of one entity gathered into one chunk.
struct Pending {
    id: ChunkId,
    rows: Vec<Row>,
    bytes: usize,
}

/// Most rows in one chunk of a timed entity.
const CHUNK_ROWS: usize = 64;

/// Chunks of a timed entity are written once their component arrays reach this size.
const CHUNK_BYTES: usize = 4 << 20;

impl RrdFile {
    /// Starts the recording `recording_id` (shown as `name` in the viewer) for `path`.
    pub fn create(path: &Path, recording_id: &str, name: &str) -> Result<Self, RecordingError> {
        let fail = |e: &dyn std::fmt::Display| RecordingError::File {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| fail(&e))?;
        }
        let tmp = temp_path(path);
        let file = File::create(&tmp).map_err(|e| fail(&e))?;
        let encoder = Encoder::new_eager(
            CrateVersion::LOCAL,
            EncodingOptions::PROTOBUF_COMPRESSED,
            BufWriter::new(file),
        );
        let encoder = match encoder {
            Ok(e) => e,
            Err(e) => {
                let _ = std::fs::remove_file(&tmp);
                return Err(fail(&e));
            }
        };
        let store = StoreId::new(StoreKind::Recording, APPLICATION_ID, recording_id);
        let rec = RrdFile {
            encoder: RefCell::new(Some(encoder)),
            store: store.clone(),
            id_base: (derive_seed(0, &["rrd", recording_id]) & 0xffff_ffff) << 32,
            next_id: Cell::new(0),
            time: RefCell::new(TimePoint::default()),
            pending: RefCell::new(BTreeMap::new()),
            tmp,
            path: path.to_path_buf(),
        };
        let source = StoreSource::Other(format!("minos {}", env!("CARGO_PKG_VERSION")));
        rec.append(&LogMsg::SetStoreInfo(SetStoreInfo {
            row_id: rec.next_tuid(),
            info: StoreInfo::new(store, source),
        }))?;
        rec.log_static(
            EntityPath::properties(),
            &rerun::RecordingInfo::new().with_name(name),
        )?;
        Ok(rec)
    }

    /// An error about this recording.
    pub(crate) fn error(&self, message: impl std::fmt::Display) -> RecordingError {
        RecordingError::File {
            path: self.path.clone(),
            message: message.to_string(),
        }
    }

    /// The next id of this recording (row, chunk or store-info ids share one counter).
    fn next_tuid(&self) -> Tuid {
        let n = self.next_id.get();
        self.next_id.set(n + 1);
        Tuid::from_nanos_and_inc(ID_EPOCH_NANOS, self.id_base | n)
    }

    /// Encodes one message into the file.
    fn append(&self, msg: &LogMsg) -> Result<(), RecordingError> {
        let mut encoder = self.encoder.borrow_mut();
        let encoder = encoder
            .as_mut()
            .ok_or_else(|| self.error("recording already finished"))?;
        encoder.append(msg).map_err(|e| self.error(e))?;
        Ok(())
    }

    /// Writes `what` at `entity` at `time` (empty: static). Static rows become a chunk at
    /// once; timed rows are gathered per entity into chunks of up to [`CHUNK_ROWS`] rows or
    /// [`CHUNK_BYTES`] bytes, as rerun's own batcher does (one chunk per row would repeat
    /// the chunk's schema with every image).
    fn write<AS: ?Sized + rerun::AsComponents>(
        &self,
        entity: EntityPath,
        time: TimePoint,
        what: &AS,
    ) -> Result<(), RecordingError> {
        let row_id = RowId::from_tuid(self.next_tuid());
        let batches = what.as_serialized_batches();
        if time.is_static() {
            return self.emit(
                entity,
                Pending {
                    id: ChunkId::from_tuid(self.next_tuid()),
                    rows: vec![(row_id, time, batches)],
                    bytes: 0,
                },
            );
        }
        let bytes: usize = batches
            .iter()
            .map(|b| b.array.get_array_memory_size())
            .sum();
        let mut pending = self.pending.borrow_mut();
        let p = pending.entry(entity.clone()).or_insert_with(|| Pending {
            id: ChunkId::from_tuid(self.next_tuid()),
            rows: Vec::new(),
            bytes: 0,
        });
        p.rows.push((row_id, time, batches));
        p.bytes += bytes;
        if p.rows.len() >= CHUNK_ROWS || p.bytes >= CHUNK_BYTES {
            let full = pending.remove(&entity);
            drop(pending);
            if let Some(full) = full {
                return self.emit(entity, full);
            }
        }
        Ok(())
    }

    /// Builds one chunk of gathered rows and encodes it.
    fn emit(&self, entity: EntityPath, p: Pending) -> Result<(), RecordingError> {
        let mut builder = Chunk::builder_with_id(p.id, entity.clone());
        for (row_id, time, batches) in p.rows {
            builder = builder.with_serialized_batches(row_id, time, batches);
        }
        let msg = builder
            .build()
            .and_then(|c| c.to_arrow_msg())
            .map_err(|e| self.error(format!("{entity}: {e}")))?;
        self.append(&LogMsg::ArrowMsg(self.store.clone(), msg))
    }

    /// Writes every gathered row, entity by entity in path order.
    fn flush_pending(&self) -> Result<(), RecordingError> {
        let pending = std::mem::take(&mut *self.pending.borrow_mut());
        for (entity, p) in pending {
            self.emit(entity, p)?;
        }
        Ok(())
    }

    /// Logs `what` at `entity` at the current time (see [`RrdFile::set_step`]).
    pub fn log<AS: ?Sized + rerun::AsComponents>(
        &self,
        entity: impl Into<EntityPath>,
        what: &AS,
    ) -> Result<(), RecordingError> {
        let time = self.time.borrow().clone();
        self.write(entity.into(), time, what)
    }

    /// Logs `what` at `entity` for all times (scene geometry, camera intrinsics).
    pub fn log_static<AS: ?Sized + rerun::AsComponents>(
        &self,
        entity: impl Into<EntityPath>,
        what: &AS,
    ) -> Result<(), RecordingError> {
        self.write(entity.into(), TimePoint::default(), what)
    }

    /// Sets the time of what is logged next: the `step` sequence and `sim_time` (step × `dt`
    /// seconds).
    pub fn set_step(&self, step: u32, dt: f32) -> Result<(), RecordingError> {
        let nanos = (f64::from(step) * f64::from(dt) * 1e9).round() as i64;
        let mut time = TimePoint::default();
        time.insert_cell(STEP_TIMELINE, TimeCell::from_sequence(i64::from(step)));
        time.insert_cell(SIM_TIME_TIMELINE, TimeCell::from_duration_nanos(nanos));
        *self.time.borrow_mut() = time;
        Ok(())
    }

    /// Writes rerun's footer (the index of every chunk), closes the file and renames it to
    /// its final name.
    pub fn finish(self) -> Result<PathBuf, RecordingError> {
        self.flush_pending()?;
        let encoder = self.encoder.borrow_mut().take();
        if let Some(mut encoder) = encoder {
            encoder.finish().map_err(|e| self.error(e))?;
            let mut w = encoder.into_inner().map_err(|e| self.error(e))?;
            w.flush().map_err(|e| self.error(e))?;
            w.get_ref().sync_all().map_err(|e| self.error(e))?;
        }
        crate::atomic::rename_durably(&self.tmp, &self.path).map_err(|e| self.error(e))?;
        Ok(self.path.clone())
    }
}

impl Drop for RrdFile {
    fn drop(&mut self) {
        if self.encoder.get_mut().take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Joins the recordings `parts` into one file `out` (atomically), in order: each part is
/// decoded and its messages re-encoded, so the file gets one footer indexing every recording
/// (byte-wise concatenation would leave each part's footer pointing at the wrong offsets).
/// The viewer lists each recording on its own.
pub fn concat(parts: &[PathBuf], out: &Path) -> Result<(), RecordingError> {
    write_messages(out, |append| {
        for p in parts {
            for msg in decode(p)? {
                append(&msg)?;
            }
        }
        Ok(())
    })
}

/// The messages of a recording file, grouped by recording id (each group in file order).
/// `minos merge` takes the episodes' recordings of shard files apart with it.
pub fn recordings_of(path: &Path) -> Result<BTreeMap<String, Vec<LogMsg>>, RecordingError> {
    let mut by_id: BTreeMap<String, Vec<LogMsg>> = BTreeMap::new();
    for msg in decode(path).map_err(|e| RecordingError::File {
        path: path.to_path_buf(),
        message: e.to_string(),
    })? {
        let id = msg.store_id().recording_id().as_str().to_string();
        by_id.entry(id).or_default().push(msg);
    }
    Ok(by_id)
}

/// Writes recordings (each a sequence of messages, in the order given) into one file `out`
/// (atomically): [`concat()`] of recordings already in memory.
pub fn write_recordings<'a>(
    out: &Path,
    recordings: impl IntoIterator<Item = &'a [LogMsg]>,
) -> Result<(), RecordingError> {
    write_messages(out, |append| {
        for msg in recordings.into_iter().flatten() {
            append(msg)?;
        }
        Ok(())
    })
}

/// Every message of the recording file `path`, in order.
fn decode(path: &Path) -> std::io::Result<Vec<LogMsg>> {
    use re_log_encoding::DecoderApp;
    let fail =
        |e: &dyn std::fmt::Display| std::io::Error::other(format!("{}: {e}", path.display()));
    let reader = std::io::BufReader::new(File::open(path).map_err(|e| fail(&e))?);
    DecoderApp::decode_eager(reader)
        .map_err(|e| fail(&e))?
        .map(|m| m.map_err(|e| fail(&e)))
        .collect()
}

/// Encodes the messages `fill` appends into `out` (atomically, one footer at the end).
fn write_messages(
    out: &Path,
    fill: impl FnOnce(&mut dyn FnMut(&LogMsg) -> std::io::Result<()>) -> std::io::Result<()>,
) -> Result<(), RecordingError> {
    let fail = |e: &dyn std::fmt::Display| std::io::Error::other(format!("{}: {e}", out.display()));
    write_atomic(out, |w| {
        let mut encoder =
            Encoder::new_eager(CrateVersion::LOCAL, EncodingOptions::PROTOBUF_COMPRESSED, w)
                .map_err(|e| fail(&e))?;
        fill(&mut |msg: &LogMsg| encoder.append(msg).map(|_| ()).map_err(|e| fail(&e)))?;
        encoder.finish().map_err(|e| fail(&e))?;
        drop(encoder);
        Ok(())
    })
    .map_err(|e: std::io::Error| RecordingError::File {
        path: out.to_path_buf(),
        message: e.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn files(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_recording_appears_only_when_finished() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.rrd");
        {
            let f = RrdFile::create(&path, "one", "one").unwrap();
            f.log_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Y_UP())
                .unwrap();
            assert!(!path.exists());
        }
        assert!(
            files(dir.path()).is_empty(),
            "dropped unfinished: nothing left"
        );
        let f = RrdFile::create(&path, "one", "one").unwrap();
        f.set_step(3, 0.1).unwrap();
        f.log("world/x", &rerun::Scalars::single(1.0)).unwrap();
        assert_eq!(f.finish().unwrap(), path);
        assert_eq!(files(dir.path()), vec!["a.rrd".to_string()]);
        let joined = dir.path().join("both.rrd");
        concat(&[path.clone(), path.clone()], &joined).unwrap();
        let data_messages = |p: &Path| {
            let reader = std::io::BufReader::new(std::fs::File::open(p).unwrap());
            re_log_encoding::DecoderApp::decode_eager(reader)
                .unwrap()
                .filter(|m| matches!(m, Ok(rerun::log::LogMsg::ArrowMsg(..))))
                .count()
        };
        let one = data_messages(&path);
        assert!(one >= 1);
        assert_eq!(data_messages(&joined), 2 * one, "both copies decode");
        let missing = concat(&[dir.path().join("missing.rrd")], &joined);
        assert!(missing.unwrap_err().to_string().contains("missing.rrd"));
    }
}
