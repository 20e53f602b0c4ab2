//! One episode-sampling job, the same for `minos episodes` and Python's `sample_episodes`: the
//! scenes of a split (or every ingested scene, on a variant if asked), sampled, checked for
//! ObjectGoal categories none of them has, written with their statistics and provenance, and
//! exported to Habitat's or a VLN layout. The front doors only turn flags or keyword
//! arguments into an [`EpisodesJob`] and report the [`EpisodesOutcome`].

use std::path::{Path, PathBuf};

use crate::body::{AgentPreset, BodyRule};
use crate::episode::habitat::{export_habitat, HabitatError, SceneIdStyle};
use crate::episode::sample::{category_preset, SampleConfig};
use crate::episode::vln::export::{
    export_r2r, export_vlnce, EpisodeExport, VlnExportError, VlnFormat,
};
use crate::episode::Task;
use crate::file_error::FileError;
use crate::progress::Progress;
use crate::provenance;
use crate::scene::RoomClass;
use crate::shard::Shard;
use crate::split::{read_split, SplitError, Subset};
use crate::store::{DataDir, StoreError};

use super::rules::{check_options, EpisodeOptionsError};
use super::{read_starts, sample_scenes_from, BatchWriteError, EpisodeBatch};
use crate::episode::format::EpisodeFileError;

/// What a job samples and where it writes.
#[derive(Debug, Clone)]
pub struct EpisodesJob {
    /// The DATA folder.
    pub data: DataDir,
    /// `(scene reference, subset)` of every selected scene ([`select_scenes`]).
    pub scenes: Vec<(String, String)>,
    /// Sampling parameters.
    pub sample: SampleConfig,
    /// The body the episodes are for.
    pub body_rule: BodyRule,
    /// This process's shard of the scenes.
    pub shard: Shard,
    /// The episode file.
    pub out: PathBuf,
    /// Also export Habitat-Lab's layout into this folder.
    pub habitat_export: Option<PathBuf>,
    /// Also export VLN episodes in this format into this folder.
    pub vln_export: Option<(VlnFormat, PathBuf)>,
    /// How the exports name scenes.
    pub scene_names: SceneIdStyle,
    /// The command line (or call) recorded in the provenance file.
    pub command: Vec<String>,
    /// Take each scene's starts from this episode file (in its order) instead of drawing
    /// them: MINOS's episode states, e.g. the starts of PointGoal episodes sampled with
    /// `min_doors`, given ObjectGoal goals.
    pub starts: Option<PathBuf>,
}

/// What a job did.
#[derive(Debug)]
pub struct EpisodesOutcome {
    /// The sampled episodes and their statistics.
    pub batch: EpisodeBatch,
    /// The statistics file written beside the episode file.
    pub stats_path: PathBuf,
    /// The provenance file written beside the episode file.
    pub provenance_path: PathBuf,
    /// Things worth a warning: scenes that yielded nothing and why, ObjectGoal categories
    /// some scenes lack.
    pub warnings: Vec<String>,
}

/// Why a job could not run or finish. Messages are one line and name no front-door flag.
#[derive(Debug, thiserror::Error)]
pub enum EpisodesJobError {
    /// The options break a rule ([`check_options`]).
    #[error(transparent)]
    Options(#[from] EpisodeOptionsError),
    /// The split's lists could not be read.
    #[error("split `{split}`")]
    Split {
        /// The split name.
        split: String,
        /// Why.
        #[source]
        source: SplitError,
    },
    /// A subset was asked for without a split.
    #[error("a subset needs a split (without one, every ingested scene is used)")]
    SubsetWithoutSplit,
    /// The variant or the manifest could not be read.
    #[error("{source}")]
    Store {
        /// Why.
        #[source]
        source: StoreError,
    },
    /// No ObjectGoal category names an object of any sampled scene (a typo, most likely).
    #[error("no object of the {scenes} scene(s) has category {missing} (known: {known})")]
    UnknownCategories {
        /// How many scenes were sampled.
        scenes: usize,
        /// The categories, quoted.
        missing: String,
        /// Some categories the scenes do have.
        known: String,
    },
    /// The file of given starts could not be read.
    #[error("starts")]
    Starts(#[source] EpisodeFileError),
    /// The episode file or its statistics.
    #[error(transparent)]
    Write(#[from] BatchWriteError),
    /// The provenance record.
    #[error(transparent)]
    Provenance(#[from] FileError),
    /// The Habitat export.
    #[error(transparent)]
    Habitat(#[from] HabitatError),
    /// A VLN export.
    #[error(transparent)]
    Vln(#[from] VlnExportError),
}

/// Whether episodes are stratified by distance bin (`--stratify`, `stratify=`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Stratify {
    /// For the val and test subsets only (MINOS picked their states across the distance
    /// range).
    #[default]
    Auto,
    /// Always.
    On,
    /// Never.
    Off,
}

impl Stratify {
    /// Whether episodes of `subset` (`None`: all three) are stratified.
    pub fn applies(self, subset: Option<Subset>) -> bool {
        match self {
            Stratify::On => true,
            Stratify::Off => false,
            Stratify::Auto => matches!(subset, Some(Subset::Val | Subset::Test)),
        }
    }
}

impl crate::vocab::Vocabulary for Stratify {
    const WHAT: &'static str = "stratification";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: Stratify::Auto,
            name: "auto",
            aliases: &[],
            help: "for val and test subsets only (MINOS picked their states across the distance range)",
        },
        crate::vocab::Term {
            value: Stratify::On,
            name: "on",
            aliases: &[],
            help: "always",
        },
        crate::vocab::Term {
            value: Stratify::Off,
            name: "off",
            aliases: &[],
            help: "never",
        },
    ];
}

crate::vocab::name_traits!(Stratify);

/// The scenes a job samples: those of `split` (its `subset`, or all three), or every ingested
/// scene without a split — each as `(scene reference, subset name)`, on `variant` if given.
pub fn select_scenes(
    data: &DataDir,
    split: Option<&str>,
    subset: Option<Subset>,
    variant: Option<&str>,
) -> Result<Vec<(String, String)>, EpisodesJobError> {
    let refs = |ids: &[String]| {
        data.refs(ids, variant)
            .map_err(|source| EpisodesJobError::Store { source })
    };
    let mut scenes = Vec::new();
    match split {
        Some(name) => {
            let lists = read_split(data, name).map_err(|source| EpisodesJobError::Split {
                split: name.to_string(),
                source,
            })?;
            for part in Subset::ALL {
                if subset.is_none_or(|s| s == part) {
                    scenes.extend(
                        refs(lists.get(part))?
                            .into_iter()
                            .map(|r| (r.to_string(), part.name().to_string())),
                    );
                }
            }
        }
        None if subset.is_some() => return Err(EpisodesJobError::SubsetWithoutSplit),
        None => {
            let ids = data
                .ingested_ids()
                .map_err(|source| EpisodesJobError::Store { source })?;
            scenes.extend(
                refs(&ids)?
                    .into_iter()
                    .map(|r| (r.to_string(), String::new())),
            );
        }
    }
    Ok(scenes)
}

/// The success radius a task's episodes get when none is given: MINOS's 0.4 m for PointGoal
/// under MINOS's presets (the preset's own radius), 0.2 m for objects and rooms, R2R's 3 m
/// for VLN.
pub fn default_success_radius(task: Task, preset: AgentPreset) -> f32 {
    match task {
        Task::PointGoal => preset.point_goal_radius(),
        Task::ObjectGoal | Task::RoomGoal => SampleConfig::default().success_radius,
        Task::Vln => crate::episode::vln::DEFAULT_SUCCESS_RADIUS,
    }
}

/// The shortest geodesic distance a task's episodes get when none is given: 4 m for VLN
/// (routes worth describing), else 1 m (MINOS's `--min_dist`).
pub fn default_min_geodesic(task: Task) -> f32 {
    if task == Task::Vln {
        4.0
    } else {
        1.0
    }
}

/// The fewest rooms on the shortest path when none is given: 2 for VLN (a route leaves the
/// start room), else no rule.
pub fn default_min_rooms(task: Task) -> u32 {
    if task == Task::Vln {
        2
    } else {
        0
    }
}

/// Whether start and goal keep to one level when not said: yes for ObjectGoal, as in
/// Habitat's 2023 ObjectNav challenge (single-floor episodes); other tasks span levels.
pub fn default_same_level(task: Task) -> bool {
    task == Task::ObjectGoal
}

/// ObjectGoal category names as given → (the categories with presets expanded, whether
/// `all`); `None` when `all` is given beside others.
pub fn expand_categories(given: &[String]) -> Option<(Vec<String>, bool)> {
    if given.iter().any(|c| c == "all") {
        return (given.len() == 1).then(|| (Vec::new(), true));
    }
    let mut out: Vec<String> = Vec::new();
    for c in given {
        match category_preset(c) {
            Some(list) => out.extend(list.iter().map(|s| s.to_string())),
            None => out.push(c.clone()),
        }
    }
    out.dedup();
    Some((out, false))
}

/// Room class labels ([`RoomClass::parse_label`]) → the classes (`None` for `any`, MINOS's
/// any room); `Err` names the first unknown label and the classes.
pub fn parse_room_classes(
    names: &[String],
) -> Result<Option<Vec<RoomClass>>, crate::vocab::UnknownName> {
    if names.iter().any(|t| t == "any") {
        return Ok(None);
    }
    names
        .iter()
        .map(|t| RoomClass::parse_label(t))
        .collect::<Result<Vec<_>, _>>()
        .map(Some)
}

/// Runs `job`: checks its options ([`check_options`]), samples, checks the categories,
/// writes the episode file with its statistics and provenance, exports.
pub fn run_job(
    job: &EpisodesJob,
    progress: &dyn Progress,
) -> Result<EpisodesOutcome, EpisodesJobError> {
    let cfg = &job.sample;
    let exports = EpisodeExport::requested(
        job.habitat_export.is_some(),
        job.vln_export.as_ref().map(|(f, _)| *f),
    );
    check_options(cfg, exports)?;
    let starts = match &job.starts {
        Some(path) => Some(read_starts(path).map_err(EpisodesJobError::Starts)?),
        None => None,
    };
    let batch = sample_scenes_from(
        &job.data,
        &job.scenes,
        cfg,
        job.body_rule,
        job.shard,
        starts.as_ref(),
        progress,
    );
    let mut warnings = Vec::new();
    if cfg.task == Task::ObjectGoal && !cfg.all_categories {
        if let Some(w) = check_categories(&cfg.categories, &batch, job.shard)? {
            warnings.push(w);
        }
    }
    let stats_path = batch.write(&job.out)?;
    let provenance_path = write_provenance(job, &batch, &stats_path)?;
    for (id, s) in &batch.scenes {
        if let Some(p) = &s.problem {
            warnings.push(format!("scene {id}: {p}"));
        }
    }
    if let Some(dir) = &job.habitat_export {
        // Episodes of no split go into Habitat's split `all`.
        for (split, eps) in batch.export_splits() {
            export_habitat(dir, split, &job.scene_names, &eps)?;
        }
    }
    if let Some((format, dir)) = &job.vln_export {
        for (split, eps) in batch.export_splits() {
            match format {
                VlnFormat::VlnCe => export_vlnce(dir, split, &job.scene_names, &eps)?,
                VlnFormat::R2r => export_r2r(dir, split, &eps)?,
            };
        }
    }
    Ok(EpisodesOutcome {
        batch,
        stats_path,
        provenance_path,
        warnings,
    })
}

/// ObjectGoal categories against the objects of the sampled scenes: none of them found (a
/// typo, which would otherwise give no episodes) is an error; some missing is a warning (and
/// a shard, which sees only its scenes, only ever warns).
fn check_categories(
    categories: &[String],
    batch: &EpisodeBatch,
    shard: Shard,
) -> Result<Option<String>, EpisodesJobError> {
    let found = &batch.object_categories;
    if found.is_empty() {
        // No grid read, or no objects at all: the per-scene problems say so.
        return Ok(None);
    }
    let missing: Vec<&str> = categories
        .iter()
        .filter(|c| !found.contains(&c.to_ascii_lowercase()))
        .map(String::as_str)
        .collect();
    if missing.is_empty() {
        return Ok(None);
    }
    const SHOWN: usize = 12;
    let mut known: Vec<&str> = found.iter().take(SHOWN).map(String::as_str).collect();
    if found.len() > SHOWN {
        known.push("…");
    }
    let err = EpisodesJobError::UnknownCategories {
        scenes: batch.scenes.len(),
        missing: missing
            .iter()
            .map(|c| format!("`{c}`"))
            .collect::<Vec<_>>()
            .join(", "),
        known: known.join(", "),
    };
    if missing.len() == categories.len() && shard.count == 1 {
        return Err(err);
    }
    Ok(Some(crate::escape::error_line(&err)))
}

/// Writes `<out>.provenance.json` beside the episode file: minos version and commit, the
/// command and resolved configuration, the scenes with the checksums of their compiled and
/// source files, and the checksums of the episode file and its statistics.
fn write_provenance(
    job: &EpisodesJob,
    batch: &EpisodeBatch,
    stats_path: &Path,
) -> Result<PathBuf, FileError> {
    let name = |p: &Path| {
        p.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let mut files = serde_json::Map::new();
    for p in [job.out.as_path(), stats_path] {
        files.insert(name(p), serde_json::json!(provenance::sha256_file(p)?));
    }
    let starts = match &job.starts {
        Some(p) => serde_json::json!({
            "path": p.display().to_string(),
            "checksum": provenance::sha256_file(p)?,
        }),
        None => serde_json::Value::Null,
    };
    let record = serde_json::json!({
        "format": provenance::FORMAT,
        "kind": "episodes",
        "minos": provenance::MINOS,
        "command": job.command,
        "configuration": format!("{:?}", job.sample),
        "seed": job.sample.seed,
        "starts": starts,
        "shard": job.shard.to_string(),
        "body": format!("{:?}", job.body_rule),
        "scenes": crate::store::provenance::scene_records(
            &job.data,
            batch.scenes.keys().map(String::as_str)
        ),
        "files": files,
    });
    let path = PathBuf::from(format!("{}.provenance.json", job.out.display()));
    provenance::write_record(&path, &record)?;
    Ok(path)
}
