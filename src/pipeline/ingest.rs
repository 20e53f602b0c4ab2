//! Ingest: find the scenes of a dataset root, load each in parallel, write one compiled scene
//! per scene under `DATA/scenes/` and the manifest `DATA/houses.parquet`.
//!
//! A scene that fails gets an error row and the batch goes on. A compiled scene newer than
//! all its sources is reused (unless `force`), so re-running resumes an interrupted ingest.
//! Rows of scenes not in this run (another dataset, an `--ids` subset) are kept.
//!
//! Ingest holds the DATA folder's writer lock while it writes, removes what a killed ingest
//! left (temporary files in `DATA/` and `DATA/scenes/`) before writing, and stops at the first
//! compiled scene or manifest it cannot write (a full disk, a read-only folder), naming the
//! file and leaving the manifest as it was.
//!
//! Every path ingest stores (the manifest's `source_path`, the compiled scene's `source` and
//! `sources`, the mesh file names textures are found beside) is absolute: the dataset root,
//! `--categories` and `--models` are made absolute (symbolic links resolved) before anything
//! is read, so later commands give the same results from any working directory.

use crate::file_error::FileError;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use rayon::prelude::*;

use crate::atomic::{sweep_stale, sweep_stale_where};
use crate::lock::{LockError, LockMode};
use crate::progress::Progress;
use crate::scene::formats::gltf_scene::GltfLoader;
use crate::scene::formats::mp3d::Mp3dLoader;
use crate::scene::formats::suncg::SuncgLoader;
use crate::scene::formats::threedfront::ThreeDFrontLoader;
use crate::scene::formats::{DatasetLoader, LoadError, SceneEntry};
use crate::shard::Shard;
use crate::store::manifest::{read_manifest, write_manifest, ManifestError, ManifestRow};
use crate::store::scene_file::{read_header, read_scene, write_scene, SceneFileError, SceneHeader};
use crate::store::DataDir;

/// Dataset formats ingest reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DatasetFormat {
    /// SUNCG `house.json` houses.
    Suncg,
    /// 3D-FRONT scene JSON files (furniture meshes from `models` when given).
    ThreeDFront,
    /// glTF / GLB scenes, with optional Habitat configs.
    Gltf,
    /// Matterport3D `.house` scans (with their `.ply` house mesh when present).
    Mp3d,
}

impl crate::vocab::Vocabulary for DatasetFormat {
    const WHAT: &'static str = "dataset";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: DatasetFormat::Suncg,
            name: "suncg",
            aliases: &[],
            help: "SUNCG: <root>/house/<id>/house.json (or <root>/<id>/house.json) with room/, \
                   object/, metadata/ModelCategoryMapping.csv; meshes as .obj or .gltf/.glb",
        },
        crate::vocab::Term {
            value: DatasetFormat::ThreeDFront,
            name: "3dfront",
            aliases: &[],
            help: "3D-FRONT: <root>/<scene uid>.json; furniture meshes from the 3D-FUTURE \
                   models folder (<jid>/raw_model.obj) when one is given, else boxes; \
                   categories from the categories file given, else a model_info.json or \
                   *ModelCategoryMapping.csv in the models folder, <root>, <root>/metadata \
                   or <root>/../metadata",
        },
        crate::vocab::Term {
            value: DatasetFormat::Gltf,
            name: "gltf",
            aliases: &[],
            help: "glTF: every .glb/.gltf (id = file stem) and *.scene_instance.json under \
                   <root>, with Habitat stage/object/dataset configs and HM3D .semantic.txt \
                   beside them; the categories file is a Habitat category-mapping TSV",
        },
        crate::vocab::Term {
            value: DatasetFormat::Mp3d,
            name: "mp3d",
            aliases: &[],
            help: "Matterport3D: <root>/<scan>/house_segmentations/<scan>.house (+ .ply, \
                   matterport_mesh/) or bare <root>/<scan>.house files; category_mapping.tsv \
                   and mpcat40.tsv from the root",
        },
    ];
}

crate::vocab::name_traits!(DatasetFormat);

impl DatasetFormat {
    /// The loader of this format for `cfg.root`.
    pub fn loader(self, cfg: &IngestConfig) -> Result<Box<dyn DatasetLoader>, LoadError> {
        Ok(match self {
            DatasetFormat::Suncg => {
                Box::new(SuncgLoader::open(&cfg.root, cfg.categories.as_deref())?)
            }
            DatasetFormat::ThreeDFront => Box::new(ThreeDFrontLoader::open(
                &cfg.root,
                cfg.models.as_deref(),
                cfg.categories.as_deref(),
            )?),
            DatasetFormat::Gltf => {
                Box::new(GltfLoader::open(&cfg.root, cfg.categories.as_deref())?)
            }
            DatasetFormat::Mp3d => {
                Box::new(Mp3dLoader::open(&cfg.root, cfg.categories.as_deref())?)
            }
        })
    }
}

/// What to ingest.
#[derive(Debug, Clone)]
pub struct IngestConfig {
    /// Format of the dataset.
    pub format: DatasetFormat,
    /// Dataset root.
    pub root: PathBuf,
    /// DATA folder to fill.
    pub data: DataDir,
    /// Only these scene ids (all when `None`).
    pub ids: Option<Vec<String>>,
    /// Rebuild compiled scenes even when up to date.
    pub force: bool,
    /// Category table overriding the one found under the root.
    pub categories: Option<PathBuf>,
    /// 3D-FRONT: the 3D-FUTURE model folder (`<jid>/raw_model.obj`); furniture are boxes
    /// without it.
    pub models: Option<PathBuf>,
}

impl IngestConfig {
    /// Ingest every scene of a SUNCG root into `data`, reusing up-to-date compiled scenes.
    pub fn suncg(root: &Path, data: &Path) -> Self {
        IngestConfig {
            format: DatasetFormat::Suncg,
            root: root.to_path_buf(),
            data: DataDir::new(data),
            ids: None,
            force: false,
            categories: None,
            models: None,
        }
    }
}

/// How one scene went.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Loaded from its sources and compiled.
    Compiled,
    /// Its compiled scene was up to date.
    UpToDate,
    /// It failed (the row holds the error).
    Failed,
}

/// The outcomes' names, as reports (Python's `ingest`) give them.
impl crate::vocab::Vocabulary for Outcome {
    const WHAT: &'static str = "ingest outcome";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: Outcome::Compiled,
            name: "compiled",
            aliases: &[],
            help: "loaded from its sources and compiled",
        },
        crate::vocab::Term {
            value: Outcome::UpToDate,
            name: "up_to_date",
            aliases: &[],
            help: "its compiled scene was up to date",
        },
        crate::vocab::Term {
            value: Outcome::Failed,
            name: "failed",
            aliases: &[],
            help: "it failed (its manifest row holds the error)",
        },
    ];
}

/// What ingest did.
#[derive(Debug, Default)]
pub struct IngestReport {
    /// This run's rows with their outcome, sorted by id.
    pub scenes: Vec<(ManifestRow, Outcome)>,
    /// Requested ids that the root does not hold.
    pub missing_ids: Vec<String>,
    /// Non-fatal remarks, one line each.
    pub warnings: Vec<String>,
    /// The manifest written (by an unsharded ingest; a shard writes none).
    pub manifest: PathBuf,
    /// Whether the manifest was written: false for a shard ([`ingest_shard`]).
    pub manifest_written: bool,
}

impl IngestReport {
    /// Number of scenes with the given outcome.
    pub fn count(&self, outcome: Outcome) -> usize {
        self.scenes.iter().filter(|(_, o)| *o == outcome).count()
    }
}

/// Errors that stop a whole ingest (per-scene errors become rows instead).
#[derive(Debug, thiserror::Error)]
pub enum IngestError {
    /// The root or its category table cannot be read.
    #[error(transparent)]
    Load(#[from] LoadError),
    /// The manifest cannot be read or written.
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    /// The id list could not be read.
    #[error("{0}")]
    Ids(#[source] FileError),
    /// Another process writes the DATA folder, or its lock cannot be taken.
    #[error("the DATA folder's lock")]
    Lock(#[from] LockError),
    /// The DATA folder's provenance record could not be written.
    #[error("the DATA folder's provenance record")]
    Provenance(#[source] crate::file_error::FileError),
    /// A compiled scene cannot be written (the message names it); nothing after it is.
    #[error(transparent)]
    Write(SceneFileError),
    /// Stale temporary files cannot be removed from a folder.
    #[error("{}: cannot remove stale temporary files", path.display())]
    Sweep {
        /// The folder.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The root holds no scene of the format (nothing is written).
    #[error(
        "{}: no {dataset} scenes found (looked for {layout}; is this the dataset root, and \
         the right dataset format?)",
        root.display()
    )]
    NoScenes {
        /// The dataset root searched.
        root: PathBuf,
        /// The dataset's name.
        dataset: &'static str,
        /// Where the loader looked, relative to the root.
        layout: &'static str,
    },
}

/// Reads an id list: one id per line, `#` comments and blank lines ignored.
pub fn read_id_list(path: &Path) -> Result<Vec<String>, IngestError> {
    let text = std::fs::read_to_string(path)
        .map_err(|source| IngestError::Ids(FileError::new(path, source)))?;
    Ok(text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(str::to_string)
        .collect())
}

fn mtime(path: &Path) -> Option<SystemTime> {
    std::fs::metadata(path).and_then(|m| m.modified()).ok()
}

/// True when the compiled scene exists, was built from `source`, and is newer than every
/// file it was built from.
fn up_to_date(compiled: &Path, source: &Path) -> bool {
    let Some(built) = mtime(compiled) else {
        return false;
    };
    let Ok(header) = read_header(compiled) else {
        return false;
    };
    header.source == source.display().to_string()
        && header
            .sources
            .iter()
            .all(|s| mtime(Path::new(s)).is_some_and(|t| t <= built))
}

fn ingest_one(
    loader: &dyn DatasetLoader,
    house: &SceneEntry,
    data: &DataDir,
    force: bool,
) -> Result<(ManifestRow, Outcome, Vec<String>), IngestError> {
    let dataset = loader.dataset().name();
    let compiled = data.scene_path(&house.id);
    let source = house.path.display().to_string();
    let fail = |e: String| {
        // A stale compiled scene must not outlive a source that no longer loads.
        let _ = std::fs::remove_file(&compiled);
        (
            ManifestRow::failed(&house.id, dataset, &source, e),
            Outcome::Failed,
            Vec::new(),
        )
    };
    if !force && up_to_date(&compiled, &house.path) {
        if let Ok((header, scene)) = read_scene(&compiled) {
            return Ok((
                ManifestRow::from_scene(&scene, &header.source),
                Outcome::UpToDate,
                Vec::new(),
            ));
        }
    }
    let loaded = match loader.load(house) {
        Ok(l) => l,
        Err(e) => return Ok(fail(crate::escape::error_line(&e))),
    };
    let header = SceneHeader {
        id: house.id.clone(),
        source: source.clone(),
        sources: loaded
            .sources
            .iter()
            .map(|p| p.display().to_string())
            .collect(),
    };
    match write_scene(&compiled, &header, &loaded.scene) {
        Ok(()) => {}
        // The folder's problem (a full disk, a read-only folder), not the scene's.
        Err(e @ SceneFileError::Io(FileError { .. })) => return Err(IngestError::Write(e)),
        Err(e) => return Ok(fail(crate::escape::error_line(&e))),
    }
    Ok((
        ManifestRow::from_scene(&loaded.scene, &source),
        Outcome::Compiled,
        loaded.warnings,
    ))
}

/// Removes what a killed process left in `dir`.
fn sweep(dir: &Path) -> Result<(), IngestError> {
    sweep_stale(dir)
        .map(drop)
        .map_err(|source| IngestError::Sweep {
            path: dir.to_path_buf(),
            source,
        })
}

/// `path` made absolute against the working directory, with symbolic links and `..` resolved
/// when it exists (as given when it cannot be resolved; the loader then names it).
fn absolute(path: &Path) -> PathBuf {
    std::fs::canonicalize(path)
        .or_else(|_| std::path::absolute(path))
        .unwrap_or_else(|_| path.to_path_buf())
}

impl IngestConfig {
    /// The same configuration with the root, the category table and the model folder made
    /// absolute, so nothing stored depends on the working directory.
    pub fn with_absolute_paths(&self) -> IngestConfig {
        IngestConfig {
            root: absolute(&self.root),
            categories: self.categories.as_deref().map(absolute),
            models: self.models.as_deref().map(absolute),
            ..self.clone()
        }
    }
}

/// Ingests every selected scene of the root into the DATA folder, failing at once when
/// another process writes it ([`ingest_with`] can wait instead).
pub fn ingest(cfg: &IngestConfig, progress: &dyn Progress) -> Result<IngestReport, IngestError> {
    ingest_with(cfg, LockMode::Fail, progress)
}

/// Ingests every selected scene of the root into the DATA folder, holding its writer lock
/// (taken as `mode` says) once scenes are found: a root without scenes writes nothing.
pub fn ingest_with(
    cfg: &IngestConfig,
    mode: LockMode,
    progress: &dyn Progress,
) -> Result<IngestReport, IngestError> {
    ingest_impl(cfg, Shard::ALL, mode, progress)
}

/// Compiles shard `shard` of the selected scenes (every n-th id in sorted order) into the
/// DATA folder, for several shards ingesting one folder at once, on one machine or many
/// sharing it: it holds the folder's lock shared with the other shards, sweeps only its own
/// scenes' temporaries and writes no manifest. When every shard is done, an unsharded ingest
/// with the same options finds every compiled scene up to date (it reads them, it does not
/// load the sources again) and writes the manifest: the folder one ingest would write.
pub fn ingest_shard(
    cfg: &IngestConfig,
    shard: Shard,
    mode: LockMode,
    progress: &dyn Progress,
) -> Result<IngestReport, IngestError> {
    ingest_impl(cfg, shard, mode, progress)
}

fn ingest_impl(
    cfg: &IngestConfig,
    shard: Shard,
    mode: LockMode,
    progress: &dyn Progress,
) -> Result<IngestReport, IngestError> {
    let cfg = &cfg.with_absolute_paths();
    let loader = cfg.format.loader(cfg)?;
    let loader = loader.as_ref();
    let mut report = IngestReport {
        manifest: cfg.data.manifest_path(),
        ..Default::default()
    };
    report.warnings.extend(loader.root_warning());
    let mut houses = loader.discover()?;
    if houses.is_empty() {
        return Err(IngestError::NoScenes {
            root: cfg.root.clone(),
            dataset: loader.dataset().name(),
            layout: loader.scene_layout(),
        });
    }
    if let Some(ids) = &cfg.ids {
        let wanted: BTreeSet<&str> = ids.iter().map(String::as_str).collect();
        let present: BTreeSet<String> = houses.iter().map(|h| h.id.clone()).collect();
        report.missing_ids = wanted
            .iter()
            .filter(|id| !present.contains(**id))
            .map(|s| s.to_string())
            .collect();
        houses.retain(|h| wanted.contains(h.id.as_str()));
    }
    let sharded = shard != Shard::ALL;
    if sharded {
        houses.sort_by(|a, b| a.id.cmp(&b.id));
        let mut i = 0;
        houses.retain(|_| {
            i += 1;
            shard.keeps(i - 1)
        });
    }
    let _lock = if sharded {
        let lock = cfg.data.lock_shared(mode)?;
        let dir = cfg.data.scenes_dir();
        for h in &houses {
            let path = cfg.data.scene_path(&h.id);
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
            sweep_stale_where(&dir, |of| Some(of) == name.as_deref()).map_err(|source| {
                IngestError::Sweep {
                    path: dir.clone(),
                    source,
                }
            })?;
        }
        lock
    } else {
        let lock = cfg.data.lock("ingest", mode)?;
        sweep(cfg.data.root())?;
        sweep(&cfg.data.scenes_dir())?;
        lock
    };
    progress.set_total(houses.len() as u64);
    let results: Vec<(ManifestRow, Outcome, Vec<String>)> = houses
        .par_iter()
        .map(|h| {
            let r = ingest_one(loader, h, &cfg.data, cfg.force);
            progress.advance(1);
            r
        })
        .collect::<Result<_, _>>()?;
    for (row, outcome, warnings) in results {
        report.warnings.extend(warnings);
        report.scenes.push((row, outcome));
    }
    if sharded {
        return Ok(report);
    }
    // Merge with the rows of scenes this run did not touch.
    let mut rows: BTreeMap<String, ManifestRow> = BTreeMap::new();
    if report.manifest.is_file() {
        for row in read_manifest(&report.manifest)? {
            rows.insert(row.id.clone(), row);
        }
    }
    for (row, _) in &report.scenes {
        rows.insert(row.id.clone(), row.clone());
    }
    let rows: Vec<ManifestRow> = rows.into_values().collect();
    write_manifest(&report.manifest, &rows)?;
    report.manifest_written = true;
    crate::store::provenance::write_data_record(&cfg.data).map_err(IngestError::Provenance)?;
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_id_list_is_read_and_a_missing_one_names_the_file() {
        let dir = tempfile::tempdir().expect("temp dir");
        let list = dir.path().join("ids.txt");
        std::fs::write(&list, "# houses\na\n\n  b  \n#c\n").expect("written");
        assert_eq!(read_id_list(&list).expect("read"), ["a", "b"]);
        let missing = dir.path().join("none.txt");
        let e = read_id_list(&missing).unwrap_err();
        assert!(
            matches!(&e, IngestError::Ids(FileError { path, source })
                if path == &missing && source.kind() == std::io::ErrorKind::NotFound),
            "{e:?}"
        );
        assert!(e.to_string().starts_with(&missing.display().to_string()));
    }
}
