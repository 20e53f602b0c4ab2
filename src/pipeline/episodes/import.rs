//! `minos episodes import`: a Habitat or MINOS episode file read into minos's episode
//! Parquet, with the provenance record every episode file carries (the source file and its
//! checksum in place of the sampling configuration), so `minos verify` checks it as it
//! checks sampled ones.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use crate::episode::format::{read_episodes, write_episodes, EpisodeFileError};
use crate::episode::import::{import_episodes, ForeignFormat, ImportError};
use crate::episode::{Episode, Task};
use crate::file_error::FileError;
use crate::provenance;
use crate::vocab::Vocabulary;

/// What to import and where to write it.
#[derive(Debug, Clone)]
pub struct ImportJob {
    /// The foreign file's format.
    pub from: ForeignFormat,
    /// The foreign file.
    pub file: PathBuf,
    /// Read every row as this task (MINOS's tables as RoomGoal, as MINOS's RoomGoal
    /// configurations read them); `None`: as the file says.
    pub task: Option<Task>,
    /// The episode file to write; `None` only reads and counts.
    pub out: Option<PathBuf>,
    /// The command line (or call) recorded in the provenance file.
    pub command: Vec<String>,
}

/// What an import read and wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportReport {
    /// The episodes read (as written, when written).
    pub episodes: Vec<Episode>,
    /// Distinct scenes they name.
    pub scenes: usize,
    /// The episode file and its provenance record, when written.
    pub written: Option<(PathBuf, PathBuf)>,
}

/// Why an import failed.
#[derive(Debug, thiserror::Error)]
pub enum ImportJobError {
    /// The foreign file could not be read.
    #[error(transparent)]
    Read(#[from] ImportError),
    /// The episode file could not be written or read back.
    #[error(transparent)]
    Write(#[from] EpisodeFileError),
    /// The provenance record could not be written.
    #[error("the episode file's provenance record")]
    Provenance(#[source] FileError),
}

/// Runs `job`: reads the foreign file, and when `job.out` is set writes the episodes (read
/// back to check them) and the provenance record beside them (`<out>.provenance.json`).
pub fn import_job(job: &ImportJob) -> Result<ImportReport, ImportJobError> {
    let episodes = import_episodes(job.from, &job.file, job.task)?;
    let scenes = episodes
        .iter()
        .map(|e| e.scene_id.as_str())
        .collect::<BTreeSet<_>>()
        .len();
    let (episodes, written) = match &job.out {
        None => (episodes, None),
        Some(out) => {
            write_episodes(out, &episodes)?;
            let back = read_episodes(out)?;
            let record =
                write_provenance(job, out, back.len()).map_err(ImportJobError::Provenance)?;
            (back, Some((out.clone(), record)))
        }
    };
    Ok(ImportReport {
        episodes,
        scenes,
        written,
    })
}

/// Writes `<out>.provenance.json`: the command, the source file with its format and
/// checksum, and the checksum of the episode file.
fn write_provenance(job: &ImportJob, out: &Path, count: usize) -> Result<PathBuf, FileError> {
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut record = serde_json::json!({
        "format": provenance::FORMAT,
        "kind": "episodes",
        "minos": provenance::MINOS,
        "command": job.command,
        "imported": {
            "from": job.from.term_name(),
            "path": job.file.display().to_string(),
            "checksum": provenance::sha256_file(&job.file)?,
            "episodes": count,
        },
        "files": { name: provenance::sha256_file(out)? },
    });
    if let (Some(task), Some(imported)) = (job.task, record.get_mut("imported")) {
        imported["task"] = task.term_name().into();
    }
    let path = PathBuf::from(format!("{}.provenance.json", out.display()));
    provenance::write_record(&path, &record)?;
    Ok(path)
}
