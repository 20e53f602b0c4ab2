//! Participants and their links: `STATE/participants.json` (each participant's id and
//! token, readable by the owner only), minted by `minos campaign links`, and the operator's
//! token (`MINOS_OPERATOR_TOKEN`, else `STATE/operator.token`, made on first use). Tokens
//! never travel on a command line.

use crate::file_error::FileError;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::CampaignError;
use crate::lock::{DirLock, LockMode};
use crate::serve::token::{same, session_token};

/// The participants file in a campaign's state folder.
pub const PARTICIPANTS: &str = "participants.json";
/// The operator token file in a campaign's state folder.
pub const OPERATOR_TOKEN: &str = "operator.token";
/// The environment variable that overrides the operator token file.
pub const OPERATOR_TOKEN_ENV: &str = "MINOS_OPERATOR_TOKEN";

/// One participant.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Participant {
    /// `p0001`, `p0002`, … (names the participant's session folders).
    pub id: String,
    /// The secret in the participant's link.
    pub token: String,
}

/// Every participant of a campaign.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Participants {
    /// In the order minted.
    pub participants: Vec<Participant>,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> CampaignError + '_ {
    move |source| CampaignError::Io(FileError::new(path, source))
}

/// Writes `bytes` to `path` atomically, readable by the owner only.
fn write_secret(path: &Path, bytes: &[u8]) -> Result<(), CampaignError> {
    crate::atomic::write_atomic(path, |w| {
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            w.get_ref()
                .set_permissions(std::fs::Permissions::from_mode(0o600))?;
        }
        std::io::Write::write_all(w, bytes)
    })
    .map_err(io(path))
}

impl Participants {
    /// The participants of the state folder `state` (none when it has no file yet).
    pub fn load(state: &Path) -> Result<Participants, CampaignError> {
        let path = state.join(PARTICIPANTS);
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Self::default()),
            Err(e) => return Err(io(&path)(e)),
        };
        let p: Participants = serde_json::from_str(&text).map_err(|e| CampaignError::File {
            path: path.clone(),
            message: e.to_string(),
        })?;
        for (i, x) in p.participants.iter().enumerate() {
            let ok_id = !x.id.is_empty()
                && x.id.len() <= 32
                && x.id.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-');
            if !ok_id || !crate::serve::token::looks_like_token(&x.token) {
                return Err(CampaignError::File {
                    path,
                    message: format!("participants[{i}]: not an id and a 64-digit token"),
                });
            }
        }
        Ok(p)
    }

    /// The id of the participant whose token is `token` (every token compared in constant
    /// time).
    pub fn find(&self, token: &str) -> Option<&str> {
        let mut found = None;
        for p in &self.participants {
            if same(&p.token, token) && found.is_none() {
                found = Some(p.id.as_str());
            }
        }
        found
    }
}

/// Adds `count` participants with fresh tokens to the state folder `state` (under its
/// lock); returns the new ones.
pub fn mint(state: &Path, count: usize) -> Result<Vec<Participant>, CampaignError> {
    std::fs::create_dir_all(state).map_err(io(state))?;
    let _lock = DirLock::acquire(state, "campaign links", LockMode::Wait).map_err(|e| {
        CampaignError::File {
            path: state.to_path_buf(),
            message: crate::escape::error_line(&e),
        }
    })?;
    let mut all = Participants::load(state)?;
    let mut new = Vec::with_capacity(count);
    for _ in 0..count {
        let token = session_token().map_err(|e| CampaignError::File {
            path: state.to_path_buf(),
            message: format!("no randomness from the OS: {e}"),
        })?;
        let p = Participant {
            id: format!("p{:04}", all.participants.len() + 1),
            token,
        };
        all.participants.push(p.clone());
        new.push(p);
    }
    let text = serde_json::to_string_pretty(&all).map_err(|e| CampaignError::File {
        path: state.join(PARTICIPANTS),
        message: e.to_string(),
    })?;
    write_secret(&state.join(PARTICIPANTS), text.as_bytes())?;
    operator_token(state)?;
    Ok(new)
}

/// The operator's token: `MINOS_OPERATOR_TOKEN` when set, else `STATE/operator.token`
/// (made, with a fresh token, when missing). Returns the token and where it came from.
pub fn operator_token(state: &Path) -> Result<(String, String), CampaignError> {
    if let Ok(t) = std::env::var(OPERATOR_TOKEN_ENV) {
        let t = t.trim().to_string();
        if t.len() < 16 {
            return Err(CampaignError::File {
                path: PathBuf::from(format!("${OPERATOR_TOKEN_ENV}")),
                message: "shorter than 16 characters".into(),
            });
        }
        return Ok((t, format!("${OPERATOR_TOKEN_ENV}")));
    }
    let path = state.join(OPERATOR_TOKEN);
    match std::fs::read_to_string(&path) {
        Ok(t) if t.trim().len() >= 16 => Ok((t.trim().to_string(), path.display().to_string())),
        Ok(_) => Err(CampaignError::File {
            path,
            message: "the operator token is shorter than 16 characters".into(),
        }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            let t = session_token().map_err(|e| CampaignError::File {
                path: path.clone(),
                message: format!("no randomness from the OS: {e}"),
            })?;
            std::fs::create_dir_all(state).map_err(io(state))?;
            write_secret(&path, format!("{t}\n").as_bytes())?;
            Ok((t, path.display().to_string()))
        }
        Err(e) => Err(io(&path)(e)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minted_links_are_kept_private_and_found_by_token() {
        let dir = tempfile::tempdir().expect("tempdir");
        let a = mint(dir.path(), 2).expect("mint");
        let b = mint(dir.path(), 1).expect("mint");
        assert_eq!([&a[0].id, &a[1].id, &b[0].id], ["p0001", "p0002", "p0003"]);
        let all = Participants::load(dir.path()).expect("load");
        assert_eq!(all.participants.len(), 3);
        assert_eq!(all.find(&b[0].token), Some("p0003"));
        assert_eq!(all.find(&"0".repeat(64)), None);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            for f in [PARTICIPANTS, OPERATOR_TOKEN] {
                let mode = std::fs::metadata(dir.path().join(f))
                    .unwrap()
                    .permissions()
                    .mode();
                assert_eq!(mode & 0o077, 0, "{f}: {mode:o}");
            }
        }
        std::fs::write(
            dir.path().join(PARTICIPANTS),
            r#"{"participants":[{"id":"../x","token":"t"}]}"#,
        )
        .unwrap();
        let e = Participants::load(dir.path()).unwrap_err().to_string();
        assert!(e.contains("participants[0]"), "{e}");
    }
}
