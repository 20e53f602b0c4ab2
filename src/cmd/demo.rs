//! `minos demo`: the README's main job. Runs every stage that exists on generated houses
//! (generate → ingest → split → stats) into one folder and says where everything is.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use minos::episode::Task;
use minos::io::run_dir::RunDir;
use minos::pipeline::demo::{DemoJob, DemoObserver, DemoStage};
use minos::progress::Progress;
use minos::run::metrics::render_table;
use minos::stats;

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

/// Flags → the job.
fn config(args: &Args) -> DemoJob {
    DemoJob {
        out: args.out.clone(),
        houses: args.houses,
        seed: args.seed,
        command: std::env::args().collect(),
    }
}

/// Prints each stage as it ends, and shows its progress.
impl DemoObserver for Context {
    fn progress(&self, total: u64, what: &str) -> Box<dyn Progress + '_> {
        Box::new(Context::progress(self, total, what))
    }

    fn finished(&self, stage: DemoStage<'_>) {
        match stage {
            DemoStage::Generated { houses, root } => self.say(format!(
                "1/7 generated {houses} houses      -> {}",
                root.display()
            )),
            DemoStage::Ingested(report) => self.say(format!(
                "2/7 ingested {} scenes ({} failed) -> {}",
                report.scenes.len(),
                report.count(minos::pipeline::ingest::Outcome::Failed),
                report.manifest.display()
            )),
            DemoStage::Split { all, multiroom } => {
                let (a, m) = (&all.result.lists, &multiroom.result.lists);
                self.say(format!(
                    "3/7 splits: all {}/{}/{} -> {}, multiroom (3-5 rooms) {}/{}/{} -> {}",
                    a.train.len(),
                    a.val.len(),
                    a.test.len(),
                    all.dir.display(),
                    m.train.len(),
                    m.val.len(),
                    m.test.len(),
                    multiroom.dir.display()
                ));
            }
            DemoStage::Statistics(columns) => {
                self.say("4/7 statistics of split `all`:");
                self.say(stats::render_table(columns));
            }
            DemoStage::Baked {
                scenes,
                report,
                nav_dir,
            } => {
                for (id, e) in report.failures() {
                    eprintln!("error: scene {id}: {e}");
                }
                self.say(format!(
                    "5/7 baked {scenes} navigation grids ({} failed) -> {}",
                    report.failures().count(),
                    nav_dir.display()
                ));
            }
            DemoStage::Episodes {
                batches,
                dir,
                oracle_episodes,
                oracle_file,
            } => {
                let written: Vec<String> = batches
                    .iter()
                    .map(|(task, b)| format!("{} {}", b.total, task.name()))
                    .collect();
                self.say(format!(
                    "6/7 episodes: {} -> {} (the oracle's {oracle_episodes} in {})",
                    written.join(", "),
                    dir.display(),
                    oracle_file.display()
                ));
            }
            DemoStage::Oracle {
                report,
                dir,
                recording,
            } => {
                self.say(format!(
                    "7/7 oracle rollouts (RGB-D-semantic 84², Habitat agent) of {} validation \
                     episodes -> {} (Parquet tables and a LeRobot v3.0 dataset in lerobot/), {} \
                     recorded -> {}",
                    report.episodes.len(),
                    dir.display(),
                    report.recorded,
                    recording.display()
                ));
                self.say(render_table(&report.groups));
            }
        }
    }
}

/// Runs `minos demo`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let start = Instant::now();
    let report = config(&args).run(ctx.lock_mode, ctx)?;
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
        rrd = report.recording.display(),
        nav = minos::store::DataDir::new(&report.data).nav_dir().display(),
        d = report.data.display(),
        id = report.first_scene.as_deref().unwrap_or("ID"),
        e = report.episode_file(Task::PointGoal).display(),
        r = RunDir::new(&report.run).observations().display(),
        lr = RunDir::new(&report.run).lerobot().display(),
        demos = args.out.join("demos").display(),
    ));
    Ok(
        if report.ingest_failures == 0 && report.bake_failures == 0 {
            ExitCode::SUCCESS
        } else {
            ExitCode::FAILURE
        },
    )
}
