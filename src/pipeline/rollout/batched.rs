//! A scene's episodes stepped in lockstep: N environments (a stepper and an agent each) take
//! the scene's episodes in order, decide in parallel, and every step's observations are
//! rendered together ([`step_many`]: one render call, one GPU submission per step for the
//! wgpu renderer, instead of one per environment). Each environment writes its episode's
//! parts as the per-thread loop does ([`EpisodeParts`]), and every episode is seeded from
//! its own id, so the run's outputs are the same bytes whatever the batch size.

use rayon::prelude::*;

use super::episode::{EpisodeError, EpisodeParts};
use super::scene::make_agent;
use super::{Failed, Outcome, Queue, Workers};
use crate::navmesh::geodesic::Geodesic;
use crate::run::agents::{Agent, Decision};
use crate::run::stepper::{step_many, Command, EpisodeStepper, StepperConfig};
use crate::sim::{SceneAssets, Simulator};

/// An environment's episode in progress.
struct Active {
    index: usize,
    parts: EpisodeParts,
}

/// Runs `queue`'s episodes on `envs` environments made from `sim` (its siblings share its
/// assets and renderer) in lockstep.
pub(super) fn run_batched(
    sim: Simulator,
    agent: Box<dyn Agent>,
    assets: &SceneAssets,
    envs: usize,
    queue: Queue<'_>,
    w: Workers<'_>,
) -> Vec<Outcome> {
    let Workers {
        cfg,
        parts,
        recorded,
        ..
    } = w;
    let geo = Geodesic::new(&assets.grid);
    let mut out: Vec<Outcome> = Vec::new();
    let mut agents: Vec<Box<dyn Agent>> = vec![agent];
    let mut sims = vec![sim];
    for _ in 1..envs.max(1) {
        match make_agent(&cfg.agent, cfg.seed) {
            Ok(a) => {
                sims.push(sims[0].sibling());
                agents.push(a);
            }
            // The environments made so far run every episode.
            Err(e) => {
                tracing::warn!("one environment fewer: {e}");
                break;
            }
        }
    }
    let mut steppers: Vec<EpisodeStepper> = sims
        .into_iter()
        .zip(&agents)
        .map(|(sim, agent)| {
            EpisodeStepper::new(
                sim,
                StepperConfig {
                    reward: cfg.reward,
                    max_steps: cfg.max_steps,
                    require_stop: agent.stops(),
                },
            )
        })
        .collect();
    let mut active: Vec<Option<Active>> = (0..steppers.len()).map(|_| None).collect();
    loop {
        // Idle environments take the next episodes, in parallel (a reset renders the
        // episode's first frame); those the queue cannot feed retire.
        let mut claims: Vec<Option<(usize, &crate::episode::Episode)>> =
            Vec::with_capacity(active.len());
        for slot in &active {
            claims.push(match slot {
                Some(_) => None,
                None => w.next(queue, &mut out).map(|(i, ep)| (*i, ep)),
            });
        }
        let started: Vec<Option<Outcome>> = steppers
            .par_iter_mut()
            .zip(agents.par_iter_mut())
            .zip(active.par_iter_mut())
            .zip(claims.par_iter())
            .map(|(((stepper, agent), slot), claim)| {
                let &Some((i, ep)) = claim else {
                    return None;
                };
                let opened = (|| {
                    stepper.reset_in(ep, Some(&geo))?;
                    agent.reset(ep, stepper.sim())?;
                    EpisodeParts::open(stepper, ep, cfg, parts, i, recorded.contains(&i))
                })();
                match opened {
                    Ok(p) => {
                        *slot = Some(Active { index: i, parts: p });
                        None
                    }
                    Err(e) => Some((i, Err(Failed::of(e)))),
                }
            })
            .collect();
        for o in started.into_iter().flatten() {
            w.done(o, &mut out);
        }
        // Retire the environments left without an episode.
        let mut k = 0;
        while k < active.len() {
            if active[k].is_none() {
                active.swap_remove(k);
                steppers.swap_remove(k);
                agents.swap_remove(k);
            } else {
                k += 1;
            }
        }
        if active.is_empty() {
            break;
        }
        // Every environment decides and writes the observation it decided on.
        let decided: Vec<Result<Decision, EpisodeError>> = steppers
            .par_iter()
            .zip(agents.par_iter_mut())
            .zip(active.par_iter_mut())
            .map(|((stepper, agent), slot)| {
                let a = slot.as_mut().ok_or_else(|| {
                    EpisodeError::Part("an environment stepped without an episode".into())
                })?;
                let d = agent.decide(stepper.observation(), stepper.sim())?;
                a.parts.before(stepper, &d)?;
                Ok(d)
            })
            .collect();
        let mut commands = Vec::with_capacity(decided.len());
        let mut failed = vec![None; decided.len()];
        for (k, d) in decided.into_iter().enumerate() {
            match d {
                Ok(d) => commands.push(Command::Step(d)),
                Err(e) => {
                    // The episode ends here as a failure; its environment stops (an idle
                    // step) and takes the next episode.
                    failed[k] = Some(Failed::of(e));
                    commands.push(Command::Step(Decision::Stop));
                }
            }
        }
        // One batched step; then each environment records what its step gave.
        let recorded_steps: Result<Vec<Option<Failed>>, Failed> =
            match step_many(&mut steppers, &commands) {
                Err(e) => Err(Failed::of(EpisodeError::Step(e))),
                Ok(outcomes) => Ok(outcomes
                    .par_iter()
                    .zip(active.par_iter_mut())
                    .zip(failed.par_iter())
                    .map(|((o, slot), f)| match (f, slot.as_mut()) {
                        (Some(_), _) | (_, None) => None,
                        (None, Some(a)) => a.parts.after(o).err().map(Failed::of),
                    })
                    .collect()),
            };
        let after = match recorded_steps {
            Ok(a) => a,
            Err(e) => {
                // The batch could not be rendered: every episode in it fails.
                for slot in active.iter_mut() {
                    if let Some(a) = slot.take() {
                        w.done((a.index, Err(e.clone())), &mut out);
                    }
                }
                continue;
            }
        };
        // Episodes that ended (or failed) write their last parts; their environments are
        // idle for the next round.
        let finished: Vec<Option<Outcome>> = steppers
            .par_iter()
            .zip(active.par_iter_mut())
            .zip(failed.into_par_iter().zip(after.into_par_iter()))
            .map(|((stepper, slot), (failed, after))| {
                let failure = failed.or(after);
                let ended = failure.is_some() || stepper.ended();
                if !ended {
                    return None;
                }
                let a = slot.take()?;
                Some(match failure {
                    Some(f) => (a.index, Err(f)),
                    None => (
                        a.index,
                        a.parts
                            .finish(stepper)
                            .map(|m| (m, false))
                            .map_err(Failed::of),
                    ),
                })
            })
            .collect();
        for o in finished.into_iter().flatten() {
            w.done(o, &mut out);
        }
    }
    out
}
