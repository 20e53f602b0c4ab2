//! A scene's episodes stepped in lockstep: N environments (a stepper and an agent each) take
//! the scene's episodes in order, decide in parallel, and every step's observations are
//! rendered together ([`step_many`]: one render call, one GPU submission per step for the
//! wgpu renderer, instead of one per environment). Each environment writes its episode's
//! parts as the per-thread loop does ([`EpisodeParts`]), and every episode is seeded from
//! its own id, so the run's outputs are the same bytes whatever the batch size. Episodes
//! start beside the lockstep, each as a task of its own, and their first frames are rendered
//! with the lockstep's next step.

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

/// One environment: its stepper and agent.
type Env = (EpisodeStepper, Box<dyn Agent>);

/// What a start task sends back: the environment with its next episode opened (`None` when
/// the queue had none left for it), and the outcomes it recorded meanwhile (episodes that
/// failed to start, episodes not run after a failed write).
type Started = (Option<(Env, Active)>, Vec<Outcome>);

/// Takes the next episodes of `queue` for `env` until one opens (reset with its goal field,
/// the agent's plan, its part files; its first frame comes with the lockstep's next render
/// call) or none is left.
fn start_next(
    (mut stepper, mut agent): Env,
    queue: Queue<'_>,
    w: Workers<'_>,
    geo: &Geodesic,
) -> Started {
    let mut out = Vec::new();
    while let Some((i, ep)) = w.next(queue, &mut out) {
        let opened = (|| {
            stepper.prepare_in(ep, Some(geo));
            agent.reset(ep, stepper.sim())?;
            EpisodeParts::open(&stepper, ep, w.cfg, w.parts, *i, w.recorded.contains(i))
        })();
        match opened {
            Ok(parts) => {
                let active = Active { index: *i, parts };
                return (Some(((stepper, agent), active)), out);
            }
            Err(e) => w.done((*i, Err(Failed::of(e))), &mut out),
        }
    }
    (None, out)
}

/// Runs `queue`'s episodes on `envs` environments made from `sim` (its siblings share its
/// assets and renderer) in lockstep.
///
/// Starting an episode (its goal field, the agent's plan — tens of milliseconds each on a
/// large scan — and its first frame) runs as a task beside the lockstep, as `bench run
/// --envs` does, so the other environments keep stepping; the environment rejoins the batch
/// when its episode is open. Which batch an environment steps in never changes what it
/// observes, so the outputs are those of the per-thread loop.
pub(super) fn run_batched(
    sim: Simulator,
    agent: Box<dyn Agent>,
    assets: &SceneAssets,
    envs: usize,
    queue: Queue<'_>,
    w: Workers<'_>,
) -> Vec<Outcome> {
    let cfg = w.cfg;
    let geo = Geodesic::new(&assets.grid);
    let mut out: Vec<Outcome> = Vec::new();
    let mut made: Vec<Env> = Vec::with_capacity(envs.max(1));
    for _ in 1..envs.max(1) {
        match make_agent(&cfg.agent, cfg.seed) {
            Ok(a) => made.push((stepper_for(sim.sibling(), a.as_ref(), cfg), a)),
            // The environments made so far run every episode.
            Err(e) => {
                tracing::warn!("one environment fewer: {}", crate::escape::error_line(&e));
                break;
            }
        }
    }
    made.insert(0, (stepper_for(sim, agent.as_ref(), cfg), agent));
    rayon::scope(|scope| {
        let geo = &geo;
        let (ready_tx, ready) = std::sync::mpsc::channel::<Started>();
        // Starts `env`'s next episode as a task; it comes back through `ready`.
        let begin = |env: Env| {
            let tx = ready_tx.clone();
            scope.spawn(move |_| {
                let _ = tx.send(start_next(env, queue, w, geo));
            });
        };
        let mut pending = made.len();
        for env in made {
            begin(env);
        }
        // The batch: steppers (a slice, for `step_many`), agents and episodes side by side.
        let mut steppers: Vec<EpisodeStepper> = Vec::new();
        let mut agents: Vec<Box<dyn Agent>> = Vec::new();
        let mut active: Vec<Option<Active>> = Vec::new();
        loop {
            // Environments whose episode is open join; with none stepping, wait for one
            // (running tasks on this thread meanwhile, so one thread suffices). Those the
            // queue could not feed retire.
            loop {
                match ready.try_recv() {
                    Ok((env, outcomes)) => {
                        pending -= 1;
                        out.extend(outcomes);
                        if let Some(((stepper, agent), a)) = env {
                            steppers.push(stepper);
                            agents.push(agent);
                            active.push(Some(a));
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
            step_once(&mut steppers, &mut agents, &mut active, w, &mut out);
            // Environments whose episode ended leave the batch and start their next one.
            let mut k = 0;
            while k < active.len() {
                if active[k].is_none() {
                    active.swap_remove(k);
                    pending += 1;
                    begin((steppers.swap_remove(k), agents.swap_remove(k)));
                } else {
                    k += 1;
                }
            }
        }
    });
    out
}

/// A stepper for `sim` with the run's reward and step limit and `agent`'s stopping rule.
fn stepper_for(sim: Simulator, agent: &dyn Agent, cfg: &super::RunConfig) -> EpisodeStepper {
    EpisodeStepper::new(
        sim,
        StepperConfig {
            reward: cfg.reward,
            max_steps: cfg.max_steps,
            require_stop: agent.stops(),
        },
    )
}

/// One lockstep step of the batch: every environment decides and writes the observation it
/// decided on (one that has just joined observes its episode's first frame instead), all step
/// together, each records its step; episodes that ended (or failed) write their last parts
/// and leave their slot empty.
fn step_once(
    steppers: &mut [EpisodeStepper],
    agents: &mut [Box<dyn Agent>],
    active: &mut [Option<Active>],
    w: Workers<'_>,
    out: &mut Vec<Outcome>,
) {
    // `None`: an environment that has just joined, observing its first frame.
    let decided: Vec<Result<Option<Decision>, EpisodeError>> = steppers
        .par_iter()
        .zip(agents.par_iter_mut())
        .zip(active.par_iter_mut())
        .map(|((stepper, agent), slot)| {
            let a = slot.as_mut().ok_or_else(|| {
                EpisodeError::OutOfOrder("an environment stepped without an episode".into())
            })?;
            if stepper.awaits_first_observation() {
                return Ok(None);
            }
            let d = agent.decide(stepper.observation(), stepper.sim())?;
            a.parts.before(stepper, &d)?;
            Ok(Some(d))
        })
        .collect();
    let mut commands = Vec::with_capacity(decided.len());
    let mut failed = vec![None; decided.len()];
    for (k, d) in decided.into_iter().enumerate() {
        match d {
            Ok(Some(d)) => commands.push(Command::Step(d)),
            Ok(None) => commands.push(Command::Observe),
            Err(e) => {
                // The episode ends here as a failure; its environment stops (an idle
                // step) and takes the next episode.
                failed[k] = Some(Failed::of(e));
                commands.push(Command::Step(Decision::Stop));
            }
        }
    }
    // One batched step; then each environment records what its step gave.
    let recorded_steps: Result<Vec<Option<Failed>>, Failed> = match step_many(steppers, &commands) {
        Err(e) => Err(Failed::of(EpisodeError::Step(e))),
        Ok(outcomes) => Ok(outcomes
            .par_iter()
            .zip(active.par_iter_mut())
            .zip(failed.par_iter().zip(commands.par_iter()))
            .map(|((o, slot), (f, c))| match (f, slot.as_mut()) {
                (Some(_), _) | (_, None) => None,
                // A first observation is no step: nothing to record.
                (None, Some(_)) if *c == Command::Observe => None,
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
                    w.done((a.index, Err(e.clone())), out);
                }
            }
            return;
        }
    };
    // Episodes that ended (or failed) write their last parts; their environments leave.
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
        w.done(o, out);
    }
}
