//! A session's quality records: `<session>/qc.json`, one entry per finished episode in the
//! order played (figures, verdict, whether it was the tutorial), rewritten atomically after
//! each episode. `minos export-dataset --accepted` reads it.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::CampaignError;
use crate::run::qc::{DemoQc, Verdict};

/// The quality file in a session folder.
pub const QC_FILE: &str = "qc.json";

/// The quality record of one demonstration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DemoEntry {
    /// The episode.
    pub episode_id: String,
    /// The participant.
    pub participant: String,
    /// The tutorial episode (never exported).
    pub tutorial: bool,
    /// The figures (null when they were lost: the server stopped between writing the
    /// episode and its record).
    pub qc: Option<DemoQc>,
    /// Accepted or flagged.
    pub verdict: Verdict,
}

/// Every record of a session.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SessionQc {
    /// In the order played.
    pub demos: Vec<DemoEntry>,
}

impl SessionQc {
    /// The records of session folder `dir` (none when it has no file).
    pub fn load(dir: &Path) -> Result<SessionQc, CampaignError> {
        let path = dir.join(QC_FILE);
        match std::fs::read(&path) {
            Ok(bytes) => serde_json::from_slice(&bytes).map_err(|e| CampaignError::File {
                path,
                message: e.to_string(),
            }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(SessionQc::default()),
            Err(source) => Err(CampaignError::Io { path, source }),
        }
    }

    /// Writes the records into session folder `dir` (atomically).
    pub fn save(&self, dir: &Path) -> Result<(), CampaignError> {
        let path = dir.join(QC_FILE);
        let text = serde_json::to_string_pretty(self).map_err(|e| CampaignError::File {
            path: path.clone(),
            message: e.to_string(),
        })?;
        crate::atomic::write_bytes_atomic(&path, text.as_bytes())
            .map_err(|source| CampaignError::Io { path, source })
    }

    /// Ids of the accepted, non-tutorial episodes.
    pub fn accepted(&self) -> Vec<String> {
        self.demos
            .iter()
            .filter(|d| d.verdict.accepted && !d.tutorial)
            .map(|d| d.episode_id.clone())
            .collect()
    }
}
