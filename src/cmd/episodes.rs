//! `minos episodes`: flags → an [`EpisodesJob`] ([`config`]: the scenes, the
//! [`SampleConfig`], the agent body); [`minos::pipeline::episodes`] samples, then this writes
//! the episode Parquet, its statistics JSON, and optionally Habitat's layout.
//! `minos episodes import` reads Habitat or MINOS episode files into the same Parquet.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context as _};
use minos::body::{AgentPreset, BodyRule};
use minos::episode::habitat::SceneIdStyle;
use minos::episode::import::ForeignFormat;
use minos::episode::sample::{SampleConfig, Select};
use minos::episode::vln::export::{EpisodeExport, VlnFormat};
use minos::episode::Task;
use minos::pipeline::episodes::{
    check_options, default_min_geodesic, default_min_rooms, default_same_level,
    default_success_radius, expand_categories, import_job, parse_room_classes, run_job,
    select_scenes, EpisodeOptionsError, EpisodesJob, EpisodesJobError, ImportJob, Stratify,
};
use minos::shard::ShardSpec;
use minos::split::Subset;
use minos::store::DataDir;
use minos::vocab::Vocabulary;

use super::common::vocab;
use super::Context;

/// Sample navigable PointGoal, ObjectGoal, RoomGoal or VLN episodes, or import episode files.
#[derive(Debug, clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct Args {
    #[command(subcommand)]
    command: Option<Sub>,
    #[command(flatten)]
    sample: SampleArgs,
}

#[derive(Debug, clap::Subcommand)]
enum Sub {
    /// Read Habitat (json.gz) or MINOS (csv, csv.bz2) episodes into minos's Parquet.
    Import(ImportArgs),
}

/// Formats of `episodes import --from`.
/// Each start is a uniformly random walkable point (by area) with a uniform yaw, on an island
/// of radius >= --min-island-radius; the goal lies on the same island. Per-scene randomness
/// derives from (seed, scene id, task), so thread count, scene order and sharding never change
/// the output bytes. Scenes must be baked first (`minos bake`).
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos episodes --data DATA --task pointgoal --split all --per-scene 20 --seed 1 --out eps/point.parquet\n  \
    minos episodes --data DATA --task objectgoal --categories door,arch --select closest --split all --subset val \\\n      --per-scene 10 --out eps/door_val.parquet --export habitat eps/habitat \\\n      --scene-prefix data/scene_datasets/minos/ --scene-suffix .glb\n  \
    minos episodes --data DATA --task roomgoal --room-types kitchen,bedroom --split all --per-scene 10 --out eps/rooms.parquet\n  \
    minos episodes --data DATA --task pointgoal --split all --shard 0/4 --out eps/part0.parquet\n  \
    minos episodes --data DATA --task vln --split all --per-scene 20 --out eps/vln.parquet \\\n      --export vlnce eps/vlnce --scene-prefix mp3d/ --scene-suffix .glb\n  \
    minos episodes --data DATA --task objectgoal --categories hm3d --split all --out eps/hm3d6.parquet\n  \
    minos episodes --data DATA --task objectgoal --categories all --min-instances 2 --split all --out eps/ovon.parquet\n  \
    minos episodes import --from habitat val.json.gz --out eps/habitat_val.parquet"
)]
pub struct SampleArgs {
    /// DATA folder (baked with `minos bake`).
    #[arg(long, required = false)]
    data: Option<PathBuf>,
    /// Task.
    #[arg(long, value_parser = vocab::<Task>())]
    task: Option<Task>,
    /// Split whose scenes are used (DATA/splits/NAME); default: every scene `minos ingest`
    /// compiled, with an empty `split` in the episodes (exported to Habitat as `all`).
    #[arg(long, value_name = "NAME")]
    split: Option<String>,
    /// Only this subset of the split (needs --split); default: all three.
    #[arg(long, value_parser = vocab::<Subset>())]
    subset: Option<Subset>,
    /// Sample on this variant of every scene (needs `minos bake --variant NAME`); scene ids in
    /// the output read `<scene>@NAME`.
    #[arg(long, value_name = "NAME")]
    variant: Option<String>,
    /// Agent preset whose body the episodes are for (the grids must be baked for it).
    #[arg(long, value_parser = vocab::<AgentPreset>(), default_value = "habitat")]
    preset: AgentPreset,
    /// Sample on grids baked for another body than --preset's.
    #[arg(long)]
    allow_body_mismatch: bool,
    /// Episodes per scene (1 to 4,294,967,295).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..))]
    per_scene: u32,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Output Parquet file (statistics go to FILE.stats.json).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Smallest island radius for starts (m).
    #[arg(long, default_value_t = 1.5)]
    min_island_radius: f32,
    /// Success radius (m); MINOS used 0.25 (objects) and 0.4 (points). Default: 0.4 for
    /// PointGoal episodes of MINOS's presets (minos, minos-gridworld, minos-paper), 3.0 for
    /// VLN (R2R's and VLN-CE's), else 0.2.
    #[arg(long)]
    success_radius: Option<f32>,
    /// ObjectGoal categories, comma-separated (MINOS used doors); or a preset: `minos`
    /// (door, arch), `hm3d` (HM3D ObjectNav's 6: chair, bed, plant, toilet, tv_monitor,
    /// sofa), `mpcat40` (Matterport3D ObjectNav's 21 mpcat40 goal categories); or `all`:
    /// every category of each scene's objects (their most specific labels) with at least
    /// --min-instances reachable instances. Categories are drawn uniformly among those
    /// reachable from the start (balanced; counts in the statistics).
    #[arg(long, value_delimiter = ',', default_value = "door,arch")]
    categories: Vec<String>,
    /// ObjectGoal: fewest reachable instances a category needs in a scene.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    min_instances: u32,
    /// VLN: instructions per route (R2R has 3); the k-th is full, medium or brief in turn.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    instructions: u32,
    /// RoomGoal classes, comma-separated, or `any`: other, bedroom, living_room, bathroom,
    /// kitchen, dining_room, office, hallway, outdoor.
    #[arg(long, value_delimiter = ',', default_value = "any")]
    room_types: Vec<String>,
    /// Which goal instances count.
    #[arg(long, value_parser = vocab::<Select>(), default_value = "any")]
    select: Select,
    /// Shortest geodesic distance (m). Default: 4 for VLN (routes worth describing), else 1.
    #[arg(long)]
    min_geodesic: Option<f32>,
    /// Longest geodesic distance (m).
    #[arg(long, default_value_t = 30.0)]
    max_geodesic: f32,
    /// Disable Habitat's geodesic/Euclidean ratio rule (pairs with ratio < 1.1 kept with
    /// probability 20·(ratio−0.98)²).
    #[arg(long)]
    no_ratio_rule: bool,
    /// Fewest doorways (doors and arches) on the shortest path (MINOS).
    #[arg(long, default_value_t = 0)]
    min_doors: u32,
    /// Fewest rooms on the shortest path (MINOS). Default: 2 for VLN (the route leaves the
    /// start room), else 0.
    #[arg(long)]
    min_rooms: Option<u32>,
    /// Take each scene's starts (positions and yaws, in file order) from this episode file
    /// instead of drawing them, and draw a goal for each: MINOS's episode states (its tasks
    /// shared one file of starts, filtered by their PointGoal paths' doors — sample those
    /// with `--task pointgoal --min-doors N`, then the task's goals with `--starts`).
    #[arg(long, value_name = "EPISODES")]
    starts: Option<PathBuf>,
    /// Start and goal on the same level. The default for ObjectGoal, as in Habitat's 2023
    /// ObjectNav challenge (single-floor episodes); other tasks span levels unless asked.
    #[arg(long, conflicts_with = "multi_level")]
    same_level: bool,
    /// ObjectGoal: allow start and goal on different levels (multi-floor episodes).
    #[arg(long)]
    multi_level: bool,
    /// Geodesic thresholds easy/medium and medium/hard (m), e.g. 3,6.
    #[arg(long, value_delimiter = ',', default_value = "3,6", num_args = 1)]
    bins: Vec<f32>,
    /// Stratified sampling across distance bins.
    #[arg(long, value_parser = vocab::<Stratify>(), default_value = "auto")]
    stratify: Stratify,
    /// Step limit stored in each episode.
    #[arg(long, default_value_t = minos::episode::interchange::DEFAULT_MAX_STEPS)]
    max_steps: u32,
    /// Process every n-th scene: i/n, or `auto` from the scheduler (Slurm array, Kubernetes
    /// Indexed Job with MINOS_SHARD_COUNT, or MINOS_SHARD=i/n).
    #[arg(long, value_parser = ShardSpec::parse, default_value = "0/1")]
    shard: ShardSpec,
    #[arg(long, num_args = 2, value_names = ["FORMAT", "DIR"], help = export_help())]
    export: Option<Vec<String>>,
    /// Scene path prefix written into Habitat's scene_id.
    #[arg(long, default_value = "")]
    scene_prefix: String,
    /// Scene file extension appended to Habitat's scene_id (e.g. `.glb`); the goal keys
    /// follow it.
    #[arg(long, default_value = "", value_name = "EXT")]
    scene_suffix: String,
}

/// Reads an episode file of another tool.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos episodes import --from habitat data/objectnav/val/content/X.json.gz --out x.parquet\n  \
    minos episodes import --from minos-csv episode_states.suncg.csv.bz2 --out minos_suncg.parquet\n  \
    minos episodes import --from minos-csv episode_states.mp3d.csv.bz2 --task roomgoal --out minos_mp3d_rooms.parquet"
)]
struct ImportArgs {
    /// Format of FILE.
    #[arg(long, value_parser = vocab::<ForeignFormat>())]
    from: ForeignFormat,
    /// The file (.json, .json.gz, .csv, .csv.bz2).
    file: PathBuf,
    /// Write the episodes to this Parquet file.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Read every row as this task: `roomgoal` reads MINOS's PointGoal tables as its RoomGoal
    /// configurations did (the goal is the room of each row's goal point). Default: as the
    /// file says.
    #[arg(long, value_parser = vocab::<Task>())]
    task: Option<Task>,
}

/// The help of `--export`: each format the library writes, from its vocabulary.
fn export_help() -> String {
    let formats: Vec<String> = EpisodeExport::TERMS
        .iter()
        .map(|t| format!("{}: {}", t.name, t.help))
        .collect();
    format!(
        "Also write the episodes in FORMAT into DIR ({})",
        formats.join("; ")
    )
}

/// Flags → the job (reads the split lists and checks the variant).
pub fn config(a: &SampleArgs) -> anyhow::Result<EpisodesJob> {
    let (Some(data), Some(task), Some(out)) = (a.data.as_ref(), a.task, a.out.as_ref()) else {
        bail!("--data, --task and --out are required (see `minos episodes --help`)");
    };
    if a.subset.is_some() && a.split.is_none() {
        bail!("--subset needs --split (without one, every ingested scene is used)");
    }
    let data = DataDir::new(data);
    let [easy, hard] = a.bins[..] else {
        bail!("--bins: expected two increasing distances, e.g. 3,6");
    };
    let export = match a.export.as_deref() {
        None => None,
        Some([format, dir]) => Some((
            EpisodeExport::parse_name(format).map_err(|e| anyhow::anyhow!("--export: {e}"))?,
            PathBuf::from(dir),
        )),
        Some(other) => bail!("--export: expected FORMAT DIR, got {} values", other.len()),
    };
    let exports = export.as_ref().map(|(e, _)| *e);
    let (habitat_export, vln_export) = match export {
        None => (None, None),
        Some((EpisodeExport::Habitat, dir)) => (Some(dir), None),
        Some((EpisodeExport::Vln(format), dir)) => (None, Some((format, dir))),
    };
    if a.multi_level && task != Task::ObjectGoal {
        bail!("--multi-level: only ObjectGoal keeps to one level by default; other tasks already span levels");
    }
    let (categories, all_categories) =
        expand_categories(&a.categories).context("--categories all: give it alone")?;
    let scene_names = SceneIdStyle {
        prefix: a.scene_prefix.clone(),
        suffix: a.scene_suffix.clone(),
    };
    scene_names
        .check()
        .map_err(|e| anyhow::anyhow!("--scene-suffix: {e}"))?;
    let room_classes =
        parse_room_classes(&a.room_types).map_err(|e| anyhow::anyhow!("--room-types: {e}"))?;
    let subset = a.subset;
    let stratified = a.stratify.applies(subset);
    let sample = SampleConfig {
        task,
        per_scene: a.per_scene as usize,
        seed: a.seed,
        min_island_radius: a.min_island_radius,
        success_radius: a
            .success_radius
            .unwrap_or_else(|| default_success_radius(task, a.preset)),
        categories,
        all_categories,
        min_instances: a.min_instances,
        instructions: a.instructions as usize,
        room_classes,
        select: a.select,
        min_geodesic: a.min_geodesic.unwrap_or(default_min_geodesic(task)),
        max_geodesic: a.max_geodesic,
        ratio_rule: !a.no_ratio_rule,
        min_doors: a.min_doors,
        min_rooms: a.min_rooms.unwrap_or(default_min_rooms(task)),
        same_level: a.same_level || (default_same_level(task) && !a.multi_level),
        bins: [easy, hard],
        stratified,
        max_steps: a.max_steps,
        ..SampleConfig::default()
    };
    check_options(&sample, exports).map_err(|e| match e {
        EpisodeOptionsError::BinsOutOfOrder { .. } => anyhow::anyhow!("--bins: {e}, e.g. 3,6"),
        EpisodeOptionsError::VlnExportOfOtherTask { format, .. } => anyhow::anyhow!(
            "--export {}: {e} (--task vln)",
            EpisodeExport::Vln(format).term_name()
        ),
        EpisodeOptionsError::HabitatExportOfVln => anyhow::anyhow!("--export habitat: {e}"),
        EpisodeOptionsError::MinInstancesOfOtherTask { .. } => {
            anyhow::anyhow!("--min-instances: {e}")
        }
    })?;
    // The library's errors name the split or the variant (as Python reports them).
    let scenes = select_scenes(&data, a.split.as_deref(), subset, a.variant.as_deref())?;
    Ok(EpisodesJob {
        data,
        scenes,
        sample,
        body_rule: BodyRule {
            body: a.preset.body(),
            allow_mismatch: a.allow_body_mismatch,
        },
        shard: a
            .shard
            .resolve(|k| std::env::var(k).ok())
            .map_err(anyhow::Error::msg)?,
        out: out.clone(),
        habitat_export,
        vln_export,
        scene_names,
        command: std::env::args().collect(),
        starts: a.starts.clone(),
    })
}

/// Runs `minos episodes` (or `minos episodes import`).
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    if let Some(Sub::Import(a)) = args.command {
        return import(a, ctx);
    }
    let job = config(&args.sample)?;
    let (cfg, out) = (&job.sample, &job.out);
    let outcome = {
        let bar = ctx.progress(job.scenes.len() as u64, "episodes");
        run_job(&job, &bar).map_err(|e| match e {
            EpisodesJobError::UnknownCategories { .. } => {
                anyhow::anyhow!("--categories: {}", minos::escape::error_line(&e))
            }
            other => other.into(),
        })?
    };
    for w in &outcome.warnings {
        tracing::warn!("{w}");
    }
    let (batch, stats_path) = (&outcome.batch, &outcome.stats_path);
    if let Some(dir) = &job.habitat_export {
        ctx.say(format!("exported Habitat episodes -> {}", dir.display()));
    }
    if let Some((format, dir)) = &job.vln_export {
        ctx.say(format!(
            "exported {} episodes -> {}",
            match format {
                VlnFormat::VlnCe => "VLN-CE",
                VlnFormat::R2r => "R2R",
            },
            dir.display()
        ));
    }
    let top: Vec<String> = {
        let mut r: Vec<(&String, &u64)> = batch.rejected.iter().collect();
        r.sort_by(|x, y| y.1.cmp(x.1));
        r.iter().take(3).map(|(k, v)| format!("{k}: {v}")).collect()
    };
    ctx.say(format!(
        "{} {} episodes from {} scenes -> {} (mean geodesic {:.2} m, geodesic/Euclidean {:.3}; \
         rejected draws: {}; details in {})",
        batch.total,
        cfg.task.name(),
        batch.scenes.len(),
        out.display(),
        batch.mean_geodesic,
        batch.mean_ratio,
        if top.is_empty() {
            "none".to_string()
        } else {
            top.join(", ")
        },
        stats_path.display()
    ));
    let failed = batch.scenes.values().filter(|s| s.episodes == 0).count();
    if failed > 0 {
        ctx.say(format!("{failed} scenes yielded no episode (see warnings)"));
    }
    Ok(ExitCode::SUCCESS)
}

fn import(a: ImportArgs, ctx: &Context) -> anyhow::Result<ExitCode> {
    let report = import_job(&ImportJob {
        from: a.from,
        file: a.file.clone(),
        task: a.task,
        out: a.out.clone(),
        command: std::env::args().collect(),
    })?;
    ctx.say(format!(
        "read {} episodes of {} scenes from {}",
        report.episodes.len(),
        report.scenes,
        a.file.display()
    ));
    if let Some((out, record)) = &report.written {
        ctx.say(format!(
            "wrote {} episodes -> {} (provenance: {})",
            report.episodes.len(),
            out.display(),
            record.display()
        ));
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::common::parse_flags;

    fn config_of(line: &str) -> anyhow::Result<EpisodesJob> {
        config(&parse_flags::<SampleArgs>(line).expect("flags parse"))
    }

    #[test]
    fn flags_are_checked_before_any_file_is_read() {
        let err = config_of("--task pointgoal --split s --out o.parquet").unwrap_err();
        assert!(err.to_string().contains("--data"), "{err}");
        let base = "--data /nonexistent --task pointgoal --split s --out o.parquet";
        let err = config_of(&format!("{base} --bins 6,3")).unwrap_err();
        assert_eq!(
            err.to_string(),
            "--bins: expected two increasing distances, e.g. 3,6"
        );
        let err = config_of(&format!("{base} --export hm3d dir")).unwrap_err();
        assert!(err.to_string().contains("unknown format `hm3d`"), "{err}");
        let err = config_of(&format!("{base} --scene-suffix x/.glb")).unwrap_err();
        assert!(err.to_string().starts_with("--scene-suffix: "), "{err}");
        assert!(err.to_string().contains("path separator"), "{err}");
        let err = config_of(&format!("{base} --room-types kitchen,attic")).unwrap_err();
        assert!(err.to_string().contains("`attic`"), "{err}");
        // Only then is the split read: a missing DATA folder names the split.
        let err = config_of(base).unwrap_err();
        assert!(err.to_string().contains("split `s`"), "{err}");
        assert!(parse_flags::<SampleArgs>(&format!("{base} --subset dev")).is_err());
        assert!(parse_flags::<SampleArgs>(&format!("{base} --preset default")).is_err());
    }

    #[test]
    fn the_split_the_subset_and_the_body_shape_the_job() {
        let dir = tempfile::tempdir().unwrap();
        let data = DataDir::new(dir.path());
        let lists = minos::split::SplitLists {
            train: vec!["a".into(), "b".into()],
            val: vec!["c".into()],
            test: vec![],
        };
        minos::split::write_split(&data, "s", &lists).unwrap();
        let line = format!(
            "--data {} --task roomgoal --split s --subset val --out o.parquet --preset minos",
            dir.path().display()
        );
        let job = config_of(&line).unwrap();
        assert_eq!(job.scenes, [("c".to_string(), "val".to_string())]);
        assert!(job.sample.stratified, "val subsets stratify by default");
        assert_eq!(job.body_rule.body, minos::body::AgentBody::MINOS);
        assert!(!job.body_rule.allow_mismatch);
        let job = config_of(&line.replace(" --subset val", "")).unwrap();
        assert_eq!(job.scenes.len(), 3);
        assert!(!job.sample.stratified);
        assert_eq!(job.scene_names, SceneIdStyle::default());
    }

    #[test]
    fn point_goals_of_minos_presets_get_minos_success_radius() {
        let dir = tempfile::tempdir().unwrap();
        let data = DataDir::new(dir.path());
        let lists = minos::split::SplitLists {
            train: vec!["a".into()],
            val: vec![],
            test: vec![],
        };
        minos::split::write_split(&data, "s", &lists).unwrap();
        let radius = |extra: &str| {
            let line = format!(
                "--data {} --split s --out o.parquet {extra}",
                dir.path().display()
            );
            config_of(&line).unwrap().sample.success_radius
        };
        assert_eq!(radius("--task pointgoal"), 0.2, "Habitat's");
        for preset in ["minos", "minos-gridworld", "minos-paper"] {
            assert_eq!(radius(&format!("--task pointgoal --preset {preset}")), 0.4);
            assert_eq!(radius(&format!("--task objectgoal --preset {preset}")), 0.2);
        }
        assert_eq!(
            radius("--task pointgoal --preset minos-paper --success-radius 0.3"),
            0.3
        );
    }

    #[test]
    fn objectgoal_keeps_to_one_level_presets_expand_and_vln_has_its_defaults() {
        let dir = tempfile::tempdir().unwrap();
        let data = DataDir::new(dir.path());
        let lists = minos::split::SplitLists {
            train: vec!["a".into()],
            val: vec![],
            test: vec![],
        };
        minos::split::write_split(&data, "s", &lists).unwrap();
        let base = format!("--data {} --split s --out o.parquet", dir.path().display());
        let job = |extra: &str| config_of(&format!("{base} {extra}"));
        assert!(job("--task objectgoal").unwrap().sample.same_level);
        assert!(
            !job("--task objectgoal --multi-level")
                .unwrap()
                .sample
                .same_level
        );
        assert!(!job("--task pointgoal").unwrap().sample.same_level);
        assert!(
            job("--task pointgoal --same-level")
                .unwrap()
                .sample
                .same_level
        );
        let err = job("--task pointgoal --multi-level").unwrap_err();
        assert!(err.to_string().starts_with("--multi-level"), "{err}");
        let hm3d = job("--task objectgoal --categories hm3d").unwrap().sample;
        assert_eq!(hm3d.categories, minos::episode::sample::HM3D_OBJECTNAV);
        let mixed = job("--task objectgoal --categories minos,bed")
            .unwrap()
            .sample;
        assert_eq!(mixed.categories, ["door", "arch", "bed"]);
        let all = job("--task objectgoal --categories all --min-instances 2")
            .unwrap()
            .sample;
        assert!(all.all_categories && all.categories.is_empty());
        assert_eq!(all.min_instances, 2);
        assert!(job("--task objectgoal --categories all,bed").is_err());
        let err = job("--task pointgoal --min-instances 2").unwrap_err();
        assert!(err.to_string().starts_with("--min-instances: "), "{err}");
        let vln = job("--task vln").unwrap().sample;
        assert_eq!(vln.task, Task::Vln);
        assert_eq!(
            (
                vln.min_geodesic,
                vln.min_rooms,
                vln.success_radius,
                vln.instructions
            ),
            (4.0, 2, 3.0, 3)
        );
        let vln = job("--task vln --min-geodesic 2 --min-rooms 1 --instructions 5")
            .unwrap()
            .sample;
        assert_eq!(
            (vln.min_geodesic, vln.min_rooms, vln.instructions),
            (2.0, 1, 5)
        );
        let j = job("--task vln --export vlnce out").unwrap();
        assert_eq!(j.vln_export, Some((VlnFormat::VlnCe, PathBuf::from("out"))));
        assert_eq!(j.habitat_export, None);
        let j = job("--task vln --export r2r out").unwrap();
        assert_eq!(j.vln_export, Some((VlnFormat::R2r, PathBuf::from("out"))));
        let err = job("--task pointgoal --export vlnce out").unwrap_err();
        assert_eq!(
            err.to_string(),
            "--export vlnce: VLN exports need task `vln`, not `pointgoal` (--task vln)"
        );
        let err = job("--task vln --export habitat out").unwrap_err();
        assert_eq!(
            err.to_string(),
            "--export habitat: VLN episodes export as `vlnce` (habitat-lab's R2RVLN-v1) or `r2r`"
        );
    }

    #[test]
    fn scene_prefix_and_suffix_name_the_habitat_scenes() {
        let dir = tempfile::tempdir().unwrap();
        let data = DataDir::new(dir.path());
        let lists = minos::split::SplitLists {
            train: vec!["a".into()],
            val: vec![],
            test: vec![],
        };
        minos::split::write_split(&data, "s", &lists).unwrap();
        let job = config_of(&format!(
            "--data {} --task objectgoal --split s --out o.parquet --export habitat h \
             --scene-prefix data/scene_datasets/minos/ --scene-suffix .glb",
            dir.path().display()
        ))
        .unwrap();
        assert_eq!(job.habitat_export, Some(PathBuf::from("h")));
        assert_eq!(
            job.scene_names.scene_id("a"),
            "data/scene_datasets/minos/a.glb"
        );
    }

    #[test]
    fn without_a_split_every_ingested_scene_is_used() {
        let dir = tempfile::tempdir().unwrap();
        let data = DataDir::new(dir.path());
        let row =
            |id: &str| minos::store::manifest::ManifestRow::failed(id, "suncg", "/x", "".into());
        let mut rows = vec![row("a"), row("b"), row("c")];
        for r in &mut rows[..2] {
            r.error = None;
        }
        minos::store::manifest::write_manifest(&data.manifest_path(), &rows).unwrap();
        let line = format!(
            "--data {} --task pointgoal --out o.parquet",
            dir.path().display()
        );
        let job = config_of(&line).unwrap();
        assert_eq!(
            job.scenes,
            [
                ("a".to_string(), String::new()),
                ("b".to_string(), String::new())
            ],
            "scenes that failed to ingest are left out"
        );
        let err = config_of(&format!("{line} --subset val")).unwrap_err();
        assert!(err.to_string().contains("--subset needs --split"), "{err}");
        let empty = tempfile::tempdir().unwrap();
        let err = config_of(&format!(
            "--data {} --task pointgoal --out o.parquet",
            empty.path().display()
        ))
        .unwrap_err();
        // Nothing ingested: the error says so as data; `main` adds "run `minos ingest`".
        assert_eq!(
            minos::store::remedy::remedy_of(err.as_ref()),
            Some(minos::store::remedy::Remedy::Ingest),
            "{err}"
        );
    }
}
