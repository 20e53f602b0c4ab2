//! `minos bench`: how fast minos runs on one ingested scene — anyone's own data — stage by
//! stage, on the calling thread (so figures are per core).
//!
//! Four benchmarks share the stages they need:
//! - `bake`: load the compiled scene, bake its grid (nothing is written);
//! - `episodes`: read the scene's grid, sample PointGoal episodes;
//! - `render`: load scene and grid, set up the simulator, render the sensors' images from
//!   random walkable poses (a frame is one observation: every image of every camera);
//! - `run`: the rollout loop of `minos run` with the oracle — sample PointGoal episodes, reset,
//!   plan, decide and step the simulator (nothing is written); with more than one thread
//!   asked for, the same loop once more on that many threads at once (each its own
//!   simulator and oracle on the shared scene, claiming the next episode, as `minos run`
//!   does), timed by the wall clock: the machine's throughput.
//!
//! With a GPU renderer, `render` adds batched stages (`bench/gpu.rs`): batches of views rendered
//! with one submission and read-back, and the same with colour, depth and semantic images
//! derived on all threads, timed by the wall clock; `run` with `envs` adds the rollout loop
//! with that many environments stepped together (`bench/batched.rs`: every environment's cameras
//! in one render call per step), wall clock. Stages after set-up are timed by the wall clock
//! with a GPU renderer, whose work this thread's CPU time does not see.
//!
//! Each stage reports how many items it did (scenes, episodes, frames, steps) and the CPU
//! time of this thread (wall time where the platform does not say). Random choices (poses,
//! episodes) derive from `(seed, scene id, purpose)`, so the counts of two runs agree; only
//! the timings differ. The resident memory after loading the scene is reported too.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::Vec3;

use crate::body::BodyRule;
use crate::episode::interchange::DEFAULT_MAX_STEPS;
use crate::episode::sample::{sample_scene, SampleConfig};
use crate::episode::{Episode, Task};
use crate::navmesh::build::build;
use crate::navmesh::geodesic::Geodesic;
use crate::navmesh::{NavGrid, NavParams};
use crate::render::Renderer;
use crate::render::RendererChoice;
use crate::run::agents::{Agent, Decision};
use crate::run::oracle::OracleAgent;
use crate::run::stepper::{EpisodeStepper, StepperConfig};
use crate::scene::{Scene, SceneRef};
use crate::seed::{derive_seed, Rng};
use crate::sim::{AgentConfig, SceneAssets, SensorSuite, Simulator};
use crate::store::DataDir;

mod batched;
mod gpu;
pub use batched::{BATCHED, PHASES, STARTS_POOL_ENV};
pub use gpu::{GPU_BATCH, GPU_DERIVED, GPU_IMAGES};

/// Which benchmark to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BenchKind {
    /// Loading and baking the scene's grid.
    Bake,
    /// Sampling PointGoal episodes.
    Episodes,
    /// Rendering the sensors' images.
    Render,
    /// The oracle's rollout loop.
    Run,
}

impl BenchKind {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        crate::vocab::Vocabulary::term_name(self)
    }
}

impl crate::vocab::Vocabulary for BenchKind {
    const WHAT: &'static str = "benchmark";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: BenchKind::Bake,
            name: "bake",
            aliases: &[],
            help: "load the compiled scene and bake its grid (nothing written)",
        },
        crate::vocab::Term {
            value: BenchKind::Episodes,
            name: "episodes",
            aliases: &[],
            help: "sample PointGoal episodes on the scene's grid",
        },
        crate::vocab::Term {
            value: BenchKind::Render,
            name: "render",
            aliases: &[],
            help: "render the sensors from random walkable poses",
        },
        crate::vocab::Term {
            value: BenchKind::Run,
            name: "run",
            aliases: &[],
            help: "the oracle's rollout loop (reset, plan, decide, step; nothing written), \
                   then on all threads at once by the wall clock",
        },
    ];
}

crate::vocab::name_traits!(BenchKind);

/// What to measure.
#[derive(Debug, Clone)]
pub struct BenchConfig {
    /// The DATA folder.
    pub data: DataDir,
    /// The scene (`None`: the first scene of the manifest ingested without error).
    pub scene: Option<SceneRef>,
    /// The benchmark.
    pub kind: BenchKind,
    /// The agent (its body is the one the grid must be baked for; `bake` bakes for it).
    pub agent: AgentConfig,
    /// Sensors of `render` and `run`.
    pub sensors: SensorSuite,
    /// Renderer of `render` and `run`.
    pub renderer: RendererChoice,
    /// Poses rendered by `render`.
    pub frames: usize,
    /// Episodes sampled by `episodes` and rolled out by `run`.
    pub episodes: usize,
    /// Seed of poses and episodes.
    pub seed: u64,
    /// Accept a grid baked for another body.
    pub allow_body_mismatch: bool,
    /// Threads of `run`'s last stage, the rollout loop on that many threads at once (wall
    /// clock), and of `render`'s GPU stage that derives images; 1: no `run` stage.
    pub threads: usize,
    /// Views per batch of `render`'s batched GPU stages (with a GPU renderer; 0: none).
    pub batch: usize,
    /// Environments of `run`'s batched rollout stage, stepped together on `threads`
    /// threads (0: none).
    pub envs: usize,
    /// Run `run`'s per-core stages (else only the all-threads and batched rows, the
    /// machine's throughput).
    pub per_core: bool,
}

/// Name of `run`'s stage on all threads.
pub const ALL_THREADS: &str = "rollout loop, all threads";

/// One measured stage.
#[derive(Debug, Clone, PartialEq)]
pub struct Stage {
    /// What was done (`load scene`, `bake`, `sample`, `render`, `sim step`, …).
    pub name: &'static str,
    /// How many items.
    pub count: u64,
    /// What the items are (`scenes`, `episodes`, `frames`, `steps`).
    pub unit: &'static str,
    /// Seconds of this thread's CPU time (wall time where that is unavailable, or where
    /// [`Stage::wall`] says).
    pub seconds: f64,
    /// Timed by the wall clock (stages on several threads, or waiting for a GPU), whatever
    /// the report's clock.
    pub wall: bool,
}

impl Stage {
    /// Items per second (per core); 0 when nothing was timed.
    pub fn per_second(&self) -> f64 {
        if self.seconds > 0.0 {
            self.count as f64 / self.seconds
        } else {
            0.0
        }
    }
}

/// What a benchmark measured.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchReport {
    /// The benchmark.
    pub kind: BenchKind,
    /// The scene measured.
    pub scene: String,
    /// Its triangles.
    pub triangles: u64,
    /// Walkable spans of its grid (baked or read).
    pub walkable_spans: u64,
    /// Resident memory of the process after loading the scene (and grid), bytes (0 where the
    /// platform does not say).
    pub rss_after_load: u64,
    /// Resident memory the loading added, bytes.
    pub rss_of_load: u64,
    /// Peak resident memory of the process at the end, bytes (0 where unknown).
    pub rss_peak: u64,
    /// Whether stage times are thread CPU time (else wall time).
    pub cpu_time: bool,
    /// Threads of the [`ALL_THREADS`] stage (timed by the wall clock); 1 when there is none.
    pub threads: usize,
    /// The GPU adapter of the GPU stages, if any.
    pub adapter: Option<String>,
    /// Views per batch of the batched GPU stages (0: none).
    pub batch: usize,
    /// Environments of the [`BATCHED`] stage (0: none).
    pub envs: usize,
    /// The stages, in order.
    pub stages: Vec<Stage>,
}

impl BenchReport {
    /// The stage named `name`.
    pub fn stage(&self, name: &str) -> Option<&Stage> {
        self.stages.iter().find(|s| s.name == name)
    }

    /// The report as JSON (for scripts).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "bench": self.kind.name(),
            "scene": self.scene,
            "triangles": self.triangles,
            "walkable_spans": self.walkable_spans,
            "rss_after_load_bytes": self.rss_after_load,
            "rss_of_load_bytes": self.rss_of_load,
            "rss_peak_bytes": self.rss_peak,
            "clock": if self.cpu_time { "thread-cpu" } else { "wall" },
            "threads": self.threads,
            "adapter": self.adapter,
            "views_per_batch": self.batch,
            "envs": self.envs,
            "stages": self.stages.iter().map(|s| serde_json::json!({
                "stage": s.name,
                "count": s.count,
                "unit": s.unit,
                "seconds": s.seconds,
                "per_second": s.per_second(),
                "clock": if s.wall || !self.cpu_time { "wall" } else { "thread-cpu" },
            })).collect::<Vec<_>>(),
        })
    }

    /// The report as a Markdown table, with a header line.
    pub fn table(&self) -> String {
        let mut out = format!(
            "{} on {}: {} triangles, {} walkable spans, {:.0} MB resident after loading ({:.0} MB for the scene), {:.0} MB peak; {} time of one thread\n\n\
             | stage | count | unit | seconds | per second (1 core) |\n|---|---|---|---|---|\n",
            self.kind.name(),
            self.scene,
            self.triangles,
            self.walkable_spans,
            self.rss_after_load as f64 / 1e6,
            self.rss_of_load as f64 / 1e6,
            self.rss_peak as f64 / 1e6,
            if self.cpu_time { "CPU" } else { "wall" },
        );
        if self.threads > 1 {
            out.insert_str(
                out.find('\n').unwrap_or(out.len()),
                &format!("; `{ALL_THREADS}`: {} threads, wall clock", self.threads),
            );
        }
        if self.envs > 0 {
            out.insert_str(
                out.find('\n').unwrap_or(out.len()),
                &format!("; `{BATCHED}`: {} environments stepped together", self.envs),
            );
        }
        if let Some(adapter) = &self.adapter {
            let batch = if self.batch > 0 {
                format!(", {} views per batch", self.batch)
            } else {
                String::new()
            };
            out.insert_str(
                out.find('\n').unwrap_or(out.len()),
                &format!("; GPU: {adapter}{batch}; stages marked (wall) by the wall clock"),
            );
        }
        for s in &self.stages {
            let wall = if s.wall && self.cpu_time {
                " (wall)"
            } else {
                ""
            };
            out.push_str(&format!(
                "| {}{wall} | {} | {} | {:.4} | {:.1} |\n",
                s.name,
                s.count,
                s.unit,
                s.seconds,
                s.per_second()
            ));
        }
        out
    }
}

/// Why a benchmark could not run (one line).
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// A pool of `threads` threads could not be made.
    #[error("a {threads}-thread pool")]
    Pool {
        /// Its size.
        threads: usize,
        /// The cause.
        #[source]
        source: rayon::ThreadPoolBuildError,
    },
    /// A rollout thread panicked.
    #[error("a rollout thread panicked")]
    WorkerPanicked,
    /// The DATA folder could not be read (its manifest, a scene, a grid); `hint` says which
    /// step makes what is missing.
    #[error("cannot read the DATA folder{hint}")]
    Data {
        /// The cause.
        #[source]
        source: crate::store::StoreError,
        /// ` (ingest the scene first)`, ` (bake the scene first)` or nothing.
        hint: &'static str,
    },
    /// No scene of the manifest was ingested without error.
    #[error("{}: no scene ingested without error (ingest the scenes first)", .0.display())]
    NothingIngested(std::path::PathBuf),
    /// The scene's grid was baked for another body.
    #[error("{scene}")]
    Body {
        /// The scene.
        scene: String,
        /// The mismatch.
        #[source]
        source: crate::body::BodyMismatch,
    },
    /// Baking failed.
    #[error(transparent)]
    Bake(#[from] crate::navmesh::build::BuildError),
    /// The scene's simulator could not be made.
    #[error(transparent)]
    Simulator(#[from] crate::sim::SimError),
    /// The renderer failed (making it, or a frame).
    #[error(transparent)]
    Render(#[from] crate::render::gpu::GpuError),
    /// An agent could not decide.
    #[error(transparent)]
    Agent(#[from] crate::run::agents::AgentError),
    /// A lockstep of the batched rollout failed.
    #[error(transparent)]
    Step(#[from] crate::run::stepper::StepError),
    /// The GPU batch benchmark has nothing to render.
    #[error("GPU batch: {0}")]
    GpuBatch(&'static str),
    /// What the benchmark needs was not loaded (a bug: each kind loads what it needs).
    #[error("no {0}")]
    NotLoaded(&'static str),
    /// The scene gave nothing to measure (`no PointGoal episode could be sampled`, `the
    /// grid has no walkable floor`).
    #[error("{scene}: {what}")]
    Empty {
        /// The scene.
        scene: String,
        /// What it lacks.
        what: &'static str,
    },
}

impl BenchError {
    fn data(hint: &'static str) -> impl Fn(crate::store::StoreError) -> BenchError {
        move |source| BenchError::Data { source, hint }
    }
}

/// This thread's CPU time, where the platform says (Linux).
fn thread_cpu() -> Option<Duration> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    Some(Duration::from_nanos(
        s.split_whitespace().next()?.parse().ok()?,
    ))
}

/// Resident memory of the process in bytes, where the platform says (Linux).
pub fn resident_bytes() -> Option<u64> {
    status_bytes("VmRSS:")
}

/// A `kB` field of `/proc/self/status`, in bytes.
fn status_bytes(field: &str) -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with(field))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Times closures in thread CPU time (wall time where unavailable, or once `wall` is set)
/// into stages.
struct Timer {
    stages: Vec<Stage>,
    cpu: bool,
    /// Time by the wall clock from now on (work on a GPU, which this thread's CPU time does
    /// not see), marking the stages so.
    wall: bool,
}

impl Timer {
    fn new() -> Self {
        Timer {
            stages: Vec::new(),
            cpu: thread_cpu().is_some(),
            wall: false,
        }
    }

    /// Seconds `f` took.
    fn measure<R>(&self, f: impl FnOnce() -> R) -> (R, f64) {
        let (c0, w0) = (thread_cpu(), Instant::now());
        let r = f();
        let s = match (c0, thread_cpu()) {
            (Some(a), Some(b)) if self.cpu && !self.wall => b.saturating_sub(a).as_secs_f64(),
            _ => w0.elapsed().as_secs_f64(),
        };
        (r, s)
    }

    /// Runs `f` as one stage of `count(&result)` items.
    fn stage<R>(
        &mut self,
        name: &'static str,
        unit: &'static str,
        count: impl FnOnce(&R) -> u64,
        f: impl FnOnce() -> R,
    ) -> R {
        let (r, seconds) = self.measure(f);
        self.stages.push(Stage {
            name,
            count: count(&r),
            unit,
            seconds,
            wall: self.wall,
        });
        r
    }

    /// Adds time to a stage accumulated over a loop.
    fn add(&mut self, name: &'static str, unit: &'static str, count: u64, seconds: f64) {
        match self.stages.iter_mut().find(|s| s.name == name) {
            Some(s) => {
                s.count += count;
                s.seconds += seconds;
            }
            None => self.stages.push(Stage {
                name,
                count,
                unit,
                seconds,
                wall: self.wall,
            }),
        }
    }
}

fn one<T>(_: &T) -> u64 {
    1
}

/// Runs the benchmark `cfg.kind` on one thread: a one-thread pool, so that the parts that
/// run in parallel elsewhere (large images are rendered in bands) stay on the thread whose
/// CPU time is measured, and every figure is per core.
pub fn bench(cfg: &BenchConfig) -> Result<BenchReport, BenchError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|source| BenchError::Pool { threads: 1, source })?
        .install(|| bench_on_this_thread(cfg))
}

/// [`bench`] on the calling thread (and whatever pool it is in).
fn bench_on_this_thread(cfg: &BenchConfig) -> Result<BenchReport, BenchError> {
    let scene_ref = match &cfg.scene {
        Some(s) => s.clone(),
        None => {
            let ids = cfg.data.ingested_ids().map_err(BenchError::data(""))?;
            let first = ids
                .first()
                .ok_or_else(|| BenchError::NothingIngested(cfg.data.manifest_path()))?;
            SceneRef::parse(first)
        }
    };
    let mut timer = Timer::new();
    let rss0 = resident_bytes().unwrap_or(0);
    let needs_scene = cfg.kind != BenchKind::Episodes;
    let scene: Option<Scene> = if needs_scene {
        let (scene, _) = timer.stage("load scene", "scenes", one, || {
            cfg.data
                .load_scene(&scene_ref)
                .map_err(BenchError::data(" (ingest the scene first)"))
        })?;
        Some(scene)
    } else {
        None
    };
    let grid: Option<NavGrid> = if cfg.kind != BenchKind::Bake {
        Some(timer.stage("load grid", "grids", one, || {
            cfg.data
                .read_grid(&scene_ref)
                .map_err(BenchError::data(" (bake the scene first)"))
        })?)
    } else {
        None
    };
    let rss_after_load = resident_bytes().unwrap_or(0);
    let mut report = BenchReport {
        kind: cfg.kind,
        scene: scene_ref.to_string(),
        triangles: scene.as_ref().map_or(0, |s| s.triangle_count()),
        walkable_spans: grid
            .as_ref()
            .map_or(0, |g| g.spans.iter().filter(|s| s.walkable).count() as u64),
        rss_after_load,
        rss_of_load: rss_after_load.saturating_sub(rss0),
        rss_peak: 0,
        cpu_time: timer.cpu,
        threads: 1,
        adapter: None,
        batch: 0,
        envs: 0,
        stages: Vec::new(),
    };
    if let Some(g) = &grid {
        BodyRule {
            body: cfg.agent.body,
            allow_mismatch: cfg.allow_body_mismatch,
        }
        .check(&g.params.body)
        .map_err(|source| BenchError::Body {
            scene: scene_ref.to_string(),
            source,
        })?;
    }
    match cfg.kind {
        BenchKind::Bake => {
            let scene = scene.as_ref().ok_or(BenchError::NotLoaded("scene"))?;
            let params = NavParams::for_body(cfg.agent.body);
            let grid = timer.stage("bake", "scenes", one, || build(scene, &params))?;
            report.walkable_spans = grid.spans.iter().filter(|s| s.walkable).count() as u64;
        }
        BenchKind::Episodes => {
            let grid = grid.as_ref().ok_or(BenchError::NotLoaded("grid"))?;
            let sampled = timer.stage(
                "sample",
                "episodes",
                |e: &Vec<Episode>| e.len() as u64,
                || episodes(cfg, grid, &scene_ref),
            );
            if sampled.is_empty() {
                return Err(BenchError::Empty {
                    scene: scene_ref.to_string(),
                    what: "no PointGoal episode could be sampled",
                });
            }
        }
        BenchKind::Render | BenchKind::Run => {
            let (scene, grid) = match (scene, grid) {
                (Some(s), Some(g)) => (s, g),
                _ => return Err(BenchError::NotLoaded("scene or grid")),
            };
            let eps = if cfg.kind == BenchKind::Run {
                let eps = timer.stage(
                    "sample",
                    "episodes",
                    |e: &Vec<Episode>| e.len() as u64,
                    || episodes(cfg, &grid, &scene_ref),
                );
                if eps.is_empty() {
                    return Err(BenchError::Empty {
                        scene: scene_ref.to_string(),
                        what: "no PointGoal episode could be sampled",
                    });
                }
                eps
            } else {
                Vec::new()
            };
            let poses = if cfg.kind == BenchKind::Render {
                poses(cfg, &grid, &scene_ref)?
            } else {
                Vec::new()
            };
            let (mut sim, assets) =
                timer.stage("prepare", "scenes", one, || prepare(cfg, &scene, grid))?;
            drop(scene);
            timer.wall = matches!(**sim.renderer(), Renderer::Gpu(_));
            if cfg.kind == BenchKind::Render {
                render(&mut timer, &mut sim, &poses)?;
                let renderer = sim.renderer().clone();
                if let (Renderer::Gpu(g), true) = (&*renderer, cfg.batch > 0) {
                    timer
                        .stages
                        .extend(gpu::batches(cfg, &mut sim, &poses, g, &assets.render)?);
                    report.adapter = Some(g.adapter_name());
                    report.batch = cfg.batch;
                }
            } else {
                let mut stepper = oracle_stepper(sim);
                if cfg.per_core {
                    rollout(&mut timer, &mut stepper, &assets.grid, &eps)?;
                }
                let sim = stepper.sim();
                if cfg.threads > 1 || !cfg.per_core {
                    let (steps, wall) = rollout_on_threads(sim, &assets.grid, &eps, cfg.threads)?;
                    timer.stages.push(Stage {
                        name: ALL_THREADS,
                        count: steps,
                        unit: "steps",
                        seconds: wall,
                        wall: true,
                    });
                    report.threads = cfg.threads;
                }
                if cfg.envs > 0 {
                    let pool = thread_pool(cfg.threads)?;
                    let separate =
                        std::env::var(batched::STARTS_POOL_ENV).is_ok_and(|v| v == "separate");
                    let own = separate.then(|| thread_pool(cfg.threads)).transpose()?;
                    let starts = own.as_ref().unwrap_or(&pool);
                    let run = pool.install(|| {
                        batched::rollout_batched(sim, &assets.grid, &eps, cfg.envs, starts)
                    })?;
                    timer.stages.push(Stage {
                        name: batched::BATCHED,
                        count: run.steps,
                        unit: "steps",
                        seconds: run.seconds,
                        wall: true,
                    });
                    timer.stages.extend(run.phase_stages());
                    report.threads = cfg.threads;
                    report.envs = cfg.envs;
                    if let Renderer::Gpu(g) = &**sim.renderer() {
                        report.adapter = Some(g.adapter_name());
                    }
                }
            }
        }
    }
    report.stages = timer.stages;
    report.rss_peak = status_bytes("VmHWM:").unwrap_or(0);
    Ok(report)
}

/// PointGoal episodes of the scene (`cfg.episodes` wanted).
fn episodes(cfg: &BenchConfig, grid: &NavGrid, scene: &SceneRef) -> Vec<Episode> {
    let sample = SampleConfig {
        task: Task::PointGoal,
        per_scene: cfg.episodes,
        seed: cfg.seed,
        ..SampleConfig::default()
    };
    sample_scene(grid, &scene.to_string(), "bench", &sample).episodes
}

/// `cfg.frames` random walkable poses (position on the floor, yaw).
fn poses(
    cfg: &BenchConfig,
    grid: &NavGrid,
    scene: &SceneRef,
) -> Result<Vec<(Vec3, f32)>, BenchError> {
    let mut rng = Rng::new(derive_seed(cfg.seed, &[&scene.to_string(), "bench-poses"]));
    let spans = grid.walkable_spans(None);
    (0..cfg.frames)
        .map(|_| {
            let (_, p) =
                grid.random_point_from(&mut rng, &spans)
                    .ok_or_else(|| BenchError::Empty {
                        scene: scene.to_string(),
                        what: "the grid has no walkable floor",
                    })?;
            Ok((p, rng.range_f64(0.0, std::f64::consts::TAU) as f32))
        })
        .collect()
}

/// The simulator of the scene (assets, renderer).
fn prepare(
    cfg: &BenchConfig,
    scene: &Scene,
    grid: NavGrid,
) -> Result<(Simulator, Arc<SceneAssets>), BenchError> {
    let assets = if cfg.allow_body_mismatch {
        SceneAssets::new_allowing_body_mismatch(scene, grid, &cfg.agent)
    } else {
        SceneAssets::new(scene, grid, &cfg.agent)
    };
    let assets = Arc::new(assets?);
    let renderer = Arc::new(Renderer::new(cfg.renderer, &assets.render)?);
    let sim = Simulator::new(
        assets.clone(),
        renderer,
        cfg.agent,
        cfg.sensors.clone(),
        DEFAULT_MAX_STEPS,
        cfg.seed,
    );
    Ok((sim, assets))
}

/// Renders every camera from each pose, one observation at a time (timed by the wall
/// clock with a GPU renderer, whose work this thread's CPU time does not see).
fn render(timer: &mut Timer, sim: &mut Simulator, poses: &[(Vec3, f32)]) -> Result<(), BenchError> {
    let wall = matches!(**sim.renderer(), Renderer::Gpu(_));
    for (p, yaw) in poses {
        sim.reset(*p, *yaw, None, "bench");
        let t = Instant::now();
        let (r, s) = timer.measure(|| sim.observe());
        let s = if wall { t.elapsed().as_secs_f64() } else { s };
        r?;
        timer.add("render", "frames", 1, s);
    }
    if wall {
        if let Some(stage) = timer.stages.iter_mut().find(|s| s.name == "render") {
            stage.wall = true;
        }
    }
    Ok(())
}

/// [`rollout`]'s loop on `threads` threads at once, each with its own simulator (a sibling
/// of `sim`), goal fields and oracle, claiming the next episode until none is left: the
/// steps taken and the wall-clock seconds they took.
fn rollout_on_threads(
    sim: &Simulator,
    grid: &NavGrid,
    eps: &[Episode],
    threads: usize,
) -> Result<(u64, f64), BenchError> {
    let next = AtomicUsize::new(0);
    let start = Instant::now();
    let results: Vec<Result<u64, BenchError>> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                let (mut stepper, next) = (oracle_stepper(sim.sibling()), &next);
                scope.spawn(move || {
                    let geo = Geodesic::new(grid);
                    let claimed =
                        std::iter::from_fn(|| eps.get(next.fetch_add(1, Ordering::Relaxed)));
                    episode_loop(&mut Untimed, &mut stepper, &geo, claimed)
                })
            })
            .collect();
        workers
            .into_iter()
            .map(|w| w.join().unwrap_or_else(|_| Err(BenchError::WorkerPanicked)))
            .collect()
    });
    let wall = start.elapsed().as_secs_f64();
    let mut steps = 0;
    for r in results {
        steps += r?;
    }
    Ok((steps, wall))
}

/// Where [`episode_loop`] reports how long each of its stages took.
trait Clock {
    /// Runs `f`, one item (`unit`) of stage `name`.
    fn time<R>(&mut self, name: &'static str, unit: &'static str, f: impl FnOnce() -> R) -> R;
}

impl Clock for Timer {
    fn time<R>(&mut self, name: &'static str, unit: &'static str, f: impl FnOnce() -> R) -> R {
        let (r, seconds) = self.measure(f);
        self.add(name, unit, 1, seconds);
        r
    }
}

/// No clock: the stages are not timed one by one (the all-threads row times the whole loop).
struct Untimed;

impl Clock for Untimed {
    fn time<R>(&mut self, _: &'static str, _: &'static str, f: impl FnOnce() -> R) -> R {
        f()
    }
}

/// A pool of `threads` threads (at least one), for the stages on all threads.
fn thread_pool(threads: usize) -> Result<rayon::ThreadPool, BenchError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .map_err(|source| BenchError::Pool { threads, source })
}

/// The stepper of `minos run`'s oracle on `sim` (success needs its `stop`; the episodes'
/// own step limits).
fn oracle_stepper(sim: Simulator) -> EpisodeStepper {
    EpisodeStepper::new(
        sim,
        StepperConfig {
            require_stop: true,
            ..StepperConfig::default()
        },
    )
}

/// The oracle's loop over `eps` on `stepper` with goal fields from `geo`: reset (goal field
/// and first frame), plan, then decide and step until it stops or the step limit; each stage
/// timed by `clock`. The steps taken.
fn episode_loop<'a>(
    clock: &mut impl Clock,
    stepper: &mut EpisodeStepper,
    geo: &Geodesic,
    eps: impl Iterator<Item = &'a Episode>,
) -> Result<u64, BenchError> {
    let mut agent = OracleAgent::new();
    let mut steps = 0;
    for ep in eps {
        clock.time(RESET, "episodes", || {
            stepper.reset_in(ep, Some(geo)).map(|_| ())
        })?;
        clock.time("oracle plan", "episodes", || agent.reset(ep, stepper.sim()))?;
        while !stepper.ended() {
            let d = clock.time("oracle decide", "steps", || {
                agent.decide(stepper.observation(), stepper.sim())
            })?;
            if d == Decision::Stop {
                stepper.step(d)?;
                break;
            }
            clock.time("sim step", "steps", || stepper.step(d).map(|_| ()))?;
            steps += 1;
        }
    }
    Ok(steps)
}

/// The stage of an episode's reset: its goal field and first observation.
const RESET: &str = "reset (goal field, first frame)";

/// The oracle's loop over the episodes: reset (goal field), plan, decide, step.
fn rollout(
    timer: &mut Timer,
    stepper: &mut EpisodeStepper,
    grid: &NavGrid,
    eps: &[Episode],
) -> Result<(), BenchError> {
    let (geo, s) = timer.measure(|| Geodesic::new(grid));
    timer.add("geodesic setup", "scenes", 1, s);
    episode_loop(timer, stepper, &geo, eps.iter())?;
    // The whole loop as one figure: steps per second of reset, planning, deciding and
    // stepping together.
    let steps = timer
        .stages
        .iter()
        .find(|s| s.name == "sim step")
        .map_or(0, |s| s.count);
    let loop_s: f64 = timer
        .stages
        .iter()
        .filter(|s| {
            matches!(
                s.name,
                "geodesic setup" | RESET | "oracle plan" | "oracle decide" | "sim step"
            )
        })
        .map(|s| s.seconds)
        .sum();
    timer.stages.push(Stage {
        name: "rollout loop",
        count: steps,
        unit: "steps",
        seconds: loop_s,
        wall: timer.wall,
    });
    Ok(())
}
