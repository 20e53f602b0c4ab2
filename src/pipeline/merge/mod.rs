//! `minos merge`: joining the outputs of a sharded command into exactly the files one
//! unsharded run writes. Shards split a sorted list (scenes for `episodes`, episode ids for
//! `run`) and every random choice is seeded by its item, never by its position in a shard, so
//! the union of the shards' rows, put back in the list's order, is the unsharded output.
//!
//! - `episodes`: episode files (`minos episodes --shard i/n --out part.parquet`) and their
//!   `.stats.json`;
//! - [`run`]: run folders (`minos run --shard i/n --out DIR`): the three tables,
//!   `metrics.json`, `manifest.json`, the rerun recording and the LeRobot copy.
//!
//! Both check that the inputs are the shards `0/n … n−1/n` of one job, each once;
//! [`MergeJob`] tells which of the two a list of shards asks for.

internal! {
    pub mod episodes;
}
pub mod run;

use crate::file_error::FileError;
use std::path::{Path, PathBuf};

use crate::lock::LockError;
use crate::progress::Progress;
use crate::shard::Shard;
use run::RunMerge;

/// Why shards could not be merged (each message names the file and what is wrong).
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    /// The inputs are not the shards of one job, or one of them is incomplete: what is
    /// wrong, naming the file.
    #[error("{0}")]
    Shards(String),
    /// A shard's file could not be read.
    #[error("{0}")]
    ShardIo(#[source] FileError),
    /// An episode file's statistics (`<file>.stats.json`) could not be read.
    #[error(
        "{}: each episode file needs the statistics `minos episodes` writes beside it",
        path.display()
    )]
    NoStats {
        /// The statistics file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A shard's JSON file (manifest, metrics, statistics) is not valid JSON.
    #[error("{}", path.display())]
    ShardJson {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: serde_json::Error,
    },
    /// A shard's manifest lacks what the merge needs (the message names the file and field).
    #[error(transparent)]
    ShardManifest(crate::io::run_dir::RunManifestError),
    /// A shard's episode file could not be read (the message names it).
    #[error(transparent)]
    ShardEpisodes(crate::episode::format::EpisodeFileError),
    /// A file or folder of the merged output could not be written.
    #[error("{0}")]
    WriteIo(#[source] FileError),
    /// The shards' rows could not be joined.
    #[error("joining the shards' rows")]
    Join(#[source] arrow::error::ArrowError),
    /// The merged run's metrics, checksums or LeRobot copy could not be written (the message
    /// names the file).
    #[error(transparent)]
    WriteRun(Box<crate::pipeline::rollout::RolloutError>),
    /// The merged recording could not be written.
    #[error(transparent)]
    WriteRecording(#[from] crate::io::rrd::RecordingError),
    /// A shard's rerun recording could not be read.
    #[error(transparent)]
    ShardRecording(crate::io::rrd::RecordingError),
    /// The merged episode file could not be written.
    #[error(transparent)]
    WriteEpisodes(crate::pipeline::episodes::BatchWriteError),
    /// A shard's table could not be read (the message names it).
    #[error(transparent)]
    ShardTable(crate::io::tables::TableError),
    /// A merged table could not be written (the message names it).
    #[error(transparent)]
    WriteTable(crate::io::tables::TableError),
    /// Another process writes the output folder.
    #[error("the output folder's lock")]
    Lock(#[from] LockError),
    /// A shard has no manifest: it did not finish (a run writes its manifest last).
    #[error("{}: unfinished shard (a run writes its manifest last)", manifest.display())]
    Unfinished {
        /// The manifest that could not be read.
        manifest: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The shards recorded episodes for rerun, but no file was named for the merged
    /// recording.
    #[error("{}: the shards recorded episodes for rerun: name a file for the merged recording", manifest.display())]
    RecordingUnnamed {
        /// The first shard's manifest, which says so.
        manifest: PathBuf,
    },
    /// A shard path names nothing.
    #[error("{}: no such shard", path.display())]
    NoSuchShard {
        /// The path.
        path: PathBuf,
    },
    /// Some shards are run folders and some episode files.
    #[error("shards must all be run folders or all episode files, not a mix")]
    MixedShards,
    /// A merged recording was asked of episode files, which have none.
    #[error("{}: episode files have no recordings (a recording merges with run folders)", file.display())]
    NoRecordingOfEpisodes {
        /// The file named for the recording.
        file: PathBuf,
    },
    /// A file was named for the merged recording, but the shards recorded nothing.
    #[error("{}: the shards recorded nothing for rerun", file.display())]
    NothingRecorded {
        /// The file named.
        file: PathBuf,
    },
}

/// One merge: run folders, or episode files.
#[derive(Debug, Clone)]
pub enum MergeJob {
    /// Join run folders.
    Runs {
        /// The shards' folders.
        shards: Vec<PathBuf>,
        /// Output and options.
        merge: RunMerge,
    },
    /// Join episode files.
    Episodes {
        /// The shards' episode files.
        shards: Vec<PathBuf>,
        /// The merged episode file.
        out: PathBuf,
    },
}

impl MergeJob {
    /// The merge of `shards` into `merge.out`: of run folders when every shard is a folder,
    /// of episode files when every one is a file (which have no recording, so
    /// `merge.rerun` must be `None`); a missing shard, or a mix, is refused.
    pub fn of_shards(shards: Vec<PathBuf>, merge: RunMerge) -> Result<MergeJob, MergeError> {
        if let Some(missing) = shards.iter().find(|p| !p.exists()) {
            return Err(MergeError::NoSuchShard {
                path: missing.clone(),
            });
        }
        if shards.iter().all(|p| p.is_dir()) {
            Ok(MergeJob::Runs { shards, merge })
        } else if shards.iter().all(|p| p.is_file()) {
            if let Some(file) = merge.rerun {
                return Err(MergeError::NoRecordingOfEpisodes { file });
            }
            Ok(MergeJob::Episodes {
                shards,
                out: merge.out,
            })
        } else {
            Err(MergeError::MixedShards)
        }
    }

    /// Runs the merge ([`run::merge_runs`] or `episodes::merge_episodes`).
    pub fn run(&self, progress: &dyn Progress) -> Result<MergeReport, MergeError> {
        match self {
            MergeJob::Runs { shards, merge } => run::merge_runs(shards, merge, progress),
            MergeJob::Episodes { shards, out } => episodes::merge_episodes(shards, out, progress),
        }
    }
}

/// What a merge joined.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct MergeReport {
    /// Shards joined.
    pub shards: usize,
    /// Episodes in the merged output.
    pub episodes: usize,
    /// Episodes that failed in their shard (listed in the merged `metrics.json`).
    pub failures: usize,
    /// Episodes in the merged rerun recording.
    pub recorded: usize,
    /// Files written.
    pub written: Vec<PathBuf>,
}

/// Checks that `found` (each input with the shard it says it is) are the shards `0/n … n−1/n`
/// of one job, each exactly once.
pub fn check_shards(found: &[(PathBuf, Shard)]) -> Result<(), MergeError> {
    let Some((first_path, first)) = found.first() else {
        return Err(MergeError::Shards("no shards to merge".into()));
    };
    let n = first.count;
    let mut seen: Vec<Option<&Path>> = vec![None; n];
    for (path, s) in found {
        if s.count != n {
            return Err(MergeError::Shards(format!(
                "{}: shard {s}, but {} is shard {first}: shards of different splits",
                path.display(),
                first_path.display()
            )));
        }
        if let Some(other) = seen[s.index] {
            return Err(MergeError::Shards(format!(
                "{}: shard {s} is given twice (also {})",
                path.display(),
                other.display()
            )));
        }
        seen[s.index] = Some(path);
    }
    let missing: Vec<String> = seen
        .iter()
        .enumerate()
        .filter(|(_, p)| p.is_none())
        .map(|(i, _)| format!("{i}/{n}"))
        .collect();
    if !missing.is_empty() {
        return Err(MergeError::Shards(format!(
            "shard{} {} missing: a merge needs all {n} shards",
            if missing.len() > 1 { "s" } else { "" },
            missing.join(", ")
        )));
    }
    Ok(())
}

/// Parses the `shard` an output records (`i/n`).
fn recorded_shard(path: &Path, value: Option<&str>) -> Result<Shard, MergeError> {
    let v = value.ok_or_else(|| {
        MergeError::Shards(format!(
            "{}: no `shard` recorded (written by an older minos?)",
            path.display()
        ))
    })?;
    Shard::parse(v).map_err(|e| {
        MergeError::Shards(format!(
            "{}: shard {}",
            path.display(),
            crate::escape::error_line(&e)
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_merge_is_of_run_folders_or_of_episode_files_never_both() {
        let d = tempfile::tempdir().unwrap();
        let (a, b) = (d.path().join("a"), d.path().join("b"));
        std::fs::create_dir(&a).unwrap();
        std::fs::create_dir(&b).unwrap();
        let f = d.path().join("part.parquet");
        std::fs::write(&f, b"x").unwrap();
        let merge = |rerun: Option<&str>| RunMerge {
            out: d.path().join("out"),
            rerun: rerun.map(PathBuf::from),
            command: Vec::new(),
            lock: Default::default(),
        };
        let job = MergeJob::of_shards(vec![a.clone(), b.clone()], merge(Some("r.rrd"))).unwrap();
        assert!(
            matches!(job, MergeJob::Runs { ref shards, .. } if shards == &[a.clone(), b.clone()])
        );
        let job = MergeJob::of_shards(vec![f.clone()], merge(None)).unwrap();
        assert!(matches!(job, MergeJob::Episodes { ref out, .. } if out == &d.path().join("out")));
        let e = MergeJob::of_shards(vec![f.clone()], merge(Some("r.rrd"))).unwrap_err();
        assert!(
            matches!(e, MergeError::NoRecordingOfEpisodes { ref file } if file == Path::new("r.rrd"))
        );
        let e = MergeJob::of_shards(vec![a.clone(), f.clone()], merge(None)).unwrap_err();
        assert!(matches!(e, MergeError::MixedShards), "{e}");
        let gone = d.path().join("gone");
        let e = MergeJob::of_shards(vec![a, gone.clone()], merge(None)).unwrap_err();
        assert_eq!(e.to_string(), format!("{}: no such shard", gone.display()));
    }

    fn shards(list: &[&str]) -> Vec<(PathBuf, Shard)> {
        list.iter()
            .enumerate()
            .map(|(i, s)| (PathBuf::from(format!("in{i}")), Shard::parse(s).unwrap()))
            .collect()
    }

    #[test]
    fn shards_must_make_a_whole() {
        assert!(check_shards(&shards(&["1/3", "0/3", "2/3"])).is_ok());
        assert!(check_shards(&shards(&["0/1"])).is_ok());
        let twice = check_shards(&shards(&["0/2", "0/2"]))
            .unwrap_err()
            .to_string();
        assert!(
            twice.contains("in1: shard 0/2 is given twice (also in0)"),
            "{twice}"
        );
        let missing = check_shards(&shards(&["0/4", "2/4"]))
            .unwrap_err()
            .to_string();
        assert!(missing.contains("shards 1/4, 3/4 missing"), "{missing}");
        let mixed = check_shards(&shards(&["0/2", "1/3"]))
            .unwrap_err()
            .to_string();
        assert!(
            mixed.contains("in1: shard 1/3, but in0 is shard 0/2"),
            "{mixed}"
        );
        assert!(check_shards(&[]).is_err());
    }
}
