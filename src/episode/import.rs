//! Episode files of other tools, by format name: Habitat-Lab's JSON and MINOS's CSV read
//! into minos episodes ([`import_episodes`]), the one entry `minos episodes import` uses.

use std::path::Path;

use super::habitat::{import_habitat, HabitatError};
use super::minos_csv::{import_minos_csv, MinosCsvError};
use super::Episode;

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

/// Why a foreign episode file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// A Habitat-Lab file.
    #[error(transparent)]
    Habitat(#[from] HabitatError),
    /// A MINOS CSV file.
    #[error(transparent)]
    MinosCsv(#[from] MinosCsvError),
}

/// Reads the episodes of `path`, a file in `format`.
pub fn import_episodes(format: ForeignFormat, path: &Path) -> Result<Vec<Episode>, ImportError> {
    Ok(match format {
        ForeignFormat::Habitat => import_habitat(path)?,
        ForeignFormat::MinosCsv => import_minos_csv(path)?,
    })
}
