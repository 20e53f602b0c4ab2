//! Episode files of other tools, by format name: Habitat-Lab's JSON and MINOS's CSV read
//! into minos episodes ([`import_episodes`]), the one entry `minos episodes import` uses.

use std::path::Path;

use super::habitat::{import_habitat, HabitatError};
use super::minos_csv::{import_minos_csv, MinosCsvError};
use super::{Episode, Task};
use crate::vocab::Vocabulary;

/// A foreign episode format minos reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ForeignFormat {
    /// Habitat-Lab's dataset JSON (`.json`, `.json.gz`).
    Habitat,
    /// MINOS's episode CSV (`.csv`, `.csv.bz2`).
    MinosCsv,
}

impl crate::vocab::Vocabulary for ForeignFormat {
    const WHAT: &'static str = "episode format";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: ForeignFormat::Habitat,
            name: "habitat",
            aliases: &[],
            help: "Habitat-Lab's json / json.gz",
        },
        crate::vocab::Term {
            value: ForeignFormat::MinosCsv,
            name: "minos-csv",
            aliases: &[],
            help: "MINOS's episode CSV (csv / csv.bz2)",
        },
    ];
}

crate::vocab::name_traits!(ForeignFormat);

/// Why a foreign episode file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// A Habitat-Lab file.
    #[error(transparent)]
    Habitat(#[from] HabitatError),
    /// A MINOS CSV file.
    #[error(transparent)]
    MinosCsv(#[from] MinosCsvError),
    /// The rows were asked to be read as a task the format does not hold.
    #[error(
        "{path}: a {} file cannot be read as {} episodes (MINOS tables: as pointgoal, objectgoal or roomgoal; Habitat files: only as they are)",
        .format.term_name(),
        .task.term_name()
    )]
    Task {
        /// The file.
        path: String,
        /// Its format's name.
        format: ForeignFormat,
        /// The task asked for.
        task: Task,
    },
}

/// Reads the episodes of `path`, a file in `format`, each as its file says or, with `task`,
/// every one as that task: MINOS's tables can be read as RoomGoal (see
/// [`import_minos_csv`]); Habitat files hold their task.
pub fn import_episodes(
    format: ForeignFormat,
    path: &Path,
    task: Option<Task>,
) -> Result<Vec<Episode>, ImportError> {
    Ok(match (format, task) {
        (ForeignFormat::Habitat, None) => import_habitat(path)?,
        (
            ForeignFormat::MinosCsv,
            None | Some(Task::PointGoal | Task::ObjectGoal | Task::RoomGoal),
        ) => import_minos_csv(path, task)?,
        (_, Some(task)) => {
            return Err(ImportError::Task {
                path: path.display().to_string(),
                format,
                task,
            })
        }
    })
}
