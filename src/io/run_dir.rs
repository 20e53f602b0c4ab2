//! A run folder — what `minos run`, `minos merge` and a `minos serve` session write — behind
//! one type, [`RunDir`], which owns every name of its layout, and [`RunManifest`], its
//! `manifest.json` read back (the agent's step, the configuration a LeRobot copy records).
//!
//! ```text
//! RUN/manifest.json          what the run was (its provenance record), written last
//! RUN/trajectories.parquet   one row per step
//! RUN/observations.parquet   the cameras' images, each episode in row groups of its own
//! RUN/episodes.parquet       one row per finished episode with its metrics
//! RUN/metrics.json           aggregates, each episode's metrics, the failures
//! RUN/lerobot/               the LeRobot v3.0 copy (`--format lerobot`)
//! RUN/played.parquet         a live run's (a session's) finished episodes, in the order played
//! RUN/qc.json                a campaign session's quality records
//! RUN/.parts/                an unfinished run's part files, and run.json, what the run is
//! ```

use std::path::{Path, PathBuf};

use serde_json::Value;

/// `manifest.json`: the run's provenance record, written last.
pub const MANIFEST: &str = "manifest.json";
/// `trajectories.parquet`: one row per step.
pub const TRAJECTORIES: &str = "trajectories.parquet";
/// `observations.parquet`: the cameras' images per step.
pub const OBSERVATIONS: &str = "observations.parquet";
/// `episodes.parquet`: one row per finished episode with its metrics.
pub const EPISODES: &str = "episodes.parquet";
/// `metrics.json`: aggregates, each episode's metrics and the failures.
pub const METRICS: &str = "metrics.json";
/// `lerobot/`: the run's LeRobot copy.
pub const LEROBOT: &str = "lerobot";
/// `played.parquet`: the episode file of a live run's finished episodes, in the order played.
pub const PLAYED: &str = "played.parquet";
/// `qc.json`: a campaign session's quality records.
pub const QC: &str = "qc.json";
/// `.parts/`: an unfinished run's part files.
pub const PARTS: &str = ".parts";
/// `.parts/run.json`: what an unfinished run is (so that running it again continues it only
/// when it is the same run).
pub const UNFINISHED_RECORD: &str = "run.json";

/// One of an episode's part files in `RUN/.parts/`, named `<index:06>.<extension>`: the
/// files an unfinished run keeps per episode, the metrics last (an episode whose metrics
/// part exists is finished).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PartFile {
    /// `<index>.traj.parquet`: the episode's trajectory rows.
    Trajectory,
    /// `<index>.obs.parquet`: its observations.
    Observations,
    /// `<index>.rrd`: its rerun recording, when recorded.
    Recording,
    /// `<index>.episode.parquet`: the episode itself (a live run's, whose episodes are not
    /// known in advance).
    Episode,
    /// `<index>.json`: its metrics, written last.
    Metrics,
}

impl PartFile {
    /// The file name's extension (after `<index>.`).
    pub const fn extension(self) -> &'static str {
        match self {
            PartFile::Trajectory => "traj.parquet",
            PartFile::Observations => "obs.parquet",
            PartFile::Recording => "rrd",
            PartFile::Episode => "episode.parquet",
            PartFile::Metrics => "json",
        }
    }

    /// The part file of episode `index` in the part folder `parts` (`RUN/.parts/`).
    pub fn of(self, parts: &Path, index: usize) -> PathBuf {
        parts.join(format!("{index:06}.{}", self.extension()))
    }

    /// The episode index of a part file's name, when it is a part of this kind.
    pub fn index_of(self, file_name: &str) -> Option<usize> {
        let stem = file_name
            .strip_suffix(self.extension())?
            .strip_suffix('.')?;
        (!stem.is_empty() && stem.bytes().all(|b| b.is_ascii_digit()))
            .then(|| stem.parse().ok())
            .flatten()
    }
}

/// A run folder (nothing is read or created by naming one).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RunDir {
    root: PathBuf,
}

impl RunDir {
    /// The run folder at `root`.
    pub fn new(root: impl Into<PathBuf>) -> Self {
        RunDir { root: root.into() }
    }

    /// The folder itself.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// `RUN/manifest.json`.
    pub fn manifest(&self) -> PathBuf {
        self.root.join(MANIFEST)
    }

    /// `RUN/trajectories.parquet`.
    pub fn trajectories(&self) -> PathBuf {
        self.root.join(TRAJECTORIES)
    }

    /// `RUN/observations.parquet`.
    pub fn observations(&self) -> PathBuf {
        self.root.join(OBSERVATIONS)
    }

    /// `RUN/episodes.parquet`.
    pub fn episodes(&self) -> PathBuf {
        self.root.join(EPISODES)
    }

    /// `RUN/metrics.json`.
    pub fn metrics(&self) -> PathBuf {
        self.root.join(METRICS)
    }

    /// `RUN/lerobot/`.
    pub fn lerobot(&self) -> PathBuf {
        self.root.join(LEROBOT)
    }

    /// `RUN/played.parquet`.
    pub fn played(&self) -> PathBuf {
        self.root.join(PLAYED)
    }

    /// `RUN/qc.json`.
    pub fn qc(&self) -> PathBuf {
        self.root.join(QC)
    }

    /// `RUN/.parts/`.
    pub fn parts(&self) -> PathBuf {
        self.root.join(PARTS)
    }

    /// `RUN/.parts/run.json`.
    pub fn unfinished_record(&self) -> PathBuf {
        self.parts().join(UNFINISHED_RECORD)
    }

    /// Whether the folder holds a finished run: its manifest (written last) and trajectory
    /// table are there.
    pub fn is_run(&self) -> bool {
        self.manifest().is_file() && self.trajectories().exists()
    }

    /// Reads `RUN/manifest.json` (a JSON value; its fields are checked when asked for).
    pub fn read_manifest(&self) -> Result<RunManifest, RunManifestError> {
        let path = self.manifest();
        let bytes = match std::fs::read(&path) {
            Ok(bytes) => bytes,
            Err(source) => return Err(RunManifestError::Read { path, source }),
        };
        match serde_json::from_slice(&bytes) {
            Ok(value) => Ok(RunManifest { path, value }),
            Err(source) => Err(RunManifestError::Json { path, source }),
        }
    }
}

/// A run's `manifest.json`, read (or about to be written: [`RunManifest::new`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RunManifest {
    path: PathBuf,
    value: Value,
}

/// Why a run's manifest could not be read, or lacks what was asked of it. The message names
/// the file, and the field and what is wrong with it.
#[derive(Debug, thiserror::Error)]
pub enum RunManifestError {
    /// The file could not be read (a run that did not finish has none: it is written last).
    #[error("{}: cannot read the run's manifest", path.display())]
    Read {
        /// The manifest.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The file is not JSON.
    #[error("{}: not JSON", path.display())]
    Json {
        /// The manifest.
        path: PathBuf,
        /// Why.
        #[source]
        source: serde_json::Error,
    },
    /// A field is missing or has a value it cannot have.
    #[error("{}: {field}: {problem}", path.display())]
    Field {
        /// The manifest.
        path: PathBuf,
        /// The field, dotted (`body.dt`).
        field: &'static str,
        /// What is wrong.
        problem: &'static str,
    },
}

impl RunManifestError {
    /// The manifest the error is about.
    pub fn path(&self) -> &Path {
        match self {
            RunManifestError::Read { path, .. }
            | RunManifestError::Json { path, .. }
            | RunManifestError::Field { path, .. } => path,
        }
    }
}

/// Keys a LeRobot copy's record of the run leaves out (see [`RunManifest::configuration`]).
const NOT_CONFIGURATION: [&str; 3] = ["command", "rerun", "files"];

impl RunManifest {
    /// The manifest `value` of the file `path` (a run's, before it is written).
    pub fn new(path: impl Into<PathBuf>, value: Value) -> Self {
        RunManifest {
            path: path.into(),
            value,
        }
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The JSON value.
    pub fn value(&self) -> &Value {
        &self.value
    }

    /// The JSON value, owned.
    pub fn into_value(self) -> Value {
        self.value
    }

    /// The agent's time step in seconds (`body.dt`): a positive, finite number.
    pub fn step(&self) -> Result<f32, RunManifestError> {
        const FIELD: &str = "body.dt";
        let Some(dt) = self.value.pointer("/body/dt") else {
            return Err(self.field_error(FIELD, "missing"));
        };
        dt.as_f64()
            .filter(|dt| dt.is_finite() && *dt > 0.0)
            .map(|dt| dt as f32)
            .ok_or_else(|| self.field_error(FIELD, "not a positive number"))
    }

    /// The run configuration a LeRobot copy records: the manifest without `command`,
    /// `rerun` and `files` (a run's shards merged give the same dataset, and the same record,
    /// as the unsharded run; the command stays in the run folder's `manifest.json`).
    pub fn configuration(&self) -> Value {
        let mut m = self.value.clone();
        if let Some(map) = m.as_object_mut() {
            for key in NOT_CONFIGURATION {
                map.remove(key);
            }
        }
        m
    }

    fn field_error(&self, field: &'static str, problem: &'static str) -> RunManifestError {
        RunManifestError::Field {
            path: self.path.clone(),
            field,
            problem,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn part_files_are_named_by_index_and_kind_and_read_back() {
        let parts = Path::new("RUN/.parts");
        assert_eq!(
            PartFile::Trajectory.of(parts, 7),
            Path::new("RUN/.parts/000007.traj.parquet")
        );
        assert_eq!(
            PartFile::Metrics.of(parts, 12),
            Path::new("RUN/.parts/000012.json")
        );
        for kind in [
            PartFile::Trajectory,
            PartFile::Observations,
            PartFile::Recording,
            PartFile::Episode,
            PartFile::Metrics,
        ] {
            let name = kind.of(parts, 42);
            let name = name.file_name().and_then(|n| n.to_str()).expect("a name");
            assert_eq!(kind.index_of(name), Some(42), "{name}");
        }
        // `000003.traj.parquet` is not a metrics part, nor `.json` or `x.json`.
        assert_eq!(PartFile::Metrics.index_of("000003.traj.parquet"), None);
        assert_eq!(PartFile::Metrics.index_of(".json"), None);
        assert_eq!(PartFile::Metrics.index_of("x.json"), None);
        assert_eq!(PartFile::Trajectory.index_of("000003.obs.parquet"), None);
    }

    #[test]
    fn every_path_is_under_the_root() {
        let run = RunDir::new("out/run");
        assert_eq!(run.manifest(), Path::new("out/run/manifest.json"));
        assert_eq!(
            run.trajectories(),
            Path::new("out/run/trajectories.parquet")
        );
        assert_eq!(
            run.observations(),
            Path::new("out/run/observations.parquet")
        );
        assert_eq!(run.episodes(), Path::new("out/run/episodes.parquet"));
        assert_eq!(run.metrics(), Path::new("out/run/metrics.json"));
        assert_eq!(run.lerobot(), Path::new("out/run/lerobot"));
        assert_eq!(run.played(), Path::new("out/run/played.parquet"));
        assert_eq!(run.qc(), Path::new("out/run/qc.json"));
        assert_eq!(
            run.unfinished_record(),
            Path::new("out/run/.parts/run.json")
        );
    }

    #[test]
    fn the_step_is_read_from_the_manifest_and_refused_unless_positive() {
        let dir = tempfile::tempdir().expect("tempdir");
        let run = RunDir::new(dir.path());
        let manifest = run.manifest();
        let e = run.read_manifest().expect_err("no manifest");
        assert!(matches!(e, RunManifestError::Read { .. }), "{e}");
        assert_eq!(
            e.to_string(),
            format!("{}: cannot read the run's manifest", manifest.display())
        );
        std::fs::write(&manifest, "{").expect("write");
        let e = run.read_manifest().expect_err("not JSON");
        assert_eq!(e.to_string(), format!("{}: not JSON", manifest.display()));
        assert_eq!(e.path(), manifest);
        let step = |text: &str| {
            std::fs::write(&manifest, text).expect("write");
            run.read_manifest().expect("JSON").step()
        };
        assert_eq!(step(r#"{"body": {"dt": 0.1}}"#).expect("positive"), 0.1);
        for (text, problem) in [
            (r#"{"body": {"dt": -1}}"#, "not a positive number"),
            (r#"{"body": {"dt": 0}}"#, "not a positive number"),
            (r#"{"body": {"dt": "0.1"}}"#, "not a positive number"),
            (r#"{"body": {}}"#, "missing"),
            ("[]", "missing"),
        ] {
            let e = step(text).expect_err(text);
            assert!(
                matches!(e, RunManifestError::Field { field: "body.dt", problem: p, .. } if p == problem),
                "{text}: {e}"
            );
            assert_eq!(
                e.to_string(),
                format!("{}: body.dt: {problem}", manifest.display())
            );
        }
    }

    #[test]
    fn the_configuration_leaves_out_what_differs_between_shards_or_copies() {
        let m = RunManifest::new(
            "m.json",
            serde_json::json!({"seed": 3, "command": ["minos"], "rerun": "r.rrd", "files": {}}),
        );
        assert_eq!(m.configuration(), serde_json::json!({"seed": 3}));
        assert_eq!(m.value()["seed"], 3);
    }
}
