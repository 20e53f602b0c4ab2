//! The campaign file (TOML) of `minos serve --campaign FILE`: which episodes, how many
//! demonstrations of each, the tutorial, the instructions, the agent and the quality
//! thresholds. Paths in it are relative to the file. See `docs/FORMATS.md`.

use crate::file_error::FileError;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::CampaignError;
use crate::body::AgentPreset;
use crate::episode::{Episode, Task};
use crate::run::qc::QcThresholds;

/// The file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Raw {
    episodes: PathBuf,
    split: Option<String>,
    task: Option<String>,
    demos_per_episode: u32,
    tutorial: Option<String>,
    #[serde(default)]
    instructions: String,
    state: Option<PathBuf>,
    preset: Option<String>,
    sensors: Option<PathBuf>,
    size: Option<u32>,
    #[serde(default)]
    qc: QcThresholds,
}

/// A campaign, read and checked.
#[derive(Debug, Clone, PartialEq)]
pub struct CampaignSpec {
    /// The campaign file.
    pub file: PathBuf,
    /// The episode file (from `minos episodes`).
    pub episodes: PathBuf,
    /// Only episodes of this split subset (`train`, `val`, …).
    pub split: Option<String>,
    /// Only episodes of this task.
    pub task: Option<Task>,
    /// Accepted demonstrations wanted of each episode.
    pub demos_per_episode: u32,
    /// The episode every participant plays first (by id, from the episode file; it is not
    /// one of the campaign's episodes and its demonstrations are never exported).
    pub tutorial: Option<String>,
    /// What participants read before the tutorial.
    pub instructions: String,
    /// The campaign's state folder: participants, the operator token, the sessions.
    pub state: PathBuf,
    /// The agent preset (else the command line's).
    pub preset: Option<AgentPreset>,
    /// A sensor suite's name or a sensor file (else the command line's): what `--sensors`
    /// takes ([`crate::sim::SensorSuite::from_spec`]).
    pub sensors: Option<PathBuf>,
    /// Image size of the default sensors (else the command line's).
    pub size: Option<u32>,
    /// Quality thresholds.
    pub qc: QcThresholds,
}

/// The campaign's episodes among those of the episode file.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// Indices of the campaign's episodes, in file order.
    pub pool: Vec<usize>,
    /// Index of the tutorial episode.
    pub tutorial: Option<usize>,
}

impl CampaignSpec {
    /// Reads the campaign file `path`.
    pub fn read(path: &Path) -> Result<CampaignSpec, CampaignError> {
        let text = std::fs::read_to_string(path)
            .map_err(|source| CampaignError::Io(FileError::new(path, source)))?;
        Self::parse(&text, path)
    }

    /// Parses the text of the campaign file `path` (paths in it are relative to its folder).
    pub fn parse(text: &str, path: &Path) -> Result<CampaignSpec, CampaignError> {
        let bad = |message: String| CampaignError::File {
            path: path.to_path_buf(),
            message: crate::escape::escape_controls(&message),
        };
        let raw: Raw = toml::from_str(text).map_err(|e| {
            bad(e
                .to_string()
                .lines()
                .filter(|l| !l.trim().is_empty())
                .collect::<Vec<_>>()
                .join(" "))
        })?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let rel = |p: &Path| {
            if p.is_absolute() {
                p.to_path_buf()
            } else {
                dir.join(p)
            }
        };
        if raw.demos_per_episode == 0 {
            return Err(bad("demos_per_episode: must be at least 1".into()));
        }
        let task = match &raw.task {
            None => None,
            Some(t) => Some(
                <Task as crate::vocab::Vocabulary>::parse_name(t)
                    .map_err(|e| bad(format!("task: {e}")))?,
            ),
        };
        let preset = match &raw.preset {
            None => None,
            Some(p) => Some(
                AgentPreset::ALL
                    .into_iter()
                    .find(|k| k.name() == p.as_str())
                    .ok_or_else(|| {
                        // Exact names only (not the CLI's old spelling `minos-continuous`).
                        bad(format!(
                            "preset: `{p}` is not one of {}",
                            <AgentPreset as crate::vocab::Vocabulary>::names().join(", ")
                        ))
                    })?,
            ),
        };
        if let Some(size) = raw.size {
            if !(8..=2048).contains(&size) {
                return Err(bad(format!("size: {size} is not between 8 and 2048")));
            }
        }
        raw.qc.validate().map_err(|e| bad(e.to_string()))?;
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "campaign".into());
        Ok(CampaignSpec {
            file: path.to_path_buf(),
            episodes: rel(&raw.episodes),
            split: raw.split.filter(|s| !s.is_empty()),
            task,
            demos_per_episode: raw.demos_per_episode,
            tutorial: raw.tutorial.filter(|t| !t.is_empty()),
            instructions: raw.instructions,
            state: raw
                .state
                .as_deref()
                .map(rel)
                .unwrap_or_else(|| dir.join(format!("{stem}.state"))),
            preset,
            // A suite's name stays a name; a file is beside the campaign file.
            sensors: raw.sensors.as_deref().map(|s| {
                if crate::sim::SuiteName::of_spec(s).is_some() {
                    s.to_path_buf()
                } else {
                    rel(s)
                }
            }),
            size: raw.size,
            qc: raw.qc,
        })
    }

    /// The campaign's episodes (split and task filters) and the tutorial among `episodes`
    /// (the episode file's, in order); an error when none is left or the tutorial is missing.
    pub fn select(&self, episodes: &[Episode]) -> Result<Selection, CampaignError> {
        let bad = |message: String| CampaignError::File {
            path: self.file.clone(),
            message,
        };
        let tutorial = match &self.tutorial {
            None => None,
            Some(id) => Some(
                episodes
                    .iter()
                    .position(|e| &e.episode_id == id)
                    .ok_or_else(|| {
                        bad(format!(
                            "tutorial: no episode `{}` in {}",
                            crate::escape::escape_controls(id),
                            self.episodes.display()
                        ))
                    })?,
            ),
        };
        let pool: Vec<usize> = episodes
            .iter()
            .enumerate()
            .filter(|(i, e)| {
                Some(*i) != tutorial
                    && self.split.as_ref().is_none_or(|s| &e.split == s)
                    && self.task.is_none_or(|t| e.task == t)
            })
            .map(|(i, _)| i)
            .collect();
        if pool.is_empty() {
            return Err(bad(format!(
                "episodes: no episode of {} is left after the split and task filters",
                self.episodes.display()
            )));
        }
        Ok(Selection { pool, tutorial })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<CampaignSpec, CampaignError> {
        CampaignSpec::parse(text, Path::new("/c/study.toml"))
    }

    #[test]
    fn a_campaign_file_reads_with_paths_beside_it() {
        let c = parse(
            r#"
            episodes = "eps/object.parquet"
            split = "val"
            task = "objectgoal"
            demos_per_episode = 3
            tutorial = "h:pointgoal:00000"
            instructions = "Find the object, then press Space."
            preset = "minos"
            size = 128
            [qc]
            max_path_ratio = 3.0
            max_idle_seconds = 30
            "#,
        )
        .expect("valid");
        assert_eq!(c.episodes, Path::new("/c/eps/object.parquet"));
        assert_eq!(c.state, Path::new("/c/study.state"));
        assert_eq!(c.task, Some(Task::ObjectGoal));
        assert_eq!(c.preset, Some(AgentPreset::Minos));
        assert_eq!(c.demos_per_episode, 3);
        assert!(c.qc.require_success);
        assert_eq!(c.qc.max_path_ratio, Some(3.0));
        assert_eq!(c.qc.max_idle_seconds, Some(30.0));
        assert_eq!(c.sensors, None);
        // Sensors: a suite's name as given, a file beside the campaign file.
        let sensors = |value: &str| {
            parse(&format!(
                "episodes = \"e.parquet\"\ndemos_per_episode = 1\nsensors = \"{value}\"\n"
            ))
            .expect("valid")
            .sensors
        };
        assert_eq!(sensors("minos-paper"), Some(PathBuf::from("minos-paper")));
        assert_eq!(sensors("s.toml"), Some(PathBuf::from("/c/s.toml")));
    }

    #[test]
    fn nonsense_is_refused_with_the_file_and_field() {
        for (text, what) in [
            (
                "episodes = \"e\"\ndemos_per_episode = 0",
                "demos_per_episode",
            ),
            (
                "episodes = \"e\"\ndemos_per_episode = 1\ntask = \"fly\"",
                "task",
            ),
            (
                "episodes = \"e\"\ndemos_per_episode = 1\npreset = \"x\"",
                "preset",
            ),
            ("episodes = \"e\"\ndemos_per_episode = 1\nsize = 0", "size"),
            (
                "episodes = \"e\"\ndemos_per_episode = 1\nspeed = 3",
                "speed",
            ),
            ("demos_per_episode = 1", "episodes"),
            (
                "episodes = \"e\"\ndemos_per_episode = 1\n[qc]\nmax_collisions = -1",
                "max_collisions",
            ),
        ] {
            let e = parse(text).expect_err(text).to_string();
            assert!(e.starts_with("/c/study.toml: "), "{e}");
            assert!(e.contains(what), "{what}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
