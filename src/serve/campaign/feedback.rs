//! What participants say when they are done: a rating of how hard the task was (1 = easy,
//! 5 = very hard) and a comment, kept per participant in `STATE/feedback/<participant>.json`
//! (rewritten atomically with each message) and shown to the operator. A lab reads it for
//! what the numbers do not say (the controls were confusing, the page was slow).

use crate::file_error::FileError;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::CampaignError;

/// The feedback folder inside a campaign's state folder.
pub const FEEDBACK: &str = "feedback";

/// Characters of a comment, at most.
pub const MAX_COMMENT: usize = 2000;

/// Messages one participant may leave, at most.
pub const MAX_PER_PARTICIPANT: usize = 10;

/// One message of a participant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Feedback {
    /// How hard the task was, 1 (easy) to 5 (very hard); absent when not given.
    #[serde(default)]
    pub rating: Option<u8>,
    /// What they wrote (may be empty).
    #[serde(default)]
    pub comment: String,
}

/// Why feedback was refused.
#[derive(Debug, thiserror::Error)]
pub enum FeedbackError {
    /// The rating is not 1 to 5.
    #[error("rating {0}: must be 1 to 5")]
    Rating(u8),
    /// The comment is too long.
    #[error("the comment has {0} characters: at most {MAX_COMMENT}")]
    CommentTooLong(usize),
    /// Neither a rating nor a comment.
    #[error("empty feedback: give a rating or a comment")]
    Empty,
    /// The participant has said enough.
    #[error("at most {MAX_PER_PARTICIPANT} messages per participant")]
    TooMany,
    /// The file could not be written.
    #[error(transparent)]
    Record(#[from] CampaignError),
}

impl Feedback {
    /// Checks the rating and the comment's length.
    pub fn validate(&self) -> Result<(), FeedbackError> {
        if let Some(r) = self.rating {
            if !(1..=5).contains(&r) {
                return Err(FeedbackError::Rating(r));
            }
        }
        let chars = self.comment.chars().count();
        if chars > MAX_COMMENT {
            return Err(FeedbackError::CommentTooLong(chars));
        }
        if self.rating.is_none() && self.comment.trim().is_empty() {
            return Err(FeedbackError::Empty);
        }
        Ok(())
    }
}

fn file(state: &Path, participant: &str) -> PathBuf {
    state.join(FEEDBACK).join(format!("{participant}.json"))
}

/// Writes `participant`'s messages (atomically). `participant` is a name from the
/// participants file, never a request's text.
pub fn save(state: &Path, participant: &str, all: &[Feedback]) -> Result<(), CampaignError> {
    let path = file(state, participant);
    let dir = state.join(FEEDBACK);
    std::fs::create_dir_all(&dir)
        .map_err(|source| CampaignError::Io(FileError::new(dir.clone(), source)))?;
    let text = serde_json::to_string_pretty(all).map_err(|e| CampaignError::File {
        path: path.clone(),
        message: e.to_string(),
    })?;
    crate::atomic::write_bytes_atomic(&path, text.as_bytes())
        .map_err(|source| CampaignError::Io(FileError { path, source }))
}

/// Every participant's messages in `state` (none when the folder does not exist); sweeps
/// what a killed writer left.
pub fn load_all(state: &Path) -> Result<BTreeMap<String, Vec<Feedback>>, CampaignError> {
    let dir = state.join(FEEDBACK);
    let io = |source: std::io::Error| CampaignError::Io(FileError::new(dir.clone(), source));
    let mut out = BTreeMap::new();
    if !dir.is_dir() {
        return Ok(out);
    }
    crate::atomic::sweep_stale(&dir).map_err(io)?;
    for entry in std::fs::read_dir(&dir).map_err(io)? {
        let path = entry.map_err(io)?.path();
        let Some(participant) = path
            .file_name()
            .and_then(|n| n.to_str())
            .and_then(|n| n.strip_suffix(".json"))
            .filter(|n| !n.starts_with('.'))
        else {
            continue;
        };
        let bytes = std::fs::read(&path)
            .map_err(|source| CampaignError::Io(FileError::new(path.clone(), source)))?;
        let list: Vec<Feedback> =
            serde_json::from_slice(&bytes).map_err(|e| CampaignError::File {
                path: path.clone(),
                message: e.to_string(),
            })?;
        out.insert(participant.to_string(), list);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn feedback_is_checked_kept_and_read_back() {
        let ok = Feedback {
            rating: Some(4),
            comment: "the turns were too big".into(),
        };
        assert!(ok.validate().is_ok());
        for (bad, says) in [
            (
                Feedback {
                    rating: Some(0),
                    comment: String::new(),
                },
                "rating 0",
            ),
            (
                Feedback {
                    rating: Some(6),
                    comment: "x".into(),
                },
                "rating 6",
            ),
            (
                Feedback {
                    rating: None,
                    comment: "  ".into(),
                },
                "empty",
            ),
            (
                Feedback {
                    rating: None,
                    comment: "é".repeat(MAX_COMMENT + 1),
                },
                "2001 characters",
            ),
        ] {
            let e = bad.validate().unwrap_err().to_string();
            assert!(e.contains(says), "{e}");
        }
        let state = tempfile::tempdir().expect("tmp");
        assert!(load_all(state.path()).expect("no folder").is_empty());
        save(state.path(), "p0002", std::slice::from_ref(&ok)).expect("save");
        let all = load_all(state.path()).expect("load");
        assert_eq!(all.len(), 1);
        assert_eq!(all["p0002"], vec![ok]);
        // A file that is not feedback is refused with its name.
        std::fs::write(state.path().join(FEEDBACK).join("p0003.json"), "{").unwrap();
        let e = load_all(state.path()).unwrap_err().to_string();
        assert!(e.contains("p0003.json"), "{e}");
    }
}
