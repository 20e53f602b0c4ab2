//! `minos demo`: the README's main job. Runs every stage that exists on generated houses
//! (generate → ingest → split → stats) into one folder and says where everything is.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context as _;
use minos::body::{AgentPreset, BodyRule};
use minos::episode::format::write_episodes;
use minos::episode::sample::SampleConfig;
use minos::episode::Task;
use minos::generate::{generate, GenerateConfig, OutputFormat};
use minos::io::tables::ImageEncoding;
use minos::navmesh::NavParams;
use minos::pipeline::bake::{bake, BakeConfig};
use minos::pipeline::episodes::{run_job, EpisodesJob};
use minos::pipeline::ingest::{ingest, IngestConfig, Outcome};
use minos::pipeline::rollout::{run as rollout, AgentKind, Provenance, RerunOutput, RunConfig};
use minos::pipeline::split::{make_split, Method, SplitJob, SplitReport};
use minos::render::RendererChoice;
use minos::run::metrics::{render_table, Reward};
use minos::shard::Shard;
use minos::sim::{AgentConfig, SensorSuite};
use minos::split::{Expr, Ratios};
use minos::stats;
use minos::store::DataDir;

use super::Context;

/// Run the pipeline on procedural houses into ./minos-demo/.
///
/// Generates houses in SUNCG's layout, ingests them into a DATA folder (compiled scenes and
/// a Parquet manifest), writes a seeded 60/20/20 split and MINOS's multi-room split
/// (3 to 5 rooms), prints environment statistics, bakes navigation grids with previews, and
/// samples PointGoal, ObjectGoal (doors) and RoomGoal episodes, and rolls out the oracle on
/// the validation episodes (episodes/oracle_val.parquet) into Parquet datasets with metrics and
/// the run's manifest.json, recording the first for the rerun viewer (episode.rrd).
/// Re-running resumes.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos demo\n  minos demo --houses 200 --seed 3 --out /tmp/demo"
)]
pub struct Args {
    /// Output folder.
    #[arg(long, default_value = "minos-demo")]
    out: PathBuf,
    /// Number of houses to generate.
    #[arg(long, default_value_t = 48)]
    houses: usize,
    /// Seed of the houses and splits.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

/// Runs `minos demo`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let start = Instant::now();
    let root = args.out.join("suncg");
    let data = args.out.join("data");
    let cfg = GenerateConfig {
        houses: args.houses,
        seed: args.seed,
        ..GenerateConfig::default()
    };
    {
        let bar = ctx.progress(cfg.houses as u64, "generate");
        generate(&cfg, OutputFormat::Suncg, &root, false, &bar).context("generate")?;
    }
    ctx.say(format!(
        "1/7 generated {} houses      -> {}",
        cfg.houses,
        root.display()
    ));
    let report = {
        let bar = ctx.progress(0, "ingest");
        ingest(&IngestConfig::suncg(&root, &data), &bar).context("ingest")?
    };
    let failed = report.count(Outcome::Failed);
    ctx.say(format!(
        "2/7 ingested {} scenes ({failed} failed) -> {}",
        report.scenes.len(),
        report.manifest.display()
    ));
    let store = DataDir::new(&data);
    // One agent for every stage: the grids are baked for the body the oracle moves.
    let preset = AgentPreset::default();
    let ratios = Ratios::new([0.6, 0.2, 0.2])?;
    let multiroom = Expr::parse("nrooms > 2 && nrooms < 6").context("demo filter")?;
    let split = |name: &str, filter: Option<Expr>| {
        let job = SplitJob {
            data: store.clone(),
            name: name.to_string(),
            filter,
            method: Method::Ratios(ratios, args.seed),
        };
        make_split(&job, ctx.lock_mode).with_context(|| format!("split {name}"))
    };
    let SplitReport {
        result: all,
        dir: all_dir,
    } = split("all", None)?;
    let SplitReport {
        result: mr,
        dir: mr_dir,
    } = split("multiroom", Some(multiroom))?;
    let rows = store.read_manifest()?;
    ctx.say(format!(
        "3/7 splits: all {}/{}/{} -> {}, multiroom (3-5 rooms) {}/{}/{} -> {}",
        all.lists.train.len(),
        all.lists.val.len(),
        all.lists.test.len(),
        all_dir.display(),
        mr.lists.train.len(),
        mr.lists.val.len(),
        mr.lists.test.len(),
        mr_dir.display()
    ));
    ctx.say("4/7 statistics of split `all`:");
    ctx.say(stats::render_table(&stats::compute_split(
        &rows, &all.lists,
    )));
    let ids: Vec<String> = rows
        .iter()
        .filter(|r| r.error.is_none())
        .map(|r| r.id.clone())
        .collect();
    let bake = {
        let bar = ctx.progress(ids.len() as u64, "bake");
        let cfg = BakeConfig {
            data: store.clone(),
            scenes: store.refs(&ids, None)?,
            params: NavParams::preset(preset),
            force: false,
            previews: true,
        };
        // The driver holds DATA's lock and rewrites its provenance record.
        bake(&cfg, minos::shard::Shard::ALL, ctx.lock_mode, &bar)?
    };
    let bake_failed = bake.failures().count();
    for (id, e) in bake.failures() {
        eprintln!("error: scene {id}: {e}");
    }
    ctx.say(format!(
        "5/7 baked {} navigation grids ({bake_failed} failed) -> {}",
        ids.len(),
        store.nav_dir().display()
    ));
    let scenes: Vec<(String, String)> = [
        ("train", &all.lists.train),
        ("val", &all.lists.val),
        ("test", &all.lists.test),
    ]
    .iter()
    .flat_map(|(subset, ids)| ids.iter().map(move |id| (id.clone(), subset.to_string())))
    .collect();
    let episodes_dir = args.out.join("episodes");
    let mut written = Vec::new();
    let mut validation = Vec::new();
    for task in [Task::PointGoal, Task::ObjectGoal, Task::RoomGoal] {
        let cfg = SampleConfig {
            task,
            per_scene: 10,
            seed: args.seed,
            ..SampleConfig::default()
        };
        // As `minos episodes` samples and writes them: statistics and provenance beside.
        let job = EpisodesJob {
            data: store.clone(),
            scenes: scenes.clone(),
            sample: cfg,
            body_rule: BodyRule::strict(preset.body()),
            shard: Shard::ALL,
            out: episodes_dir.join(format!("{}.parquet", task.name())),
            habitat_export: None,
            vln_export: None,
            scene_names: Default::default(),
            command: std::env::args().collect(),
            starts: None,
        };
        let batch = {
            let bar = ctx.progress(scenes.len() as u64, task.name());
            run_job(&job, &bar)?.batch
        };
        written.push(format!("{} {}", batch.total, task.name()));
        // The oracle demonstrates the validation episodes (3 per scene and task).
        validation.extend(
            batch
                .episodes
                .into_iter()
                .filter(|e| e.split == "val" && e.episode_id.ends_with(|c: char| c < '3')),
        );
    }
    // The oracle's episodes in a file of their own, which its manifest.json names, so the
    // run can be repeated with `minos run --episodes`.
    let validation_file = episodes_dir.join("oracle_val.parquet");
    write_episodes(&validation_file, &validation)
        .with_context(|| validation_file.display().to_string())?;
    ctx.say(format!(
        "6/7 episodes: {} -> {} (the oracle's {} in {})",
        written.join(", "),
        episodes_dir.display(),
        validation.len(),
        validation_file.display()
    ));
    let run_dir = args.out.join("runs").join("oracle");
    let recording = args.out.join("episode.rrd");
    let run_cfg = RunConfig {
        batch: None,
        data: store.clone(),
        out: run_dir.clone(),
        agent: AgentKind::Oracle,
        agent_config: AgentConfig::preset(preset),
        sensors: SensorSuite::minos(84),
        renderer: RendererChoice::Cpu,
        max_steps: None,
        seed: args.seed,
        shard: Shard::ALL,
        resume: true,
        reward: Reward::Geodesic,
        encoding: ImageEncoding::Raw,
        lerobot: true,
        lerobot_video: false,
        rerun: Some(RerunOutput {
            path: recording.clone(),
            episodes: 1,
        }),
        allow_body_mismatch: false,
        provenance: Provenance {
            command: std::env::args().collect(),
            episodes_file: Some(validation_file.clone()),
            variant: None,
            agent: "oracle".into(),
            preset: Some(preset),
        },
    };
    let report = {
        let bar = ctx.progress(validation.len() as u64, "oracle");
        rollout(&run_cfg, &validation, &bar)?
    };
    ctx.say(format!(
        "7/7 oracle rollouts (RGB-D-semantic 84², Habitat agent) of {} validation episodes -> {} \
         (Parquet tables and a LeRobot v3.0 dataset in lerobot/), {} recorded -> {}",
        report.episodes.len(),
        run_dir.display(),
        report.recorded,
        recording.display()
    ));
    ctx.say(render_table(&report.groups));
    ctx.say(format!(
        "done in {:.1} s. Next:\n  rerun {rrd}   (scrub the recorded episode: `pip install rerun-sdk==0.36.*`)\n  \
         minos view --data {d} --scene {id} --episodes {e} --out {id}.rrd\n  \
         open {nav}/<scene>.L0.png to see a navigation grid\n  \
         minos nav query --data {d} --scene {id} --from X,0,Z --to X,0,Z\n  \
         minos stats --data {d} --split multiroom\n  \
         minos export --data {d} --scene {id} --out house.glb   (open in Blender)\n  \
         python: pandas.read_parquet(\"{e}\"), pyarrow.parquet.read_table(\"{r}\")\n  \
         lerobot: LeRobotDataset(\"minos/demo\", root=\"{lr}\")\n  \
         minos serve --data {d} --episodes {e} --out {demos}   (play the episodes in a browser and record demonstrations)",
        start.elapsed().as_secs_f64(),
        rrd = recording.display(),
        nav = store.nav_dir().display(),
        d = data.display(),
        id = ids.first().map(String::as_str).unwrap_or("ID"),
        e = episodes_dir.join("pointgoal.parquet").display(),
        r = minos::io::run_dir::RunDir::new(&run_dir)
            .observations()
            .display(),
        lr = minos::io::run_dir::RunDir::new(&run_dir).lerobot().display(),
        demos = args.out.join("demos").display(),
    ));
    Ok(if failed == 0 && bake_failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
