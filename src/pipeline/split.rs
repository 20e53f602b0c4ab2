//! Making a split of a DATA folder: read its manifest, take the folder's writer lock, divide
//! the scenes (by lists or by seeded ratios, after the filter) and write
//! `DATA/splits/<name>/{train,val,test}.txt` with the folder's provenance record. The one
//! driver `minos split` and Python's `minos.split` call.

use std::path::PathBuf;

use crate::lock::{LockError, LockMode};
use crate::split::{
    read_split, resolve_lists, split_by_lists, split_by_ratios, split_dir, write_split, Expr,
    Ratios, SplitError, SplitLists, SplitResult,
};
use crate::store::{DataDir, StoreError};

/// How the scenes are divided.
#[derive(Debug, Clone, PartialEq)]
pub enum Method {
    /// Lists read from a folder of `train.txt`, `val.txt` and `test.txt`, or built-in
    /// official lists named by the path (`mp3d`, `suncg-multiroom`; a folder of that name
    /// wins).
    ListsFrom(PathBuf),
    /// Lists given in memory.
    Lists(SplitLists),
    /// Seeded fractions: each id placed by its own hash under the seed.
    Ratios(Ratios, u64),
}

/// A split to make.
#[derive(Debug, Clone)]
pub struct SplitJob {
    /// The DATA folder.
    pub data: DataDir,
    /// The split's name: its lists go to `DATA/splits/<name>/`.
    pub name: String,
    /// Keep only the scenes the expression is true for.
    pub filter: Option<Expr>,
    /// Lists or ratios.
    pub method: Method,
}

/// What a split did.
#[derive(Debug, Clone)]
pub struct SplitReport {
    /// The lists written and what was left out of them.
    pub result: SplitResult,
    /// The folder written, `DATA/splits/<name>/`.
    pub dir: PathBuf,
}

/// Why a split could not be made.
#[derive(Debug, thiserror::Error)]
pub enum SplitJobError {
    /// The name is not a plain folder name ([`SplitError::BadName`]).
    #[error(transparent)]
    Name(SplitError),
    /// The DATA folder has no readable manifest ([`StoreError::NoManifest`]: nothing was
    /// ingested into it).
    #[error("nothing ingested")]
    NoManifest(#[source] StoreError),
    /// The DATA folder's lock could not be taken.
    #[error("the DATA folder's lock")]
    Lock(#[source] LockError),
    /// The lists could not be read, or list an id twice.
    #[error("lists {}", given.display())]
    Lists {
        /// The folder or name given.
        given: PathBuf,
        /// Why.
        #[source]
        source: SplitError,
    },
    /// The lists given in memory list an id twice.
    #[error("the given lists")]
    GivenLists(#[source] SplitError),
    /// The split's files or the provenance record could not be written.
    #[error("writing the split")]
    Write(#[source] SplitError),
}

/// Makes split `job.name`: the lists are computed from the manifest (scenes that failed to
/// ingest never enter a split; the filter drops others), written atomically, and the DATA
/// folder's provenance record rewritten, all under the folder's writer lock (`mode` says
/// whether to wait for another writer). The lock is taken once the folder is known to hold a
/// manifest, so a wrong folder is left as it was.
pub fn make_split(job: &SplitJob, mode: LockMode) -> Result<SplitReport, SplitJobError> {
    let dir = split_dir(&job.data, &job.name).map_err(SplitJobError::Name)?;
    let rows = job
        .data
        .ingested_rows()
        .map_err(SplitJobError::NoManifest)?;
    let _lock = job.data.lock("split", mode).map_err(SplitJobError::Lock)?;
    let filter = job.filter.as_ref();
    let result = match &job.method {
        Method::ListsFrom(given) => {
            let lists_error = |source| SplitJobError::Lists {
                given: given.clone(),
                source,
            };
            let lists = resolve_lists(given).map_err(lists_error)?;
            split_by_lists(&rows, filter, &lists).map_err(lists_error)?
        }
        Method::Lists(lists) => {
            split_by_lists(&rows, filter, lists).map_err(SplitJobError::GivenLists)?
        }
        Method::Ratios(ratios, seed) => split_by_ratios(&rows, filter, *ratios, *seed),
    };
    write_split(&job.data, &job.name, &result.lists).map_err(SplitJobError::Write)?;
    Ok(SplitReport { result, dir })
}

/// Why the scenes a command works on could not be listed.
#[derive(Debug, thiserror::Error)]
pub enum ScenesError {
    /// The split could not be read.
    #[error("split `{name}`")]
    Split {
        /// The split's name.
        name: String,
        /// Why.
        #[source]
        source: SplitError,
    },
    /// The DATA folder has no readable manifest ([`StoreError::NoManifest`]).
    #[error("nothing ingested")]
    NoManifest(#[source] StoreError),
}

/// The scenes of split `split` (its three subsets, sorted, each once), or, without a split,
/// every scene ingested into `data` without error (in manifest order): what `bake`, `episodes`
/// and the other commands taking a split work on.
pub fn scenes_of(data: &DataDir, split: Option<&str>) -> Result<Vec<String>, ScenesError> {
    Ok(match split {
        Some(name) => read_split(data, name)
            .map_err(|source| ScenesError::Split {
                name: name.to_string(),
                source,
            })?
            .ids(),
        None => data.ingested_ids().map_err(ScenesError::NoManifest)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::split::Subset;
    use crate::store::manifest::{write_manifest, ManifestRow};

    fn data_with(rows: &[(&str, u32, bool)]) -> (tempfile::TempDir, DataDir) {
        let dir = tempfile::tempdir().unwrap();
        let data = DataDir::new(dir.path());
        let rows: Vec<ManifestRow> = rows
            .iter()
            .map(|&(id, nrooms, ok)| ManifestRow {
                id: id.into(),
                dataset: "suncg".into(),
                nlevels: 1,
                nrooms,
                error: (!ok).then(|| "broken".to_string()),
                ..Default::default()
            })
            .collect();
        write_manifest(&data.manifest_path(), &rows).unwrap();
        (dir, data)
    }

    fn lists(train: &[&str], val: &[&str], test: &[&str]) -> SplitLists {
        let v = |s: &[&str]| s.iter().map(|s| s.to_string()).collect();
        SplitLists {
            train: v(train),
            val: v(val),
            test: v(test),
        }
    }

    #[test]
    fn given_lists_keep_the_ingested_listed_scenes_and_write_them_under_the_name() {
        let (_dir, data) = data_with(&[("a", 2, true), ("b", 3, true), ("c", 2, false)]);
        let job = SplitJob {
            data: data.clone(),
            name: "mine".into(),
            filter: Some(Expr::parse("nrooms == 2").unwrap()),
            method: Method::Lists(lists(&["b", "a"], &[], &["c", "z"])),
        };
        let report = make_split(&job, LockMode::Fail).unwrap();
        // b is filtered out, c failed to ingest, z is not in DATA.
        assert_eq!(report.result.lists, lists(&["a"], &[], &[]));
        assert_eq!((report.result.filtered_out, report.result.failed), (1, 1));
        assert_eq!(report.result.missing, vec!["z".to_string()]);
        assert_eq!(report.dir, data.root().join("splits/mine"));
        assert_eq!(read_split(&data, "mine").unwrap(), report.result.lists);
        assert!(data.root().join("provenance.json").is_file());
        // The scenes a command given the split works on, and without one.
        assert_eq!(scenes_of(&data, Some("mine")).unwrap(), vec!["a"]);
        assert_eq!(scenes_of(&data, None).unwrap(), vec!["a", "b"]);
        let e = scenes_of(&data, Some("other")).unwrap_err();
        assert!(e.to_string().contains("split `other`"), "{e}");
    }

    #[test]
    fn ratios_place_each_scene_by_its_own_hash() {
        let (_dir, data) = data_with(&[("a", 2, true), ("b", 3, true), ("c", 2, true)]);
        let ratios = Ratios::new([0.5, 0.0, 0.5]).unwrap();
        let job = SplitJob {
            data: data.clone(),
            name: "r".into(),
            filter: None,
            method: Method::Ratios(ratios, 7),
        };
        let report = make_split(&job, LockMode::Fail).unwrap();
        for id in ["a", "b", "c"] {
            let subset = ratios.assign(id, 7);
            assert!(report.result.lists.get(subset).contains(&id.to_string()));
            assert_ne!(subset, Subset::Val);
        }
    }

    #[test]
    fn a_bad_name_a_missing_manifest_and_twice_listed_ids_are_refused_before_writing() {
        let (_dir, data) = data_with(&[("a", 2, true)]);
        let job = |name: &str, method| SplitJob {
            data: data.clone(),
            name: name.into(),
            filter: None,
            method,
        };
        let e = make_split(
            &job("../x", Method::Lists(lists(&["a"], &[], &[]))),
            LockMode::Fail,
        )
        .unwrap_err();
        assert!(matches!(e, SplitJobError::Name(_)), "{e:?}");
        let twice = Method::Lists(lists(&["a"], &[], &["a"]));
        let e = make_split(&job("t", twice), LockMode::Fail).unwrap_err();
        assert!(matches!(e, SplitJobError::GivenLists(_)), "{e:?}");
        assert!(!data.root().join("splits/t").exists());

        let empty = tempfile::tempdir().unwrap();
        let job = SplitJob {
            data: DataDir::new(empty.path()),
            name: "s".into(),
            filter: None,
            method: Method::Ratios(Ratios::new([1.0, 0.0, 0.0]).unwrap(), 0),
        };
        let e = make_split(&job, LockMode::Fail).unwrap_err();
        assert!(matches!(e, SplitJobError::NoManifest(_)), "{e:?}");
        // A wrong folder is left as it was: no lock file, no splits folder.
        assert_eq!(std::fs::read_dir(empty.path()).unwrap().count(), 0);
    }
}
