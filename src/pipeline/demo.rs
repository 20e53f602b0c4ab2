//! `minos demo`, the README's main job, as one library call: every stage on generated houses
//! into one folder — generate, ingest, split, statistics, bake, episodes, the oracle's run —
//! each stage's result handed to a [`DemoObserver`] as soon as it is done, so a front door
//! prints as it goes. Re-running resumes: each driver keeps what is up to date.

use std::path::{Path, PathBuf};

use crate::body::{AgentPreset, BodyRule};
use crate::episode::format::write_episodes;
use crate::episode::sample::SampleConfig;
use crate::episode::{Episode, Task};
use crate::generate::{generate, GenerateConfig, GenerateError, OutputFormat};
use crate::io::image_codec::ImageEncoding;
use crate::lock::LockMode;
use crate::navmesh::NavParams;
use crate::pipeline::bake::{bake, BakeConfig, BakeError, BakeReport};
use crate::pipeline::episodes::{run_job, EpisodeBatch, EpisodesJob, EpisodesJobError};
use crate::pipeline::ingest::{ingest_with, IngestConfig, IngestError, IngestReport};
use crate::pipeline::rollout::{
    rollout_with, AgentKind, Provenance, RerunOutput, RolloutError, RunConfig, RunReport,
};
use crate::pipeline::split::{make_split, Method, SplitJob, SplitJobError, SplitReport};
use crate::progress::Progress;
use crate::render::RendererChoice;
use crate::run::metrics::Reward;
use crate::shard::Shard;
use crate::sim::{AgentConfig, SensorSuite};
use crate::split::{Expr, Ratios};
use crate::stats::{compute_split, StatsColumn};
use crate::store::manifest::ManifestError;
use crate::store::{DataDir, StoreError};

/// The split of the houses with 3 to 5 rooms (MINOS's multi-room setting).
const MULTIROOM: &str = "nrooms > 2 && nrooms < 6";
/// Episodes sampled per scene and task.
const PER_SCENE: usize = 10;
/// Validation episodes per scene and task the oracle demonstrates (those numbered below it).
const ORACLE_PER_SCENE: char = '3';

/// Each task's batch of episodes, in task order.
type TaskBatches = Vec<(Task, EpisodeBatch)>;

/// What `minos demo` makes, where.
#[derive(Debug, Clone)]
pub struct DemoJob {
    /// The output folder (`suncg/`, `data/`, `episodes/`, `runs/oracle/`, `episode.rrd`).
    pub out: PathBuf,
    /// Houses to generate.
    pub houses: usize,
    /// Seed of the houses, splits, episodes and run.
    pub seed: u64,
    /// The command line, recorded in the provenance of what the job writes.
    pub command: Vec<String>,
}

/// One finished stage of the demo, with what it made.
#[derive(Debug)]
pub enum DemoStage<'a> {
    /// The houses are written in SUNCG's layout under `root`.
    Generated {
        /// Houses written.
        houses: usize,
        /// The dataset root.
        root: &'a Path,
    },
    /// The houses are compiled into the DATA folder.
    Ingested(&'a IngestReport),
    /// The `all` split and the multi-room split are written.
    Split {
        /// The split of every scene.
        all: &'a SplitReport,
        /// The split of the houses with 3 to 5 rooms.
        multiroom: &'a SplitReport,
    },
    /// The environment statistics of split `all` (train, val, test columns).
    Statistics(&'a [StatsColumn]),
    /// The navigation grids are baked (with previews) into `nav_dir`.
    Baked {
        /// Scenes asked for.
        scenes: usize,
        /// Each scene's outcome.
        report: &'a BakeReport,
        /// Where the grids are.
        nav_dir: &'a Path,
    },
    /// The episodes of the three tasks are sampled.
    Episodes {
        /// Each task's batch (its episodes taken out: the oracle's are in `oracle_file`).
        batches: &'a [(Task, EpisodeBatch)],
        /// The folder of the episode files.
        dir: &'a Path,
        /// Episodes the oracle will demonstrate.
        oracle_episodes: usize,
        /// Their file.
        oracle_file: &'a Path,
    },
    /// The oracle's run is written (tables, LeRobot dataset, recording).
    Oracle {
        /// The run's report.
        report: &'a RunReport,
        /// The run folder.
        dir: &'a Path,
        /// The rerun recording of its first episode.
        recording: &'a Path,
    },
}

/// Where a demo's stages report.
pub trait DemoObserver {
    /// A progress sink for the stage `what` about to do `total` units (0: not known yet).
    fn progress(&self, total: u64, what: &str) -> Box<dyn Progress + '_>;
    /// `stage` is done.
    fn finished(&self, stage: DemoStage<'_>);
}

/// What the demo made: the folders a user opens next.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DemoReport {
    /// The DATA folder.
    pub data: PathBuf,
    /// The episode files' folder.
    pub episodes: PathBuf,
    /// The oracle's run folder.
    pub run: PathBuf,
    /// The rerun recording.
    pub recording: PathBuf,
    /// The first scene that compiled, for the next commands' examples.
    pub first_scene: Option<String>,
    /// Scenes that failed to ingest.
    pub ingest_failures: usize,
    /// Scenes whose grid failed to bake.
    pub bake_failures: usize,
}

/// The demo's episode file of `task` in the episodes folder `dir` (`pointgoal.parquet`, …).
fn task_file(dir: &Path, task: Task) -> PathBuf {
    dir.join(format!("{}.parquet", task.name()))
}

impl DemoReport {
    /// The episode file of `task` (every split) in [`DemoReport::episodes`].
    pub fn episode_file(&self, task: Task) -> PathBuf {
        task_file(&self.episodes, task)
    }
}

/// A stage of the demo that failed.
#[derive(Debug, thiserror::Error)]
pub enum DemoError {
    /// Generating the houses.
    #[error("generate")]
    Generate(#[source] GenerateError),
    /// Ingesting them.
    #[error("ingest")]
    Ingest(#[source] IngestError),
    /// The split ratios (a bug: they are constants).
    #[error("the split ratios")]
    Ratios(#[source] crate::split::SplitError),
    /// The multi-room filter (a bug: it is a constant).
    #[error("the multi-room filter")]
    Filter(#[source] crate::split::ExprError),
    /// Writing split `name`.
    #[error("split {name}")]
    Split {
        /// The split.
        name: &'static str,
        /// Why.
        #[source]
        source: SplitJobError,
    },
    /// Reading the manifest back.
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    /// Naming the scenes to bake.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// Baking the grids.
    #[error(transparent)]
    Bake(#[from] BakeError),
    /// Sampling a task's episodes.
    #[error("{task} episodes")]
    Episodes {
        /// The task.
        task: Task,
        /// Why.
        #[source]
        source: EpisodesJobError,
    },
    /// Writing the oracle's episode file.
    #[error(transparent)]
    OracleEpisodes(#[from] crate::episode::format::EpisodeFileError),
    /// The oracle's run.
    #[error(transparent)]
    Run(#[from] RolloutError),
}

impl DemoJob {
    /// Runs every stage, taking each folder's lock as `mode` says, and tells `observer` as
    /// each is done.
    pub fn run(
        &self,
        mode: LockMode,
        observer: &dyn DemoObserver,
    ) -> Result<DemoReport, DemoError> {
        let root = self.out.join("suncg");
        let data = self.out.join("data");
        let cfg = GenerateConfig {
            houses: self.houses,
            seed: self.seed,
            ..GenerateConfig::default()
        };
        {
            let bar = observer.progress(cfg.houses as u64, "generate");
            generate(&cfg, OutputFormat::Suncg, &root, false, bar.as_ref())
                .map_err(DemoError::Generate)?;
        }
        observer.finished(DemoStage::Generated {
            houses: cfg.houses,
            root: &root,
        });
        let ingested = {
            let bar = observer.progress(0, "ingest");
            ingest_with(&IngestConfig::suncg(&root, &data), mode, bar.as_ref())
                .map_err(DemoError::Ingest)?
        };
        observer.finished(DemoStage::Ingested(&ingested));
        let ingest_failures = ingested.count(crate::pipeline::ingest::Outcome::Failed);

        let store = DataDir::new(&data);
        // One agent for every stage: the grids are baked for the body the oracle moves.
        let preset = AgentPreset::default();
        let (all, multiroom) = self.splits(&store, mode)?;
        observer.finished(DemoStage::Split {
            all: &all,
            multiroom: &multiroom,
        });
        let rows = store.read_manifest()?;
        observer.finished(DemoStage::Statistics(&compute_split(
            &rows,
            &all.result.lists,
        )));

        let ids: Vec<String> = rows
            .iter()
            .filter(|r| r.error.is_none())
            .map(|r| r.id.clone())
            .collect();
        let baked = {
            let bar = observer.progress(ids.len() as u64, "bake");
            let cfg = BakeConfig {
                data: store.clone(),
                scenes: store.refs(&ids, None)?,
                params: NavParams::preset(preset),
                force: false,
                previews: true,
            };
            bake(&cfg, Shard::ALL, mode, bar.as_ref())?
        };
        let nav_dir = store.nav_dir();
        observer.finished(DemoStage::Baked {
            scenes: ids.len(),
            report: &baked,
            nav_dir: &nav_dir,
        });
        let bake_failures = baked.failures().count();

        let episodes_dir = self.out.join("episodes");
        let (batches, validation) = self.sample(&store, &all, preset, &episodes_dir, observer)?;
        // The oracle's episodes in a file of their own, which its manifest.json names, so the
        // run can be repeated with `minos run --episodes`.
        let oracle_file = episodes_dir.join("oracle_val.parquet");
        write_episodes(&oracle_file, &validation)?;
        observer.finished(DemoStage::Episodes {
            batches: &batches,
            dir: &episodes_dir,
            oracle_episodes: validation.len(),
            oracle_file: &oracle_file,
        });

        let run_dir = self.out.join("runs").join("oracle");
        let recording = self.out.join("episode.rrd");
        let run = RunConfig {
            batch: None,
            data: store.clone(),
            out: run_dir.clone(),
            agent: AgentKind::Oracle,
            agent_config: AgentConfig::preset(preset),
            sensors: SensorSuite::minos(84),
            renderer: RendererChoice::Cpu,
            max_steps: None,
            seed: self.seed,
            shard: Shard::ALL,
            resume: true,
            reward: Reward::Geodesic,
            encoding: ImageEncoding::Raw,
            lerobot: true,
            lerobot_video: None,
            rerun: Some(RerunOutput {
                path: recording.clone(),
                episodes: 1,
            }),
            allow_body_mismatch: false,
            provenance: Provenance {
                command: self.command.clone(),
                episodes_file: Some(oracle_file.clone()),
                variant: None,
                agent: "oracle".into(),
                preset: Some(preset),
            },
        };
        let report = {
            let bar = observer.progress(validation.len() as u64, "oracle");
            rollout_with(&run, &validation, mode, bar.as_ref())?
        };
        observer.finished(DemoStage::Oracle {
            report: &report,
            dir: &run_dir,
            recording: &recording,
        });
        Ok(DemoReport {
            data,
            episodes: episodes_dir,
            run: run_dir,
            recording,
            first_scene: ids.first().cloned(),
            ingest_failures,
            bake_failures,
        })
    }

    /// The seeded 60/20/20 split of every scene, and of the houses with 3 to 5 rooms.
    fn splits(
        &self,
        store: &DataDir,
        mode: LockMode,
    ) -> Result<(SplitReport, SplitReport), DemoError> {
        let ratios = Ratios::new([0.6, 0.2, 0.2]).map_err(DemoError::Ratios)?;
        let multiroom = Expr::parse(MULTIROOM).map_err(DemoError::Filter)?;
        let split = |name: &'static str, filter: Option<Expr>| {
            let job = SplitJob {
                data: store.clone(),
                name: name.to_string(),
                filter,
                method: Method::Ratios(ratios, self.seed),
            };
            make_split(&job, mode).map_err(|source| DemoError::Split { name, source })
        };
        Ok((split("all", None)?, split("multiroom", Some(multiroom))?))
    }

    /// PointGoal, ObjectGoal and RoomGoal episodes over split `all`, as `minos episodes`
    /// writes them (statistics and provenance beside), and the validation episodes the
    /// oracle demonstrates (the first three per scene and task).
    fn sample(
        &self,
        store: &DataDir,
        all: &SplitReport,
        preset: AgentPreset,
        dir: &Path,
        observer: &dyn DemoObserver,
    ) -> Result<(TaskBatches, Vec<Episode>), DemoError> {
        let lists = &all.result.lists;
        let scenes: Vec<(String, String)> = [
            ("train", &lists.train),
            ("val", &lists.val),
            ("test", &lists.test),
        ]
        .iter()
        .flat_map(|(subset, ids)| ids.iter().map(move |id| (id.clone(), subset.to_string())))
        .collect();
        let mut batches = Vec::new();
        let mut validation = Vec::new();
        for task in [Task::PointGoal, Task::ObjectGoal, Task::RoomGoal] {
            let job = EpisodesJob {
                data: store.clone(),
                scenes: scenes.clone(),
                sample: SampleConfig {
                    task,
                    per_scene: PER_SCENE,
                    seed: self.seed,
                    ..SampleConfig::default()
                },
                body_rule: BodyRule::strict(preset.body()),
                shard: Shard::ALL,
                out: task_file(dir, task),
                habitat_export: None,
                vln_export: None,
                scene_names: Default::default(),
                command: self.command.clone(),
                starts: None,
            };
            let mut batch = {
                let bar = observer.progress(scenes.len() as u64, task.name());
                run_job(&job, bar.as_ref())
                    .map_err(|source| DemoError::Episodes { task, source })?
                    .batch
            };
            validation.extend(std::mem::take(&mut batch.episodes).into_iter().filter(|e| {
                e.split == "val" && e.episode_id.ends_with(|c: char| c < ORACLE_PER_SCENE)
            }));
            batches.push((task, batch));
        }
        Ok((batches, validation))
    }
}
