//! The episode stepper: what an episode is, one decision at a time, for every driver —
//! `minos run`'s rollout (and `minos serve` through it), `minos bench run`, and the Gym
//! environments of the Python bindings (through [`crate::pipeline::vector_env`]).
//!
//! [`EpisodeStepper::reset`] places the agent at an episode's start and observes;
//! [`EpisodeStepper::step`] applies a [`Decision`] and says what it gave: the reward (the
//! run's [`Reward`]), whether the episode *terminated* (on `stop`, a success when the success
//! test holds; or, unless the agent must stop, on arrival: the success test after a step) or
//! was *truncated* (the step limit reached without arrival), and whether the step collided.
//! [`EpisodeStepper::metrics`] gives the episode's metrics. [`step_many`] runs a batch of
//! steppers one command each (a step, or a reset to the next episode), in parallel: the
//! shape of vector environments and of batched rendering.
//!
//! The step limit is the run's (`max_steps`) or else the episode's own; simulators made
//! without an episode at hand use
//! [`DEFAULT_MAX_STEPS`](crate::episode::interchange::DEFAULT_MAX_STEPS).

use glam::Vec3;
use rayon::prelude::*;

use crate::episode::Episode;
use crate::navmesh::geodesic::Geodesic;
use crate::render::gpu::GpuError;
use crate::sim::batch::{observe_many_timed, PhaseTimes};
use crate::sim::AgentConfig;
use crate::sim::{Actions, Observation, Simulator};

use super::agents::{Decision, STOP};
use super::metrics::{ndtw, reached, EpisodeMetrics, Reward};
use super::step_features::StepFeatures;

/// Why a stepper could not step.
#[derive(Debug, thiserror::Error)]
pub enum StepError {
    /// Rendering the observation failed.
    #[error(transparent)]
    Render(#[from] GpuError),
    /// `step` or `metrics` before the first `reset`.
    #[error("the episode stepper was stepped before it was reset to an episode")]
    NotReset,
    /// `step` after the episode ended (terminated or truncated): reset it first.
    #[error("episode {0} has ended: reset the stepper to an episode before stepping it")]
    Ended(String),
    /// [`Command::Observe`] with no prepared episode waiting for its first observation, or
    /// a step before that observation.
    #[error("the episode stepper has no prepared episode waiting for its first observation")]
    NotPrepared,
    /// A batch with a different number of commands than steppers.
    #[error("{commands} commands for {steppers} steppers")]
    Batch {
        /// Steppers in the batch.
        steppers: usize,
        /// Commands given.
        commands: usize,
    },
}

/// The discrete actions of a motion model as environments number them: the model's single
/// actions ([`AgentConfig::action_names`]: its preset's action set), then [`STOP`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ActionSpace {
    singles: &'static [&'static str],
}

impl ActionSpace {
    /// The action set of `motion`.
    pub fn of(agent: &AgentConfig) -> ActionSpace {
        ActionSpace {
            singles: agent.action_names(),
        }
    }

    /// The names, index order: the single actions, then `stop`.
    pub fn names(&self) -> Vec<&'static str> {
        let mut names = self.singles.to_vec();
        names.push(STOP);
        names
    }

    /// Number of actions (`stop` included).
    pub fn len(&self) -> usize {
        self.singles.len() + 1
    }

    /// Never: `stop` is always there.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The decision of action `index` (`None` out of range).
    pub fn decision(&self, index: usize) -> Option<Decision> {
        match self.singles.get(index) {
            Some(name) => Actions::single(name).map(Decision::Act),
            None if index == self.singles.len() => Some(Decision::Stop),
            None => None,
        }
    }

    /// The index of `decision` (`None` for a mix of actions or one outside the set).
    pub fn index_of(&self, decision: &Decision) -> Option<usize> {
        match decision {
            Decision::Stop => Some(self.singles.len()),
            Decision::Act(a) => {
                let name = a.single_name()?;
                self.singles.iter().position(|n| *n == name)
            }
        }
    }
}

/// How a stepper scores and ends episodes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepperConfig {
    /// The reward of each step.
    pub reward: Reward,
    /// A step limit for every episode, overriding the episodes' own.
    pub max_steps: Option<u32>,
    /// Success needs an explicit `stop` at the goal (agents that stop: the oracle, replays,
    /// a person); otherwise arriving ends the episode as a success.
    pub require_stop: bool,
}

/// What one decision did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepOutcome<'a> {
    /// The observation after the decision (after a `stop`, the one the agent stopped with:
    /// a stop does not move it; after a reset, the episode's first).
    pub obs: &'a Observation,
    /// The decision's reward (0 for a reset).
    pub reward: f32,
    /// The episode ended by `stop` or arrival.
    pub terminated: bool,
    /// The episode ended at the step limit without arrival.
    pub truncated: bool,
    /// The episode ended as a success (a `stop` or an arrival within the success test).
    pub success: bool,
    /// The body hit something during the step (never for `stop` or a reset).
    pub collision: bool,
    /// The decision was `stop`.
    pub stopped: bool,
    /// This outcome is a reset to a new episode, not a step.
    pub reset: bool,
    /// Actions applied since the episode's start (a `stop` is not one).
    pub steps: u32,
}

impl StepOutcome<'_> {
    /// The episode ended (terminated or truncated).
    pub fn done(&self) -> bool {
        self.terminated || self.truncated
    }
}

/// One environment: a simulator stepped through episodes with the run's reward, success test
/// and step limit.
pub struct EpisodeStepper {
    sim: Simulator,
    cfg: StepperConfig,
    episode: Option<Episode>,
    obs: Observation,
    /// The episode's step limit.
    limit: u32,
    /// Euclidean and geodesic distance to the goal at the latest observation.
    before: (f32, Option<f32>),
    steps: u32,
    decisions: u32,
    /// The decision that led to the latest observation (`None` at the episode's start).
    previous: Option<Decision>,
    path_length: f32,
    /// The positions the agent passed, the start first, for a VLN episode's nDTW (empty for
    /// other tasks).
    trajectory: Vec<[f32; 3]>,
    collisions: u32,
    success: bool,
    ended: bool,
    /// Prepared ([`EpisodeStepper::prepare_in`]) and not yet observed.
    unobserved: bool,
}

impl EpisodeStepper {
    /// A stepper driving `sim`, scoring and ending episodes as `cfg` says.
    pub fn new(sim: Simulator, cfg: StepperConfig) -> EpisodeStepper {
        EpisodeStepper {
            sim,
            cfg,
            episode: None,
            obs: Observation::blind(),
            limit: 1,
            before: (f32::NAN, None),
            steps: 0,
            decisions: 0,
            previous: None,
            path_length: 0.0,
            trajectory: Vec::new(),
            collisions: 0,
            success: false,
            ended: false,
            unobserved: false,
        }
    }

    /// Whether the episode [`EpisodeStepper::prepare_in`] set up waits for its first
    /// observation ([`Command::Observe`]).
    pub fn awaits_first_observation(&self) -> bool {
        self.unobserved
    }

    /// The simulator (for agents deciding, recorders, hooks).
    pub fn sim(&self) -> &Simulator {
        &self.sim
    }

    /// How the stepper scores and ends episodes.
    pub fn config(&self) -> &StepperConfig {
        &self.cfg
    }

    /// Sets whether success needs an explicit `stop` (the agent's rule).
    pub fn set_require_stop(&mut self, require_stop: bool) {
        self.cfg.require_stop = require_stop;
    }

    /// The action set of the simulator's motion model.
    pub fn action_set(&self) -> ActionSpace {
        ActionSpace::of(self.sim.agent())
    }

    /// The current episode (`None` before the first reset).
    pub fn episode(&self) -> Option<&Episode> {
        self.episode.as_ref()
    }

    /// The latest observation.
    pub fn observation(&self) -> &Observation {
        &self.obs
    }

    /// The current episode's step limit: the configured one, else the episode's (at least 1).
    pub fn max_steps(&self) -> u32 {
        self.limit
    }

    /// Decisions taken in the current episode (each action, and a final `stop`).
    pub fn decisions(&self) -> u32 {
        self.decisions
    }

    /// The current episode has ended (terminated or truncated).
    pub fn ended(&self) -> bool {
        self.ended
    }

    /// Whether the agent satisfies the current episode's success test now.
    pub fn at_goal(&self) -> bool {
        self.episode
            .as_ref()
            .is_some_and(|ep| reached(&self.sim, ep, &self.sim.state()))
    }

    /// The features of the latest observation ([`StepFeatures`]: the goal measurements,
    /// contacts, the last step's collision and decision, the steps left), the one definition
    /// the run tables, the LeRobot export and the Gym observations use. Defaults before the
    /// first reset.
    pub fn features(&self) -> StepFeatures {
        match &self.episode {
            Some(ep) => StepFeatures::new(
                &self.obs.measurements,
                ep,
                self.at_goal(),
                self.previous,
                self.limit.saturating_sub(self.steps),
            ),
            None => StepFeatures::default(),
        }
    }

    /// Resets to `episode`'s start and observes.
    pub fn reset(&mut self, episode: &Episode) -> Result<&Observation, StepError> {
        self.reset_in(episode, None)
    }

    /// [`EpisodeStepper::reset`] computing the goal's distance field with `geo`, geodesic data
    /// of the simulator's grid shared by a scene's episodes (see [`Simulator::reset_in`]).
    pub fn reset_in(
        &mut self,
        episode: &Episode,
        geo: Option<&Geodesic<'_>>,
    ) -> Result<&Observation, StepError> {
        self.prepare_in(episode, geo);
        self.unobserved = false;
        self.observe_first()
    }

    /// Sets the stepper up for `episode` — the simulator reset (its goal field on `geo`'s
    /// query structures when given), the bookkeeping restarted — without observing its start:
    /// the first observation is the next [`Command::Observe`]'s, which a batch renders with
    /// the other environments' frames ([`step_many`]). The expensive part of a start (the
    /// goal field) can so run beside a lockstep while its first frame joins the lockstep's
    /// render call.
    pub fn prepare_in(&mut self, episode: &Episode, geo: Option<&Geodesic<'_>>) {
        self.sim.reset_episode_in(episode, geo);
        self.restart(episode);
        self.unobserved = true;
    }

    /// Resets the episode's bookkeeping to `episode` without touching the simulator.
    fn restart(&mut self, episode: &Episode) {
        self.limit = self.cfg.max_steps.unwrap_or(episode.max_steps).max(1);
        self.episode = Some(episode.clone());
        self.steps = 0;
        self.decisions = 0;
        self.previous = None;
        self.path_length = 0.0;
        self.trajectory.clear();
        if episode.route.is_some() {
            self.trajectory.push(self.sim.state().position);
        }
        self.collisions = 0;
        self.success = false;
        self.ended = false;
    }

    /// Observes the episode's start.
    fn observe_first(&mut self) -> Result<&Observation, StepError> {
        self.obs = self.sim.observe()?;
        let m = &self.obs.measurements;
        self.before = (m.goal_euclidean.unwrap_or(f32::NAN), m.goal_geodesic);
        Ok(&self.obs)
    }

    /// Applies `decision` and says what it gave.
    pub fn step(&mut self, decision: Decision) -> Result<StepOutcome<'_>, StepError> {
        self.run(Command::Step(decision))
    }

    /// The part of `command` before its observation: the reset or the motion, and the
    /// outcome of a `stop` (which observes nothing new).
    fn begin(&mut self, command: Command<'_>) -> Result<Pending, StepError> {
        let decision = match command {
            Command::Reset(episode) => {
                self.sim.reset_episode_in(episode, None);
                self.restart(episode);
                self.unobserved = false;
                return Ok(Pending::Reset);
            }
            Command::Observe => {
                if !self.unobserved {
                    return Err(StepError::NotPrepared);
                }
                self.unobserved = false;
                return Ok(Pending::Reset);
            }
            Command::Step(decision) => decision,
        };
        let ep = self.episode.as_ref().ok_or(StepError::NotReset)?;
        if self.unobserved {
            return Err(StepError::NotPrepared);
        }
        if self.ended {
            return Err(StepError::Ended(ep.episode_id.clone()));
        }
        self.decisions += 1;
        self.previous = Some(decision);
        Ok(match decision {
            Decision::Stop => {
                let success = reached(&self.sim, ep, &self.sim.state());
                let reward = self
                    .cfg
                    .reward
                    .of_step(self.before, self.before, self.limit, success);
                self.success = success;
                self.ended = true;
                Pending::Stopped { reward, success }
            }
            Decision::Act(actions) => {
                let from = self.sim.state().position;
                self.sim.advance(actions);
                Pending::Moved { from }
            }
        })
    }

    /// The rest of a command begun with [`EpisodeStepper::begin`], given the observation it
    /// needs (see [`Pending::observes`]).
    fn finish(&mut self, pending: Pending, obs: Option<Observation>) -> StepOutcome<'_> {
        if let Some(obs) = obs {
            self.obs = obs;
        }
        let m = &self.obs.measurements;
        let after = (m.goal_euclidean.unwrap_or(f32::NAN), m.goal_geodesic);
        // (reward, terminated, truncated, success, collision, stopped, reset)
        let o = match pending {
            Pending::Reset => {
                self.before = after;
                (0.0, false, false, false, false, false, true)
            }
            Pending::Stopped { reward, success } => {
                (reward, true, false, success, false, true, false)
            }
            Pending::Moved { from } => {
                self.steps += 1;
                let to = self.sim.state();
                self.path_length += Vec3::from_array(from).distance(Vec3::from_array(to.position));
                if !self.trajectory.is_empty() {
                    self.trajectory.push(to.position);
                }
                self.collisions += u32::from(m.collision);
                let arrived = !self.cfg.require_stop
                    && self
                        .episode
                        .as_ref()
                        .is_some_and(|ep| reached(&self.sim, ep, &to));
                let reward = self
                    .cfg
                    .reward
                    .of_step(self.before, after, self.limit, arrived);
                self.before = after;
                self.success = arrived;
                let truncated = !arrived && self.steps >= self.limit;
                self.ended = arrived || truncated;
                (
                    reward,
                    arrived,
                    truncated,
                    arrived,
                    m.collision,
                    false,
                    false,
                )
            }
        };
        let (reward, terminated, truncated, success, collision, stopped, reset) = o;
        StepOutcome {
            obs: &self.obs,
            reward,
            terminated,
            truncated,
            success,
            collision,
            stopped,
            reset,
            steps: if reset { 0 } else { self.steps },
        }
    }

    /// The current episode's metrics so far (final once it has ended): steps count every
    /// decision, a final `stop` included.
    pub fn metrics(&self) -> Result<EpisodeMetrics, StepError> {
        let ep = self.episode.as_ref().ok_or(StepError::NotReset)?;
        let mut m = EpisodeMetrics::finish(
            self.success,
            self.decisions,
            self.limit,
            self.path_length,
            self.collisions,
            ep.geodesic_distance,
            self.obs.measurements.goal_geodesic.unwrap_or(f32::NAN),
        );
        if let Some(route) = &ep.route {
            m.ndtw = ndtw(&route.path, &self.trajectory);
        }
        Ok(m)
    }

    /// Runs `command`: a reset (an outcome with `reset` set) or a step.
    pub fn run(&mut self, command: Command<'_>) -> Result<StepOutcome<'_>, StepError> {
        let pending = self.begin(command)?;
        let obs = if pending.observes() {
            Some(self.sim.observe()?)
        } else {
            None
        };
        Ok(self.finish(pending, obs))
    }
}

/// A command between its motion and its observation.
#[derive(Debug, Clone, Copy)]
enum Pending {
    /// Reset to a new episode: the first frame is to be observed.
    Reset,
    /// Moved from `from`: the frame after the step is to be observed.
    Moved { from: [f32; 3] },
    /// Stopped (nothing new to observe) with this reward and success.
    Stopped { reward: f32, success: bool },
}

impl Pending {
    /// Whether the command needs a new observation.
    fn observes(&self) -> bool {
        !matches!(self, Pending::Stopped { .. })
    }
}

/// What one stepper of a batch does in [`step_many`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Command<'e> {
    /// Reset to this episode (and observe).
    Reset(&'e Episode),
    /// Observe the start of the episode [`EpisodeStepper::prepare_in`] set up (an outcome
    /// with `reset` set, as [`Command::Reset`]'s).
    Observe,
    /// Take this decision.
    Step(Decision),
}

/// Runs `commands[i]` on `steppers[i]` for every i at once, in parallel on the current rayon
/// pool, with every new observation rendered together
/// ([`observe_many`](crate::sim::batch::observe_many): the cameras of the
/// steppers that share a renderer in one render call). Each stepper is independent: the
/// outcomes are those of running them one by one. The first failure in batch order is
/// returned.
///
/// Scene data built on first use (the CPU ray caster's BVH) must be built before the batch
/// (see [`crate::sim::prepare_render`]): a pool thread waiting on another's
/// lazy build while that build waits on pool work deadlocks.
pub fn step_many<'s>(
    steppers: &'s mut [EpisodeStepper],
    commands: &[Command<'_>],
) -> Result<Vec<StepOutcome<'s>>, StepError> {
    step_many_timed(steppers, commands, &mut PhaseTimes::default())
}

/// [`step_many`], adding the time of its phases to `times` (and counting the batch).
pub fn step_many_timed<'s>(
    steppers: &'s mut [EpisodeStepper],
    commands: &[Command<'_>],
    times: &mut PhaseTimes,
) -> Result<Vec<StepOutcome<'s>>, StepError> {
    if steppers.len() != commands.len() {
        return Err(StepError::Batch {
            steppers: steppers.len(),
            commands: commands.len(),
        });
    }
    // Motion (and resets, stops) in parallel; then every new observation at once — the
    // cameras of all steppers sharing a renderer in one render call, one GPU submission —
    // and the bookkeeping in parallel.
    let t = std::time::Instant::now();
    let pending: Vec<Pending> = steppers
        .par_iter_mut()
        .zip(commands.par_iter())
        .map(|(s, c)| s.begin(*c))
        .collect::<Result<_, _>>()?;
    PhaseTimes::lap(&mut times.motion, t);
    let mut sims: Vec<&mut Simulator> = steppers
        .iter_mut()
        .zip(&pending)
        .filter(|(_, p)| p.observes())
        .map(|(s, _)| &mut s.sim)
        .collect();
    let mut observed = observe_many_timed(&mut sims, times).into_iter();
    let mut observations: Vec<Option<Observation>> = Vec::with_capacity(pending.len());
    for p in &pending {
        observations.push(if p.observes() {
            let obs = observed.next().ok_or(StepError::Batch {
                steppers: steppers.len(),
                commands: commands.len(),
            })?;
            Some(obs?)
        } else {
            None
        });
    }
    let t = std::time::Instant::now();
    let outcomes = steppers
        .par_iter_mut()
        .zip(pending.into_par_iter())
        .zip(observations.into_par_iter())
        .map(|((s, p), o)| s.finish(p, o))
        .collect();
    PhaseTimes::lap(&mut times.finish, t);
    times.batches += 1;
    Ok(outcomes)
}
