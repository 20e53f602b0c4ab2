//! rerun recordings (`.rrd` files) of scenes, navigation grids, episodes and rollouts, for
//! looking at results in the rerun viewer (`rerun FILE.rrd`).
//!
//! [`RrdFile`] streams one recording to a temporary name and renames it into place when
//! [`RrdFile::finish`] succeeds, so a `.rrd` under its final name is always complete.
//! [`scene`] logs what does not change over time (meshes, the navigation grid, an episode's
//! start, goal and shortest path), [`episode`] what does (the agent, its cameras and
//! measurements per step), and [`view`] writes a scene's recording for `minos view`.
//! Several recordings are joined into one file ([`concat`]); the viewer lists each as a
//! recording of its own. The entity paths are listed in `docs/FORMATS.md`.

pub mod episode;
pub mod scene;
pub mod view;

use std::path::{Path, PathBuf};

use rerun::RecordingStream;

use crate::io::atomic::{temp_path, write_atomic};

/// Application id of every minos recording (the viewer groups recordings by it).
pub const APPLICATION_ID: &str = "minos";

/// The sequence timeline of simulation steps.
pub const STEP_TIMELINE: &str = "step";

/// The duration timeline of simulated time (steps × the agent's time step).
pub const SIM_TIME_TIMELINE: &str = "sim_time";

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

/// One recording streamed to a temporary file beside `path`, renamed into place by
/// [`RrdFile::finish`]; dropped unfinished, it removes its temporary file.
pub struct RrdFile {
    rec: Option<RecordingStream>,
    tmp: PathBuf,
    path: PathBuf,
}

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
        let rec = rerun::RecordingStreamBuilder::new(APPLICATION_ID)
            .recording_id(recording_id)
            .recording_name(name)
            .enabled(true)
            .save(&tmp)
            .map_err(|e| fail(&e))?;
        Ok(RrdFile {
            rec: Some(rec),
            tmp,
            path: path.to_path_buf(),
        })
    }

    /// The final path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The stream to log to (`None` only after `finish`).
    pub(crate) fn stream(&self) -> Result<&RecordingStream, RecordingError> {
        self.rec
            .as_ref()
            .ok_or_else(|| self.error("recording already finished"))
    }

    /// An error about this recording.
    pub(crate) fn error(&self, message: impl std::fmt::Display) -> RecordingError {
        RecordingError::File {
            path: self.path.clone(),
            message: message.to_string(),
        }
    }

    /// Logs `what` at `entity` at the current time (see [`RrdFile::set_step`]).
    pub fn log<AS: ?Sized + rerun::AsComponents>(
        &self,
        entity: impl Into<rerun::EntityPath>,
        what: &AS,
    ) -> Result<(), RecordingError> {
        let entity = entity.into();
        self.stream()?
            .log(entity.clone(), what)
            .map_err(|e| self.error(format!("{entity}: {e}")))
    }

    /// Logs `what` at `entity` for all times (scene geometry, camera intrinsics).
    pub fn log_static<AS: ?Sized + rerun::AsComponents>(
        &self,
        entity: impl Into<rerun::EntityPath>,
        what: &AS,
    ) -> Result<(), RecordingError> {
        let entity = entity.into();
        self.stream()?
            .log_static(entity.clone(), what)
            .map_err(|e| self.error(format!("{entity}: {e}")))
    }

    /// Sets the time of what is logged next: the `step` sequence and `sim_time` (step × `dt`
    /// seconds).
    pub fn set_step(&self, step: u32, dt: f32) -> Result<(), RecordingError> {
        let rec = self.stream()?;
        rec.set_time_sequence(STEP_TIMELINE, i64::from(step));
        rec.set_duration_secs(SIM_TIME_TIMELINE, f64::from(step) * f64::from(dt));
        Ok(())
    }

    /// Flushes everything logged, closes the file (writing rerun's footer) and renames it to
    /// its final name.
    pub fn finish(mut self) -> Result<PathBuf, RecordingError> {
        if let Some(rec) = self.rec.take() {
            rec.flush_blocking().map_err(|e| self.error(e))?;
            // Dropping the file sink joins its writer thread, which writes the footer.
            rec.disconnect();
            drop(rec);
        }
        std::fs::rename(&self.tmp, &self.path).map_err(|e| self.error(e))?;
        Ok(self.path.clone())
    }
}

impl Drop for RrdFile {
    fn drop(&mut self) {
        if let Some(rec) = self.rec.take() {
            rec.disconnect();
            drop(rec);
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Joins the recordings `parts` into one file `out` (atomically), in order: each part is
/// decoded and its messages re-encoded, so the file gets one footer indexing every recording
/// (byte-wise concatenation would leave each part's footer pointing at the wrong offsets).
/// The viewer lists each recording on its own.
pub fn concat(parts: &[PathBuf], out: &Path) -> Result<(), RecordingError> {
    use re_log_encoding::{CrateVersion, DecoderApp, Encoder, EncodingOptions};
    let fail = |path: &Path, e: &dyn std::fmt::Display| {
        std::io::Error::other(format!("{}: {e}", path.display()))
    };
    write_atomic(out, |w| {
        let mut encoder =
            Encoder::new_eager(CrateVersion::LOCAL, EncodingOptions::PROTOBUF_COMPRESSED, w)
                .map_err(|e| fail(out, &e))?;
        for p in parts {
            let reader = std::io::BufReader::new(std::fs::File::open(p).map_err(|e| fail(p, &e))?);
            for msg in DecoderApp::decode_eager(reader).map_err(|e| fail(p, &e))? {
                let msg = msg.map_err(|e| fail(p, &e))?;
                encoder.append(&msg).map_err(|e| fail(out, &e))?;
            }
        }
        encoder.finish().map_err(|e| fail(out, &e))?;
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
