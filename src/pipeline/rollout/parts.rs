//! An episode's part files in `DIR/.parts/`: `<index>.traj.parquet`, `<index>.obs.parquet`,
//! `<index>.rrd` when recorded, and `<index>.json`, its metrics, written last, so an episode
//! whose metrics exist is finished and a resumed run keeps it.

use crate::file_error::FileError;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::atomic::write_bytes_atomic;
use crate::io::run_dir::PartFile;
use crate::run::metrics::EpisodeMetrics;

/// A metrics part that could not be written or read back.
#[derive(Debug, thiserror::Error)]
pub enum PartError {
    /// Reading or writing the file failed.
    #[error(transparent)]
    Io(#[from] FileError),
    /// The part is not the JSON record minos writes (or could not be encoded as one).
    #[error("{}", path.display())]
    Json {
        /// The part file.
        path: PathBuf,
        /// The cause.
        source: serde_json::Error,
    },
}

/// How many episodes in part folder `dir` are finished (have their metrics part).
pub fn finished_count(dir: &Path) -> std::io::Result<usize> {
    let mut finished = 0;
    for entry in std::fs::read_dir(dir)? {
        let name = entry?.file_name();
        finished += usize::from(
            PartFile::Metrics
                .index_of(&name.to_string_lossy())
                .is_some(),
        );
    }
    Ok(finished)
}

/// Metrics of a finished episode as stored in its part file.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PartDone {
    episode_id: String,
    success: bool,
    speed: f32,
    spl: f32,
    soft_spl: f32,
    path_length: f32,
    steps: u32,
    collisions: u32,
    final_geodesic: Option<f32>,
    /// VLN episodes only (parts written before nDTW existed have none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    ndtw: Option<f32>,
}

impl From<&PartDone> for EpisodeMetrics {
    fn from(p: &PartDone) -> Self {
        EpisodeMetrics {
            success: p.success,
            speed: p.speed,
            spl: p.spl,
            soft_spl: p.soft_spl,
            path_length: p.path_length,
            steps: p.steps,
            collisions: p.collisions,
            final_geodesic: p.final_geodesic.unwrap_or(f32::NAN),
            ndtw: p.ndtw.unwrap_or(f32::NAN),
        }
    }
}

/// Writes the metrics part of a finished episode (atomically: it marks the episode done).
pub fn write_done(
    dir: &Path,
    index: usize,
    episode_id: &str,
    m: &EpisodeMetrics,
) -> Result<(), PartError> {
    let done = PartDone {
        episode_id: episode_id.to_string(),
        success: m.success,
        speed: m.speed,
        spl: m.spl,
        soft_spl: m.soft_spl,
        path_length: m.path_length,
        steps: m.steps,
        collisions: m.collisions,
        final_geodesic: m.final_geodesic.is_finite().then_some(m.final_geodesic),
        ndtw: m.ndtw.is_finite().then_some(m.ndtw),
    };
    let path = PartFile::Metrics.of(dir, index);
    let json = serde_json::to_vec(&done).map_err(|source| PartError::Json {
        path: path.clone(),
        source,
    })?;
    write_bytes_atomic(&path, &json).map_err(|source| PartError::Io(FileError { path, source }))
}

/// Reads the metrics part of an episode finished by an earlier run.
pub fn read_done(dir: &Path, index: usize) -> Result<EpisodeMetrics, PartError> {
    let path = PartFile::Metrics.of(dir, index);
    let bytes = std::fs::read(&path)
        .map_err(|source| PartError::Io(FileError::new(path.clone(), source)))?;
    let done: PartDone =
        serde_json::from_slice(&bytes).map_err(|source| PartError::Json { path, source })?;
    Ok(EpisodeMetrics::from(&done))
}
