//! `bench run`'s batched rollout: the oracle's loop with many environments — episode
//! steppers on simulators sharing the scene and its renderer — stepped in lockstep with
//! [`step_many`] (decisions and motion on all threads, every environment's cameras rendered
//! together: one submission and one read-back on a GPU renderer). An environment whose
//! episode ends takes the next episode not yet started, as `minos run`'s workers do,
//! preparing it beside the lockstep; the loop ends when no episode is left. Timed by the wall
//! clock.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use super::{oracle_stepper, BenchError};
use crate::episode::Episode;
use crate::navmesh::geodesic::Geodesic;
use crate::navmesh::NavGrid;
use crate::run::agents::{Agent, Decision};
use crate::run::oracle::OracleAgent;
use crate::run::stepper::{step_many, Command, EpisodeStepper};
use crate::sim::Simulator;

/// Name of the batched rollout stage.
pub const BATCHED: &str = "rollout loop, batched";

/// One environment of the batch: a stepper and its oracle.
type Env = (EpisodeStepper, OracleAgent);

/// Starts the next unclaimed episode on `env`, if any (reset, first frame, plan, as the
/// per-core loop does); `false` when none is left.
fn start_next(
    (stepper, agent): &mut Env,
    eps: &[Episode],
    next: &AtomicUsize,
    geo: &Geodesic,
) -> Result<bool, BenchError> {
    let err = |e: &dyn std::fmt::Display| BenchError(e.to_string());
    let Some(ep) = eps.get(next.fetch_add(1, Ordering::Relaxed)) else {
        return Ok(false);
    };
    stepper.reset_in(ep, Some(geo)).map_err(|e| err(&e))?;
    agent.reset(ep, stepper.sim()).map_err(|e| err(&e))?;
    Ok(true)
}

/// The oracle's rollout over `eps` with `envs` environments (siblings of `sim`) stepped
/// together on the current rayon pool: the steps taken and the wall-clock seconds.
///
/// Starting an episode (its goal field and the oracle's plan: tens of milliseconds on a
/// large scan) runs as a task beside the lockstep, so the other environments keep stepping;
/// the environment rejoins the batch when its episode is ready. Which batch an environment
/// steps in never changes what it observes, so the steps are those of the per-core loop.
pub(super) fn rollout_batched(
    sim: &Simulator,
    grid: &NavGrid,
    eps: &[Episode],
    envs: usize,
) -> Result<(u64, f64), BenchError> {
    let start = Instant::now();
    let geo = Geodesic::new(grid);
    let next = AtomicUsize::new(0);
    let steps = rayon::scope(|scope| -> Result<u64, BenchError> {
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
            if steppers.is_empty() {
                break;
            }
            let decisions = steppers
                .par_iter()
                .zip(agents.par_iter_mut())
                .map(|(s, a)| a.decide(s.observation(), s.sim()))
                .collect::<Result<Vec<Decision>, _>>()
                .map_err(|e| BenchError(e.to_string()))?;
            // An oracle's stop ends its episode (the per-core loop takes no step for it);
            // the others step together, and those that reach the step limit end too.
            let mut stepping: Vec<Env> = Vec::with_capacity(steppers.len());
            for ((stepper, agent), d) in steppers.drain(..).zip(agents.drain(..)).zip(&decisions) {
                if *d == Decision::Stop {
                    pending += 1;
                    begin((stepper, agent));
                } else {
                    stepping.push((stepper, agent));
                }
            }
            (steppers, agents) = stepping.into_iter().unzip();
            let commands: Vec<Command> = decisions
                .into_iter()
                .filter(|d| *d != Decision::Stop)
                .map(Command::Step)
                .collect();
            let ended: Vec<bool> = step_many(&mut steppers, &commands)
                .map_err(|e| BenchError(e.to_string()))?
                .iter()
                .map(|o| o.done())
                .collect();
            steps += commands.len() as u64;
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
    Ok((steps, start.elapsed().as_secs_f64()))
}
