//! `bench run`'s batched rollout: the oracle's loop with many environments — simulators
//! sharing the scene and its renderer — stepped in lockstep, each step's motion and decisions
//! on all threads and every environment's cameras rendered together
//! ([`crate::sim::batch::observe_many`]: one submission and one read-back on a GPU renderer).
//! An environment whose episode ends takes the next episode not yet started, as `minos run`'s
//! workers do, preparing it beside the lockstep; the loop ends when no episode is left.
//! Timed by the wall clock.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use super::BenchError;
use crate::episode::Episode;
use crate::navmesh::geodesic::Geodesic;
use crate::navmesh::NavGrid;
use crate::run::agents::{Agent, Decision};
use crate::run::oracle::OracleAgent;
use crate::sim::batch::observe_many;
use crate::sim::{Observation, Simulator};

/// Name of the batched rollout stage.
pub const BATCHED: &str = "rollout loop, batched";

/// One environment of the batch.
struct Env {
    sim: Simulator,
    agent: OracleAgent,
    /// The last observation (`None` before the first of an episode).
    obs: Option<Observation>,
    /// Steps left in the current episode; `None` when the environment has no episode.
    left: Option<u32>,
}

impl Env {
    /// Starts the next unclaimed episode, if any (reset and plan); `false` when none is left.
    fn start(
        &mut self,
        eps: &[Episode],
        next: &AtomicUsize,
        geo: &Geodesic,
    ) -> Result<bool, BenchError> {
        let Some(ep) = eps.get(next.fetch_add(1, Ordering::Relaxed)) else {
            self.left = None;
            return Ok(false);
        };
        self.sim.reset_episode_in(ep, Some(geo));
        self.agent
            .reset(ep, &self.sim)
            .map_err(|e| BenchError(e.to_string()))?;
        self.obs = None;
        self.left = Some(ep.max_steps);
        Ok(true)
    }

    /// Decides and applies this step's action (without observing; the observation is
    /// taken away). `false` at a stop or the step limit: the episode is over.
    fn act(&mut self) -> Result<bool, BenchError> {
        let (Some(left), Some(obs)) = (self.left, self.obs.take()) else {
            return Ok(false);
        };
        let decision = if left == 0 {
            Decision::Stop
        } else {
            self.agent
                .decide(&obs, &self.sim)
                .map_err(|e| BenchError(e.to_string()))?
        };
        match decision {
            Decision::Act(a) => {
                self.sim.advance(a);
                self.left = Some(left - 1);
                Ok(true)
            }
            Decision::Stop => Ok(false),
        }
    }
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
        let (ready_tx, ready) = std::sync::mpsc::channel::<Result<Env, BenchError>>();
        // Starts `env`'s next episode as a task; it comes back through `ready` (without an
        // episode when none is left).
        let begin = |mut env: Env| {
            let tx = ready_tx.clone();
            scope.spawn(move |_| {
                let _ = tx.send(env.start(eps, next, geo).map(|_| env));
            });
        };
        let mut pending = envs.max(1);
        for _ in 0..pending {
            begin(Env {
                sim: sim.sibling(),
                agent: OracleAgent::new(),
                obs: None,
                left: None,
            });
        }
        let mut batch: Vec<Env> = Vec::new();
        let mut steps = 0u64;
        loop {
            // Environments whose episode is ready join; with none stepping, wait for one
            // (running tasks on this thread meanwhile, so one thread suffices).
            loop {
                match ready.try_recv() {
                    Ok(env) => {
                        pending -= 1;
                        let env = env?;
                        if env.left.is_some() {
                            batch.push(env);
                        }
                    }
                    Err(_) if batch.is_empty() && pending > 0 => {
                        if rayon::yield_now().is_none() {
                            std::thread::yield_now();
                        }
                    }
                    Err(_) => break,
                }
            }
            if batch.is_empty() {
                break;
            }
            // Every environment without an observation (just started, or just stepped) is
            // observed in one call.
            let mut waiting: Vec<&mut Simulator> = batch
                .iter_mut()
                .filter(|e| e.obs.is_none())
                .map(|e| &mut e.sim)
                .collect();
            let observed = observe_many(&mut waiting);
            let mut observed = observed.into_iter();
            for env in batch.iter_mut().filter(|e| e.obs.is_none()) {
                let obs = observed
                    .next()
                    .ok_or_else(|| BenchError("an observation is missing".into()))?;
                env.obs = Some(obs.map_err(|e| BenchError(e.to_string()))?);
            }
            let outcomes = batch
                .par_iter_mut()
                .map(|env| env.act())
                .collect::<Result<Vec<bool>, BenchError>>()?;
            // Environments that stopped leave the batch to start their next episode.
            let mut kept = Vec::with_capacity(batch.len());
            for (env, stepped) in batch.drain(..).zip(outcomes) {
                if stepped {
                    steps += 1;
                    kept.push(env);
                } else {
                    pending += 1;
                    begin(env);
                }
            }
            batch = kept;
        }
        Ok(steps)
    })?;
    Ok((steps, start.elapsed().as_secs_f64()))
}
