//! Demonstration campaigns (`minos serve --campaign FILE`): participants open their own
//! link, play the tutorial and then the episodes the ledger hands them until each episode
//! has its K accepted demonstrations; every finished episode gets its quality record; an
//! operator watches progress behind a token of their own.
//!
//! The state folder (`state` in the campaign file) holds `participants.json` and
//! `operator.token` ([`links`]), `demos/`, one folder per session named
//! `<participant>-s<NN>` — each a complete run of its finished episodes plus `qc.json`
//! ([`record`], with the operator's reviews) — and `feedback/`, what each participant said
//! at the end ([`feedback`]). Nothing else is kept: at start-up the ledger is rebuilt from the session
//! folders (their `played.parquet` and `qc.json`), after sweeping what a killed server left
//! (the unfinished episode's parts, temporaries, session locks), so a restart after
//! `kill -9` goes on where the finished episodes left off.

mod assign;
mod config;
pub mod feedback;
pub(super) mod http;
pub mod links;
pub mod record;

use crate::file_error::FileError;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

pub use assign::{Assignment, Ledger, Tally};
pub use config::{CampaignSpec, Selection};
use feedback::{Feedback, FeedbackError};
use record::{DemoEntry, SessionQc};

use crate::episode::Episode;
use crate::io::run_dir::RunDir;
use crate::lock::{DirLock, LockMode};
use crate::run::metrics::EpisodeMetrics;
use crate::run::qc::{DemoQc, DemoRecord, Verdict};

/// The sessions folder inside a campaign's state folder.
pub const DEMOS: &str = "demos";

/// Why a campaign could not be read, started or recorded (one line naming the file).
#[derive(Debug, thiserror::Error)]
pub enum CampaignError {
    /// A file could not be read or written.
    #[error(transparent)]
    Io(#[from] FileError),
    /// A file says something wrong.
    #[error("{}: {message}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// Why an operator's review was refused.
#[derive(Debug, thiserror::Error)]
pub enum ReviewError {
    /// No such demonstration.
    #[error("no demonstration of episode `{episode_id}` in session `{session}`")]
    NoDemo {
        /// The session asked for.
        session: String,
        /// The episode asked for.
        episode_id: String,
    },
    /// The tutorial is practice, never a demonstration.
    #[error("the tutorial episode is practice: it is never accepted")]
    Tutorial,
    /// The note is too long.
    #[error("the note has {0} characters: at most {MAX_NOTE}")]
    NoteTooLong(usize),
    /// The session's quality file could not be read or written.
    #[error(transparent)]
    Record(#[from] CampaignError),
}

/// Characters of an operator's note, at most.
pub const MAX_NOTE: usize = 500;

/// A demonstration found or recorded, for the operator.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Demo {
    /// The session folder's name.
    pub session: String,
    /// Its quality record.
    #[serde(flatten)]
    pub entry: DemoEntry,
}

/// What the campaign knows, behind one lock.
#[derive(Debug)]
struct Books {
    ledger: Ledger,
    demos: Vec<Demo>,
    /// Live sessions: participant → session name.
    live: BTreeMap<String, String>,
    /// Sessions started per participant (names the next folder).
    sessions: BTreeMap<String, u32>,
    /// What participants said, per participant in the order said.
    feedback: BTreeMap<String, Vec<Feedback>>,
}

impl Books {
    /// Where the demonstration of `episode_id` in session `session` stands in `demos`.
    fn demo_at(&self, session: &str, episode_id: &str) -> Option<usize> {
        self.demos
            .iter()
            .position(|d| d.session == session && d.entry.episode_id == episode_id)
    }
}

/// A running campaign.
#[derive(Debug)]
pub struct Campaign {
    /// The campaign file, read.
    pub spec: CampaignSpec,
    /// Where sessions are recorded (`STATE/demos`, canonical).
    pub demos_dir: PathBuf,
    /// The operator's token.
    operator: String,
    /// The episode file's episodes (the server's `Shared::episodes`), by id → index.
    index: BTreeMap<String, usize>,
    /// The campaign's episodes and tutorial (indices into the episode file).
    pub selection: Selection,
    books: Mutex<Books>,
    /// Held while the campaign runs: one server per campaign.
    _lock: DirLock,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> CampaignError + '_ {
    move |source| CampaignError::Io(FileError::new(path, source))
}

/// Puts session folder `dir` back to what its finished episodes wrote: the parts of an
/// unfinished episode, temporaries and the session's lock file go.
fn sweep_session(dir: &Path) -> Result<(), CampaignError> {
    let parts = RunDir::new(dir).parts();
    if parts.exists() {
        crate::atomic::remove_dir_atomic(&parts).map_err(io(&parts))?;
    }
    crate::atomic::sweep_stale(dir).map_err(io(dir))?;
    let lock = dir.join(crate::lock::LOCK_FILE);
    if lock.exists() {
        std::fs::remove_file(&lock).map_err(io(&lock))?;
    }
    Ok(())
}

impl Campaign {
    /// Opens the campaign `spec` over the episode file's `episodes`: takes the state
    /// folder's lock, sweeps every session folder and rebuilds the ledger from them.
    pub fn open(spec: CampaignSpec, episodes: &[Episode]) -> Result<Campaign, CampaignError> {
        let selection = spec.select(episodes)?;
        let demos_dir = spec.state.join(DEMOS);
        std::fs::create_dir_all(&demos_dir).map_err(io(&demos_dir))?;
        let demos_dir = demos_dir.canonicalize().map_err(io(&demos_dir))?;
        let lock = DirLock::acquire(&demos_dir, "campaign", LockMode::Fail).map_err(|e| {
            CampaignError::File {
                path: demos_dir.clone(),
                message: crate::escape::error_line(&e),
            }
        })?;
        // Temporaries of a killed server or `campaign links` beside the state files.
        for dir in [&spec.state, &demos_dir] {
            crate::atomic::sweep_stale(dir).map_err(io(dir))?;
        }
        let (operator, _) = links::operator_token(&spec.state)?;
        let index: BTreeMap<String, usize> = episodes
            .iter()
            .enumerate()
            .map(|(i, e)| (e.episode_id.clone(), i))
            .collect();
        let order: Vec<String> = selection
            .pool
            .iter()
            .map(|&i| episodes[i].episode_id.clone())
            .collect();
        let tutorial_id = selection.tutorial.map(|i| episodes[i].episode_id.clone());
        let mut books = Books {
            ledger: Ledger::new(order, spec.demos_per_episode, tutorial_id.is_some()),
            demos: Vec::new(),
            live: BTreeMap::new(),
            sessions: BTreeMap::new(),
            feedback: feedback::load_all(&spec.state)?,
        };
        let mut names: Vec<String> = std::fs::read_dir(&demos_dir)
            .map_err(io(&demos_dir))?
            .filter_map(|e| e.ok())
            .filter(|e| e.path().is_dir())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| !n.starts_with('.'))
            .collect();
        names.sort();
        for name in names {
            let Some((participant, n)) = session_of(&name) else {
                continue;
            };
            let dir = demos_dir.join(&name);
            sweep_session(&dir)?;
            let count = books.sessions.entry(participant.to_string()).or_default();
            *count = (*count).max(n);
            let mut qc = SessionQc::load(&dir)?;
            let played = match RunDir::new(&dir).played() {
                p if p.exists() => {
                    crate::episode::format::read_episodes(&p).map_err(|e| CampaignError::File {
                        path: p.clone(),
                        message: crate::escape::error_line(&e),
                    })?
                }
                _ => Vec::new(),
            };
            // Episodes on disk without a record (the server died between the two writes).
            let mut changed = false;
            for e in &played {
                if !qc.demos.iter().any(|d| d.episode_id == e.episode_id) {
                    qc.demos.push(DemoEntry {
                        episode_id: e.episode_id.clone(),
                        participant: participant.to_string(),
                        tutorial: tutorial_id.as_deref() == Some(e.episode_id.as_str()),
                        qc: None,
                        verdict: Verdict {
                            accepted: false,
                            reasons: vec![
                                "quality record lost (the server stopped before writing it)".into(),
                            ],
                        },
                        review: None,
                    });
                    changed = true;
                }
            }
            // Records of episodes not on disk are dropped (cannot happen: records are
            // written after the episode).
            qc.demos
                .retain(|d| played.iter().any(|e| e.episode_id == d.episode_id));
            if changed {
                qc.save(&dir)?;
            }
            for d in &qc.demos {
                if d.tutorial {
                    books.ledger.tutorial_done(participant);
                } else {
                    books
                        .ledger
                        .finished(participant, &d.episode_id, d.verdict.accepted);
                }
                books.demos.push(Demo {
                    session: name.clone(),
                    entry: d.clone(),
                });
            }
        }
        Ok(Campaign {
            spec,
            demos_dir,
            operator,
            index,
            selection,
            books: Mutex::new(books),
            _lock: lock,
        })
    }

    fn books(&self) -> MutexGuard<'_, Books> {
        self.books.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Whether `token` is the operator's (constant time).
    pub fn is_operator(&self, token: &str) -> bool {
        crate::serve::token::same(token, &self.operator)
    }

    /// The participant whose link carries `token` (the participants file is read again, so
    /// links minted while the server runs work).
    pub fn participant(&self, token: &str) -> Result<Option<String>, CampaignError> {
        let all = links::Participants::load(&self.spec.state)?;
        Ok(all.find(token).map(str::to_string))
    }

    /// Opens a session for `participant`: its folder's name (`<participant>-s<NN>`), or
    /// `None` when the participant has a live session already.
    pub fn open_session(&self, participant: &str) -> Option<String> {
        let mut b = self.books();
        if b.live.contains_key(participant) {
            return None;
        }
        let n = b.sessions.entry(participant.to_string()).or_default();
        *n += 1;
        let name = format!("{participant}-s{:02}", *n);
        b.live.insert(participant.to_string(), name.clone());
        Some(name)
    }

    /// The session of `participant` ended: its episode in flight goes back to the pool and
    /// its lock file goes.
    pub fn close_session(&self, participant: &str, name: &str) {
        let mut b = self.books();
        b.ledger.release(participant);
        if b.live.get(participant).map(String::as_str) == Some(name) {
            b.live.remove(participant);
        }
        let _ = std::fs::remove_file(self.demos_dir.join(name).join(crate::lock::LOCK_FILE));
    }

    /// `participant`'s episode in flight was not finished: it goes back to the pool.
    pub fn release(&self, participant: &str) {
        self.books().ledger.release(participant);
    }

    /// The next episode for `participant` (an index into the episode file), reserving it;
    /// `None` when nothing is left for them.
    pub fn assign(&self, participant: &str) -> Option<usize> {
        let a = self.books().ledger.assign(participant);
        self.index_of(&a)
    }

    /// Whether anything is left for `participant`.
    pub fn more_for(&self, participant: &str) -> bool {
        !matches!(self.books().ledger.peek(participant), Assignment::Done)
    }

    fn index_of(&self, a: &Assignment) -> Option<usize> {
        match a {
            Assignment::Tutorial => self.selection.tutorial,
            Assignment::Episode(id) => self.index.get(id).copied(),
            Assignment::Done => None,
        }
    }

    /// `participant` finished `episode` in session `name` (its tables written): computes
    /// the quality record from the metrics and the action times, appends it to the
    /// session's `qc.json` and updates the ledger.
    pub fn finished(
        &self,
        participant: &str,
        name: &str,
        episode: &Episode,
        metrics: &EpisodeMetrics,
        action_times: &[f32],
    ) -> Result<DemoEntry, CampaignError> {
        let tutorial = self
            .selection
            .tutorial
            .is_some_and(|i| self.index.get(&episode.episode_id) == Some(&i));
        let qc = DemoQc::of(&DemoRecord {
            metrics,
            geodesic: episode.geodesic_distance,
            action_times,
        });
        let mut verdict = self.spec.qc.judge(&qc);
        if tutorial {
            verdict = Verdict {
                accepted: false,
                reasons: vec!["tutorial".into()],
            };
        }
        let entry = DemoEntry {
            episode_id: episode.episode_id.clone(),
            participant: participant.to_string(),
            tutorial,
            qc: Some(qc),
            verdict,
            review: None,
        };
        let dir = self.demos_dir.join(name);
        // The books' lock is held across the file's rewrite: a review of the same session
        // rewrites it too.
        let mut b = self.books();
        let mut file = SessionQc::load(&dir)?;
        file.demos.push(entry.clone());
        file.save(&dir)?;
        if tutorial {
            b.ledger.tutorial_done(participant);
        } else {
            b.ledger
                .finished(participant, &episode.episode_id, entry.verdict.accepted);
        }
        b.demos.push(Demo {
            session: name.to_string(),
            entry: entry.clone(),
        });
        Ok(entry)
    }

    /// The operator's review of the demonstration of `episode_id` in session `session`:
    /// accepted or flagged (with `note`), replacing the thresholds' verdict in the session's
    /// `qc.json` and in the ledger (a demonstration accepted by review covers its episode;
    /// one flagged by review gives the episode back to the pool).
    pub fn review(
        &self,
        session: &str,
        episode_id: &str,
        accepted: bool,
        note: &str,
    ) -> Result<DemoEntry, ReviewError> {
        let chars = note.chars().count();
        if chars > MAX_NOTE {
            return Err(ReviewError::NoteTooLong(chars));
        }
        let note: String = note.chars().filter(|c| !c.is_control()).collect();
        let mut b = self.books();
        let no_demo = || ReviewError::NoDemo {
            session: session.to_string(),
            episode_id: episode_id.to_string(),
        };
        // Only a session the books know names a folder: nothing from a request is a path.
        let at = b.demo_at(session, episode_id).ok_or_else(no_demo)?;
        let before = b.demos[at].entry.clone();
        if before.tutorial {
            return Err(ReviewError::Tutorial);
        }
        let after = before.reviewed(accepted, &note);
        let dir = self.demos_dir.join(&b.demos[at].session);
        let mut file = SessionQc::load(&dir)?;
        let slot = file
            .demos
            .iter_mut()
            .find(|d| d.episode_id == episode_id)
            .ok_or_else(no_demo)?;
        *slot = after.clone();
        file.save(&dir)?;
        b.ledger
            .reviewed(episode_id, before.verdict.accepted, after.verdict.accepted);
        b.demos[at].entry = after.clone();
        tracing::info!(
            "operator review: {session} {episode_id} {}",
            if accepted { "accepted" } else { "flagged" }
        );
        Ok(after)
    }

    /// The demonstration of `episode_id` in session `session` and the episode's index in
    /// the episode file; `None` when the books hold no such demonstration.
    pub fn demo(&self, session: &str, episode_id: &str) -> Option<(Demo, usize)> {
        let index = *self.index.get(episode_id)?;
        let b = self.books();
        let at = b.demo_at(session, episode_id)?;
        Some((b.demos[at].clone(), index))
    }

    /// Keeps what `participant` said about the campaign (see [`feedback`]).
    pub fn feedback(&self, participant: &str, said: Feedback) -> Result<(), FeedbackError> {
        said.validate()?;
        let mut b = self.books();
        let list = b.feedback.entry(participant.to_string()).or_default();
        if list.len() >= feedback::MAX_PER_PARTICIPANT {
            return Err(FeedbackError::TooMany);
        }
        let mut all = list.clone();
        all.push(said);
        feedback::save(&self.spec.state, participant, &all)?;
        *list = all;
        Ok(())
    }

    /// The campaign's progress for the operator: episodes covered, demonstrations per
    /// episode, live sessions, every demonstration's quality record.
    pub fn status(&self) -> serde_json::Value {
        let b = self.books();
        let k = b.ledger.k();
        let tallies = b.ledger.tallies();
        let covered = tallies.iter().filter(|(_, t)| t.accepted >= k).count();
        let episodes: Vec<_> = tallies
            .iter()
            .map(|(id, t)| serde_json::json!({"episode_id": id, "accepted": t.accepted, "flagged": t.flagged, "in_flight": t.in_flight}))
            .collect();
        let live: Vec<_> = b
            .live
            .iter()
            .map(|(p, s)| serde_json::json!({"participant": p, "session": s}))
            .collect();
        let feedback: Vec<_> = b
            .feedback
            .iter()
            .flat_map(|(p, list)| {
                list.iter().map(move |f| {
                    serde_json::json!({"participant": p, "rating": f.rating, "comment": f.comment})
                })
            })
            .collect();
        serde_json::json!({
            "campaign": self.spec.file.file_name().map(|n| n.to_string_lossy().into_owned()),
            "feedback": feedback,
            "demos_per_episode": k,
            "episodes_total": tallies.len(),
            "episodes_covered": covered,
            "demos_accepted": b.demos.iter().filter(|d| d.entry.verdict.accepted).count(),
            "demos_flagged": b.demos.iter().filter(|d| !d.entry.verdict.accepted && !d.entry.tutorial).count(),
            "episodes": episodes,
            "live": live,
            "demos": b.demos,
        })
    }
}

/// `(participant, n)` of a session folder named `<participant>-s<NN>`.
fn session_of(name: &str) -> Option<(&str, u32)> {
    let (p, n) = name.rsplit_once("-s")?;
    let n: u32 = n.parse().ok()?;
    (!p.is_empty()).then_some((p, n))
}

/// Where a campaign session stands, shared by the session thread.
#[derive(Debug, Clone)]
pub struct Seat {
    /// The campaign.
    pub campaign: std::sync::Arc<Campaign>,
    /// The participant.
    pub participant: String,
}

impl PartialEq for Seat {
    fn eq(&self, other: &Self) -> bool {
        std::sync::Arc::ptr_eq(&self.campaign, &other.campaign)
            && self.participant == other.participant
    }
}

/// The session folders of a campaign's state folder `state` (sorted), for export.
pub fn session_folders(state: &Path) -> Result<Vec<PathBuf>, CampaignError> {
    let demos = state.join(DEMOS);
    let mut out: Vec<PathBuf> = std::fs::read_dir(&demos)
        .map_err(io(&demos))?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_dir())
        .filter(|e| session_of(&e.file_name().to_string_lossy()).is_some())
        .map(|e| e.path())
        .collect();
    out.sort();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn session_names_parse() {
        assert_eq!(session_of("p0001-s03"), Some(("p0001", 3)));
        assert_eq!(session_of("p-1-s12"), Some(("p-1", 12)));
        assert_eq!(session_of("session-1-abc"), None);
        assert_eq!(session_of("-s1"), None);
    }
}
