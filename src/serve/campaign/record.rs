//! A session's quality records: `<session>/qc.json`, one entry per finished episode in the
//! order played (figures, verdict, whether it was the tutorial, the operator's review),
//! rewritten atomically after each episode and each review. `minos export-dataset
//! --accepted` reads it.

use crate::file_error::FileError;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::CampaignError;
use crate::io::run_dir::RunDir;
use crate::run::qc::{DemoQc, Verdict};

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
    /// Accepted or flagged: the thresholds' verdict, or the operator's when reviewed.
    pub verdict: Verdict,
    /// The operator's review, when they overrode the thresholds' verdict (absent otherwise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub review: Option<Review>,
}

/// An operator's decision on a demonstration, which replaces the thresholds' verdict.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Review {
    /// Why, in the operator's words (may be empty).
    pub note: String,
    /// The thresholds' verdict it replaced (kept, so a review can be undone).
    pub automatic: Verdict,
}

impl DemoEntry {
    /// The entry after the operator's review: `accepted` (or flagged) with `note`; the
    /// thresholds' verdict is kept in [`Review::automatic`]. Reviewing back to the
    /// thresholds' verdict with an empty note removes the review.
    pub fn reviewed(&self, accepted: bool, note: &str) -> DemoEntry {
        let automatic = self
            .review
            .as_ref()
            .map_or_else(|| self.verdict.clone(), |r| r.automatic.clone());
        let note = note.trim();
        if accepted == automatic.accepted && note.is_empty() {
            return DemoEntry {
                verdict: automatic,
                review: None,
                ..self.clone()
            };
        }
        let said = if note.is_empty() {
            String::new()
        } else {
            format!(": {note}")
        };
        let reasons = if accepted {
            Vec::new()
        } else {
            vec![format!("flagged by the operator{said}")]
        };
        DemoEntry {
            verdict: Verdict { accepted, reasons },
            review: Some(Review {
                note: note.to_string(),
                automatic,
            }),
            ..self.clone()
        }
    }
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
        let path = RunDir::new(dir).qc();
        match std::fs::read(&path) {
            Ok(bytes) => serde_json::from_slice(&bytes).map_err(|e| CampaignError::File {
                path,
                message: e.to_string(),
            }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(SessionQc::default()),
            Err(source) => Err(CampaignError::Io(FileError { path, source })),
        }
    }

    /// Writes the records into session folder `dir` (atomically).
    pub fn save(&self, dir: &Path) -> Result<(), CampaignError> {
        let path = RunDir::new(dir).qc();
        let text = serde_json::to_string_pretty(self).map_err(|e| CampaignError::File {
            path: path.clone(),
            message: e.to_string(),
        })?;
        crate::atomic::write_bytes_atomic(&path, text.as_bytes())
            .map_err(|source| CampaignError::Io(FileError { path, source }))
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

#[cfg(test)]
mod tests {
    use super::*;

    fn flagged() -> DemoEntry {
        DemoEntry {
            episode_id: "e".into(),
            participant: "p0001".into(),
            tutorial: false,
            qc: None,
            verdict: Verdict {
                accepted: false,
                reasons: vec!["idle 9.0 s (at most 5 s)".into()],
            },
            review: None,
        }
    }

    #[test]
    fn a_review_replaces_the_verdict_keeps_the_thresholds_and_can_be_undone() {
        let auto = flagged();
        let accepted = auto.reviewed(true, "  the pause was the page loading ");
        assert_eq!(
            accepted.verdict,
            Verdict {
                accepted: true,
                reasons: vec![]
            }
        );
        let review = accepted.review.clone().expect("reviewed");
        assert_eq!(review.note, "the pause was the page loading");
        assert_eq!(review.automatic, auto.verdict);
        // A second review keeps the thresholds' verdict, not the first review's.
        let flagged_again = accepted.reviewed(false, "walked into walls");
        assert_eq!(
            flagged_again.verdict.reasons,
            vec!["flagged by the operator: walked into walls".to_string()]
        );
        assert_eq!(
            flagged_again.review.expect("reviewed").automatic,
            auto.verdict
        );
        // Back to the thresholds' verdict without a note: no review left.
        assert_eq!(accepted.reviewed(false, ""), auto);
        // The record round-trips through qc.json; a record without a review reads as before.
        let file = SessionQc {
            demos: vec![auto.clone(), accepted.clone()],
        };
        let text = serde_json::to_string(&file).expect("json");
        assert_eq!(text.matches("\"review\"").count(), 1, "{text}");
        assert_eq!(
            serde_json::from_str::<SessionQc>(&text).expect("read"),
            file
        );
        assert_eq!(file.accepted(), vec!["e".to_string()]);
    }
}
