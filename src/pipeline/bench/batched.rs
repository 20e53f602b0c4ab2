//! `bench run`'s batched rollout: the oracle's loop with many environments — simulators
//! sharing the scene and its renderer — stepped in lockstep, each step's motion and decisions
//! on all threads and every environment's cameras rendered together
//! ([`crate::sim::batch::observe_many`]: one submission and one read-back on a GPU renderer).
//! An environment whose episode ends takes the next episode not yet started, as `minos run`'s
//! workers do; the loop ends when no episode is left. Timed by the wall clock.

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

    /// Decides and applies this step's action (without observing); at a stop or the step
    /// limit, starts the next episode instead. `true` when the environment stepped.
    fn act(
        &mut self,
        eps: &[Episode],
        next: &AtomicUsize,
        geo: &Geodesic,
    ) -> Result<bool, BenchError> {
        let (Some(left), Some(obs)) = (self.left, self.obs.as_ref()) else {
            return Ok(false);
        };
        let decision = if left == 0 {
            Decision::Stop
        } else {
            self.agent
                .decide(obs, &self.sim)
                .map_err(|e| BenchError(e.to_string()))?
        };
        match decision {
            Decision::Act(a) => {
                self.sim.advance(a);
                self.left = Some(left - 1);
                Ok(true)
            }
            Decision::Stop => {
                self.start(eps, next, geo)?;
                Ok(false)
            }
        }
    }
}

/// The oracle's rollout over `eps` with `envs` environments (siblings of `sim`) stepped
/// together on the current rayon pool: the steps taken and the wall-clock seconds.
pub(super) fn rollout_batched(
    sim: &Simulator,
    grid: &NavGrid,
    eps: &[Episode],
    envs: usize,
) -> Result<(u64, f64), BenchError> {
    let start = Instant::now();
    let geo = Geodesic::new(grid);
    let next = AtomicUsize::new(0);
    let mut batch: Vec<Env> = (0..envs.max(1))
        .map(|_| Env {
            sim: sim.sibling(),
            agent: OracleAgent::new(),
            obs: None,
            left: None,
        })
        .collect();
    batch
        .par_iter_mut()
        .map(|env| env.start(eps, &next, &geo).map(drop))
        .collect::<Result<(), _>>()?;
    let mut steps = 0u64;
    loop {
        // Every environment with an episode and no observation yet (just started, or just
        // stepped) is observed in one call.
        let mut waiting: Vec<&mut Env> = batch
            .iter_mut()
            .filter(|e| e.left.is_some() && e.obs.is_none())
            .collect();
        if waiting.is_empty() {
            break;
        }
        let mut sims: Vec<&mut Simulator> = waiting.iter_mut().map(|e| &mut e.sim).collect();
        let observed = observe_many(&mut sims);
        for (env, obs) in waiting.into_iter().zip(observed) {
            env.obs = Some(obs.map_err(|e| BenchError(e.to_string()))?);
        }
        let stepped = batch
            .par_iter_mut()
            .map(|env| {
                let stepped = env.act(eps, &next, &geo)?;
                if stepped {
                    env.obs = None;
                }
                Ok(u64::from(stepped))
            })
            .collect::<Result<Vec<u64>, BenchError>>()?;
        steps += stepped.iter().sum::<u64>();
    }
    Ok((steps, start.elapsed().as_secs_f64()))
}
