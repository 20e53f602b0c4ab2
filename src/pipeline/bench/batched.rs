//! `bench run`'s batched rollout: the oracle's loop with many environments — episode
//! steppers on simulators sharing the scene and its renderer — stepped in lockstep with
//! [`step_many`] (decisions and motion on all threads, every environment's cameras rendered
//! together: one submission and one read-back on a GPU renderer). An environment whose
//! episode ends takes the next episode not yet started, as `minos run`'s workers do,
//! preparing it beside the lockstep; the loop ends when no episode is left. Timed by the wall
//! clock.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use super::{oracle_stepper, BenchError};
use crate::episode::Episode;
use crate::navmesh::geodesic::Geodesic;
use crate::navmesh::NavGrid;
use crate::run::agents::{Agent, Decision};
use crate::run::oracle::OracleAgent;
use crate::run::stepper::{step_many_timed, Command, EpisodeStepper};
use crate::sim::batch::PhaseTimes;
use crate::sim::Simulator;

use super::Stage;

/// The environment variable that, set to `separate`, runs the batched rollout's episode
/// starts on a thread pool of their own (as many threads again) instead of the lockstep's:
/// an experiment on whether the lockstep's parallel loops wait behind starts they picked up.
pub const STARTS_POOL_ENV: &str = "MINOS_BENCH_STARTS_POOL";

/// Name of the batched rollout stage.
pub const BATCHED: &str = "rollout loop, batched";

/// Names of the batched rollout's phases (wall-clock time of the lockstep, counted in
/// lockstep steps): where a step of the whole batch goes. The two GPU parts are the ray
/// tracer's own clocks over every render call of the run — the lockstep's and those of the
/// episodes' starts (their first frames) running beside it —, so they may exceed the
/// lockstep's render calls; zero on the CPU renderer.
pub const PHASES: [&str; 9] = [
    "batched: waiting for episode starts",
    "batched: decisions",
    "batched: motion",
    "batched: camera poses",
    "batched: render calls (GPU: submission, work, read-back, unpacking)",
    "batched: GPU work and read-back (all calls, the starts' first frames too)",
    "batched: unpacking frames (all calls, the starts' first frames too)",
    "batched: observations from frames",
    "batched: step bookkeeping",
];

/// What the batched rollout measured.
pub(super) struct BatchedRun {
    /// Steps taken.
    pub steps: u64,
    /// Wall-clock seconds of the whole rollout.
    pub seconds: f64,
    /// The lockstep's phases.
    pub phases: PhaseTimes,
    /// Time the lockstep spent deciding (the oracles, in parallel).
    pub decide: Duration,
    /// Time it waited with no environment ready.
    pub waiting: Duration,
    /// The GPU's work and read-back, and unpacking the frames, over every render call of the
    /// run (the starts' too; zero on the CPU renderer).
    pub read_back: (Duration, Duration),
}

impl BatchedRun {
    /// The phases as wall-clock stages named [`PHASES`], counted in lockstep steps.
    pub fn phase_stages(&self) -> Vec<Stage> {
        let p = &self.phases;
        let times = [
            self.waiting,
            self.decide,
            p.motion,
            p.views,
            p.render,
            self.read_back.0,
            self.read_back.1,
            p.observe,
            p.finish,
        ];
        PHASES
            .iter()
            .zip(times)
            .map(|(name, t)| Stage {
                name,
                count: p.batches,
                unit: "lockstep steps",
                seconds: t.as_secs_f64(),
                wall: true,
            })
            .collect()
    }
}

/// One environment of the batch: a stepper and its oracle.
type Env = (EpisodeStepper, OracleAgent);

/// Prepares the next unclaimed episode on `env`, if any (the reset with its goal field, the
/// oracle's plan; its first frame comes with the lockstep's next render call); `false` when
/// none is left.
fn start_next(
    (stepper, agent): &mut Env,
    eps: &[Episode],
    next: &AtomicUsize,
    geo: &Geodesic,
) -> Result<bool, BenchError> {
    let Some(ep) = eps.get(next.fetch_add(1, Ordering::Relaxed)) else {
        return Ok(false);
    };
    stepper.prepare_in(ep, Some(geo));
    agent.reset(ep, stepper.sim())?;
    Ok(true)
}

/// The oracle's rollout over `eps` with `envs` environments (siblings of `sim`) stepped
/// together on the current rayon pool, the episodes' starts running on `starts` (the current
/// pool or another): the steps taken, the wall-clock seconds and where the lockstep's time
/// went.
///
/// Starting an episode (its goal field and the oracle's plan: tens of milliseconds on a
/// large scan) runs as a task beside the lockstep, so the other environments keep stepping;
/// the environment rejoins the batch when its episode is ready, and its first frame is
/// rendered with the batch's next step (one render call for all, on a GPU one submission).
/// Which batch an environment steps in never changes what it observes, so the steps are
/// those of the per-core loop.
pub(super) fn rollout_batched(
    sim: &Simulator,
    grid: &NavGrid,
    eps: &[Episode],
    envs: usize,
    starts: &rayon::ThreadPool,
) -> Result<BatchedRun, BenchError> {
    let start = Instant::now();
    let (mut phases, mut decide, mut waiting) =
        (PhaseTimes::default(), Duration::ZERO, Duration::ZERO);
    let gpu_times = || match &**sim.renderer() {
        crate::render::Renderer::Gpu(g) => g.read_back_times(),
        crate::render::Renderer::Cpu => Default::default(),
    };
    let before = gpu_times();
    let geo = Geodesic::new(grid);
    let next = AtomicUsize::new(0);
    let steps = starts.in_place_scope(|scope| -> Result<u64, BenchError> {
        let (geo, next) = (&geo, &next);
        let (ready_tx, ready) = std::sync::mpsc::channel::<Result<Option<Env>, BenchError>>();
        // Starts `env`'s next episode as a task; it comes back through `ready` (`None` when
        // no episode is left).
        let begin = |mut env: Env| {
            let tx = ready_tx.clone();
            scope.spawn(move |_| {
                let _ = tx.send(start_next(&mut env, eps, next, geo).map(|s| s.then_some(env)));
            });
        };
        let mut pending = envs.max(1);
        for _ in 0..pending {
            begin((oracle_stepper(sim.sibling()), OracleAgent::new()));
        }
        // The batch: steppers (a slice, for `step_many`) and their oracles, side by side.
        let (mut steppers, mut agents): (Vec<EpisodeStepper>, Vec<OracleAgent>) = (vec![], vec![]);
        let mut steps = 0u64;
        loop {
            // Environments whose episode is ready join; with none stepping, wait for one
            // (running tasks on this thread meanwhile, so one thread suffices).
            let t = Instant::now();
            loop {
                match ready.try_recv() {
                    Ok(env) => {
                        pending -= 1;
                        if let Some((stepper, agent)) = env? {
                            steppers.push(stepper);
                            agents.push(agent);
                        }
                    }
                    Err(_) if steppers.is_empty() && pending > 0 => {
                        if rayon::yield_now().is_none() {
                            std::thread::yield_now();
                        }
                    }
                    Err(_) => break,
                }
            }
            let t = PhaseTimes::lap(&mut waiting, t);
            if steppers.is_empty() {
                break;
            }
            // The environments that joined observe their first frame; the others decide.
            let decisions = steppers
                .par_iter()
                .zip(agents.par_iter_mut())
                .map(|(s, a)| match s.awaits_first_observation() {
                    true => Ok(None),
                    false => a.decide(s.observation(), s.sim()).map(Some),
                })
                .collect::<Result<Vec<Option<Decision>>, _>>()?;
            PhaseTimes::lap(&mut decide, t);
            // An oracle's stop ends its episode (the per-core loop takes no step for it);
            // the others step (or observe) together, and those that reach the step limit end.
            let mut stepping: Vec<Env> = Vec::with_capacity(steppers.len());
            let mut commands: Vec<Command> = Vec::with_capacity(steppers.len());
            for ((stepper, agent), d) in steppers.drain(..).zip(agents.drain(..)).zip(&decisions) {
                match d {
                    Some(Decision::Stop) => {
                        pending += 1;
                        begin((stepper, agent));
                    }
                    Some(d) => {
                        commands.push(Command::Step(*d));
                        stepping.push((stepper, agent));
                    }
                    None => {
                        commands.push(Command::Observe);
                        stepping.push((stepper, agent));
                    }
                }
            }
            (steppers, agents) = stepping.into_iter().unzip();
            let ended: Vec<bool> = step_many_timed(&mut steppers, &commands, &mut phases)?
                .iter()
                .map(|o| o.done())
                .collect();
            steps += commands
                .iter()
                .filter(|c| matches!(c, Command::Step(_)))
                .count() as u64;
            let mut kept: Vec<Env> = Vec::with_capacity(steppers.len());
            for (env, ended) in steppers.drain(..).zip(agents.drain(..)).zip(ended) {
                if ended {
                    pending += 1;
                    begin(env);
                } else {
                    kept.push(env);
                }
            }
            (steppers, agents) = kept.into_iter().unzip();
        }
        Ok(steps)
    })?;
    let seconds = start.elapsed().as_secs_f64();
    let after = gpu_times();
    Ok(BatchedRun {
        steps,
        seconds,
        phases,
        decide,
        waiting,
        read_back: (after.0 - before.0, after.1 - before.1),
    })
}
