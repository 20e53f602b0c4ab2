//! Vector environments: N episode steppers over one episode list, stepped together — the
//! library side of the Python bindings' `NavEnv` (N = 1) and `VectorNavEnv`.
//!
//! Episodes end as in `minos run` (the [`EpisodeStepper`]'s rules: arrival unless
//! `require_stop`, `stop`, the step limit); ended environments reset on their next step
//! (Gymnasium's next-step auto-reset) to their next episode: environment i runs episodes i,
//! i + N, i + 2N, … of the order (episode-id order, or shuffled by [`VectorEnv::reset`]'s
//! seed). A step of all environments is one [`step_many`] batch on the environments' thread
//! pool.
//!
//! Set-up loads each scene once, in parallel, and builds there what rendering needs
//! ([`prepare_render`]); simulators are then made outside parallel work, so no pool thread
//! ever waits on another's lazy build (which deadlocked N ≥ 8 environments on N threads).

use std::sync::Arc;

use rayon::prelude::*;

use super::rollout::{load_scene_assets, SceneLoadError};
use crate::episode::interchange::DEFAULT_MAX_STEPS;
use crate::episode::Episode;
use crate::render::{Renderer, RendererChoice};
use crate::run::agents::{Agent, AgentError, Decision};
use crate::run::metrics::Reward;
use crate::run::oracle::OracleAgent;
use crate::run::step_features::StepFeatures;
use crate::run::stepper::{
    step_many, ActionSpace, Command, EpisodeStepper, StepError, StepperConfig,
};
use crate::seed::{derive_seed, Rng};
use crate::sim::prepare_render;
use crate::sim::{AgentConfig, Observation, SceneAssets, SensorSuite, Simulator};
use crate::store::DataDir;

/// What a vector environment runs.
#[derive(Debug, Clone)]
pub struct VectorEnvConfig {
    /// DATA folder (ingested, baked).
    pub data: DataDir,
    /// Number of environments.
    pub num_envs: usize,
    /// Body and motion.
    pub agent_config: AgentConfig,
    /// Sensors.
    pub sensors: SensorSuite,
    /// Renderer.
    pub renderer: RendererChoice,
    /// Reward function.
    pub reward: Reward,
    /// Seed (sensor noise).
    pub seed: u64,
    /// Step limit overriding the episodes' own.
    pub max_steps: Option<u32>,
    /// Success needs an explicit `stop` at the goal.
    pub require_stop: bool,
    /// Run on grids baked for another body than `body`.
    pub allow_body_mismatch: bool,
    /// Threads of the environments' own pool (`None`: rayon's global pool).
    pub threads: Option<usize>,
}

/// Why a vector environment cannot be made or stepped.
#[derive(Debug, thiserror::Error)]
pub enum VectorEnvError {
    /// No environment asked for.
    #[error("at least one environment is needed")]
    NoEnvironments,
    /// No episode given.
    #[error("no episode to run")]
    NoEpisodes,
    /// The thread pool could not be made.
    #[error("{0}")]
    Threads(#[from] rayon::ThreadPoolBuildError),
    /// Scenes of the episodes cannot run (not ingested, not baked, baked for another body).
    #[error("{count} of the {total} scenes of the episodes cannot run: scene {scene}")]
    NotReady {
        /// Scenes that cannot run.
        count: usize,
        /// Scenes the episodes name.
        total: usize,
        /// The first scene that cannot run (in scene-id order).
        scene: String,
        /// Why it cannot.
        #[source]
        first: SceneLoadError,
    },
    /// An action index outside the action set.
    #[error("action {action}: out of range (0..{}: {})", names.len(), names.join(", "))]
    Action {
        /// The index given.
        action: usize,
        /// The action set's names.
        names: Vec<&'static str>,
    },
    /// A different number of actions than environments.
    #[error("{actions} actions for {envs} environments")]
    Actions {
        /// Actions given.
        actions: usize,
        /// Environments.
        envs: usize,
    },
    /// An environment could not step.
    #[error(transparent)]
    Step(#[from] StepError),
    /// The oracle could not decide.
    #[error(transparent)]
    Agent(#[from] AgentError),
}

/// What one environment's step (or auto-reset) gave.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnvOutcome {
    /// The step's reward (0 for a reset).
    pub reward: f32,
    /// The episode ended by `stop` or arrival.
    pub terminated: bool,
    /// The episode ended at the step limit.
    pub truncated: bool,
    /// The episode ended as a success.
    pub success: bool,
    /// The body hit something during the step.
    pub collision: bool,
    /// The environment reset to a new episode instead of stepping.
    pub reset: bool,
    /// Index of the environment's episode (into [`VectorEnv::episodes`]).
    pub episode: usize,
    /// Actions applied since the episode's start.
    pub steps: u32,
}

/// A loaded scene: its assets and renderer, shared by every simulator of it.
struct LoadedScene {
    assets: Arc<SceneAssets>,
    renderer: Arc<Renderer>,
}

/// One environment's place in the episode order.
struct Slot {
    /// Episodes started since the last seeding.
    started: usize,
    /// Scene index of the stepper's simulator.
    scene: usize,
    /// The current episode (index into the episodes).
    episode: usize,
    /// Resets on its next step.
    needs_reset: bool,
    /// The oracle of the current episode, made on first use.
    oracle: Option<OracleAgent>,
}

/// N environments over an episode list (see the module documentation).
pub struct VectorEnv {
    /// Episodes in episode-id order.
    episodes: Vec<Episode>,
    /// Scene index of each episode.
    scene_of: Vec<usize>,
    scenes: Vec<LoadedScene>,
    /// The episode order (indices into `episodes`).
    order: Vec<usize>,
    body: AgentConfig,
    sensors: SensorSuite,
    seed: u64,
    stepping: StepperConfig,
    actions: ActionSpace,
    steppers: Vec<EpisodeStepper>,
    slots: Vec<Slot>,
    pool: Option<rayon::ThreadPool>,
}

impl VectorEnv {
    /// Loads the scenes of `episodes` (each once, in parallel) and makes `cfg.num_envs`
    /// environments over them; none has started an episode yet.
    pub fn new(cfg: &VectorEnvConfig, episodes: Vec<Episode>) -> Result<Self, VectorEnvError> {
        if cfg.num_envs == 0 {
            return Err(VectorEnvError::NoEnvironments);
        }
        if episodes.is_empty() {
            return Err(VectorEnvError::NoEpisodes);
        }
        let mut episodes = episodes;
        episodes.sort_by(|a, b| a.episode_id.cmp(&b.episode_id));
        let mut scene_ids: Vec<String> = episodes.iter().map(|e| e.scene_id.clone()).collect();
        scene_ids.sort();
        scene_ids.dedup();
        let pool = cfg
            .threads
            .map(|n| rayon::ThreadPoolBuilder::new().num_threads(n).build())
            .transpose()?;
        // Each scene is loaded and prepared by one task: nothing else touches it meanwhile.
        let load = || -> Vec<Result<LoadedScene, SceneLoadError>> {
            scene_ids
                .par_iter()
                .map(|id| {
                    let (assets, renderer) = load_scene_assets(
                        &cfg.data,
                        id,
                        &cfg.agent_config,
                        cfg.renderer,
                        cfg.allow_body_mismatch,
                    )?;
                    prepare_render(&assets, &renderer, &cfg.sensors);
                    Ok(LoadedScene { assets, renderer })
                })
                .collect()
        };
        let loaded = match &pool {
            Some(p) => p.install(load),
            None => load(),
        };
        let count = loaded.iter().filter(|r| r.is_err()).count();
        let mut scenes: Vec<LoadedScene> = Vec::with_capacity(loaded.len());
        for (id, r) in scene_ids.iter().zip(loaded) {
            match r {
                Ok(s) => scenes.push(s),
                Err(first) => {
                    return Err(VectorEnvError::NotReady {
                        count,
                        total: scene_ids.len(),
                        scene: id.clone(),
                        first,
                    })
                }
            }
        }
        let scene_of: Vec<usize> = episodes
            .iter()
            .map(|e| scene_ids.binary_search(&e.scene_id).unwrap_or(0))
            .collect();
        let stepping = StepperConfig {
            reward: cfg.reward,
            max_steps: cfg.max_steps,
            require_stop: cfg.require_stop,
        };
        let mut env = VectorEnv {
            order: (0..episodes.len()).collect(),
            episodes,
            scene_of,
            scenes,
            body: cfg.agent_config,
            sensors: cfg.sensors.clone(),
            seed: cfg.seed,
            stepping,
            actions: ActionSpace::of(&cfg.agent_config),
            steppers: Vec::with_capacity(cfg.num_envs),
            slots: Vec::with_capacity(cfg.num_envs),
            pool,
        };
        for index in 0..cfg.num_envs {
            let episode = env.order[index % env.order.len()];
            let scene = env.scene_of[episode];
            env.steppers.push(env.stepper_on(scene));
            env.slots.push(Slot {
                started: 0,
                scene,
                episode: 0,
                needs_reset: true,
                oracle: None,
            });
        }
        Ok(env)
    }

    /// A stepper on a new simulator of scene `scene`.
    fn stepper_on(&self, scene: usize) -> EpisodeStepper {
        let loaded = &self.scenes[scene];
        let sim = Simulator::new(
            loaded.assets.clone(),
            loaded.renderer.clone(),
            self.body,
            self.sensors.clone(),
            self.stepping.max_steps.unwrap_or(DEFAULT_MAX_STEPS),
            self.seed,
        );
        EpisodeStepper::new(sim, self.stepping)
    }

    /// Moves environment `i` to its next episode in the order (its stepper to that episode's
    /// scene first) and returns the episode's index.
    fn next_episode(&mut self, i: usize) -> usize {
        let n = self.slots.len();
        let slot = &self.slots[i];
        let e = self.order[(i + slot.started * n) % self.order.len()];
        let scene = self.scene_of[e];
        if scene != slot.scene {
            self.steppers[i] = self.stepper_on(scene);
        }
        let slot = &mut self.slots[i];
        slot.started += 1;
        slot.scene = scene;
        slot.episode = e;
        slot.oracle = None;
        e
    }

    /// Runs one batch: `actions[i]` for environment i (`None`: reset every environment).
    fn batch(&mut self, actions: Option<&[usize]>) -> Result<Vec<EnvOutcome>, VectorEnvError> {
        let n = self.slots.len();
        match actions {
            Some(a) if a.len() != n => {
                return Err(VectorEnvError::Actions {
                    actions: a.len(),
                    envs: n,
                })
            }
            Some(_) => {}
            None => self.slots.iter_mut().for_each(|s| s.needs_reset = true),
        }
        // Every action is checked before anything moves; then the episodes to reset to are
        // chosen (and simulators moved) one by one, and the batch resets or steps every
        // environment in parallel.
        let mut decisions = Vec::with_capacity(n);
        for (i, slot) in self.slots.iter().enumerate() {
            let a = match actions {
                Some(a) if !slot.needs_reset => a[i],
                _ => {
                    decisions.push(None);
                    continue;
                }
            };
            let d = self
                .actions
                .decision(a)
                .ok_or_else(|| VectorEnvError::Action {
                    action: a,
                    names: self.actions.names(),
                })?;
            decisions.push(Some(d));
        }
        // A step's decision, or the episode to reset to.
        let mut plan: Vec<Result<Decision, usize>> = Vec::with_capacity(n);
        for (i, d) in decisions.into_iter().enumerate() {
            plan.push(d.ok_or_else(|| self.next_episode(i)));
        }
        let episodes = &self.episodes;
        let commands: Vec<Command<'_>> = plan
            .iter()
            .map(|p| match p {
                Ok(d) => Command::Step(*d),
                Err(e) => Command::Reset(&episodes[*e]),
            })
            .collect();
        let (steppers, pool) = (&mut self.steppers, &self.pool);
        let mut work = || -> Result<Vec<EnvOutcome>, StepError> {
            Ok(step_many(steppers, &commands)?
                .into_iter()
                .map(|o| EnvOutcome {
                    reward: o.reward,
                    terminated: o.terminated,
                    truncated: o.truncated,
                    success: o.success,
                    collision: o.collision,
                    reset: o.reset,
                    episode: 0,
                    steps: o.steps,
                })
                .collect())
        };
        let mut outs = match pool {
            Some(p) => p.install(work),
            None => work(),
        }?;
        for (o, slot) in outs.iter_mut().zip(&mut self.slots) {
            o.episode = slot.episode;
            slot.needs_reset = o.terminated || o.truncated;
        }
        Ok(outs)
    }

    /// Resets every environment to its next episode; with `seed`, the episode order is
    /// shuffled by it and every environment starts over.
    pub fn reset(&mut self, seed: Option<u64>) -> Result<Vec<EnvOutcome>, VectorEnvError> {
        if let Some(s) = seed {
            let mut order: Vec<usize> = (0..self.episodes.len()).collect();
            Rng::new(derive_seed(s, &["gym", "episode order"])).shuffle(&mut order);
            self.order = order;
            for slot in &mut self.slots {
                slot.started = 0;
            }
        }
        self.batch(None)
    }

    /// Steps every environment with its action (indices into [`VectorEnv::action_names`]);
    /// environments that ended (or never started) reset instead. Nothing steps when an
    /// action is out of range.
    pub fn step(&mut self, actions: &[usize]) -> Result<Vec<EnvOutcome>, VectorEnvError> {
        self.batch(Some(actions))
    }

    /// The oracle's next action for every environment (indices into the action set; `stop`
    /// once its success test holds; 0 for an environment about to reset); `None` where the
    /// oracle finds no plan from the environment's state (a state another driver led it to,
    /// from which the planner's search budget runs out): asked again, it plans anew.
    pub fn oracle_actions(&mut self) -> Result<Vec<Option<usize>>, VectorEnvError> {
        let (slots, steppers, episodes, actions) = (
            &mut self.slots,
            &self.steppers,
            &self.episodes,
            self.actions,
        );
        let mut work = || -> Result<Vec<Option<usize>>, AgentError> {
            slots
                .par_iter_mut()
                .zip(steppers.par_iter())
                .map(|(slot, stepper)| {
                    if slot.needs_reset {
                        return Ok(Some(0));
                    }
                    let sim = stepper.sim();
                    let decided = match &mut slot.oracle {
                        Some(o) => o.decide(&Observation::blind(), sim),
                        empty => {
                            let mut o = OracleAgent::new();
                            o.reset(&episodes[slot.episode], sim)
                                .and_then(|()| empty.insert(o).decide(&Observation::blind(), sim))
                        }
                    };
                    match decided {
                        Ok(d) => Ok(Some(actions.index_of(&d).unwrap_or(0))),
                        Err(AgentError::NoPlan(_) | AgentError::LostPlan(_)) => {
                            // Plan from scratch next time.
                            slot.oracle = None;
                            Ok(None)
                        }
                        Err(e) => Err(e),
                    }
                })
                .collect()
        };
        Ok(match &self.pool {
            Some(p) => p.install(work),
            None => work(),
        }?)
    }

    /// Marks environments as ended (a caller's success or termination rule): they reset on
    /// their next step.
    pub fn set_done(&mut self, done: &[bool]) {
        for (slot, &d) in self.slots.iter_mut().zip(done) {
            slot.needs_reset |= d;
        }
    }

    /// Whether each environment's agent satisfies its episode's success test now.
    pub fn reached(&self) -> Vec<bool> {
        self.steppers.iter().map(EpisodeStepper::at_goal).collect()
    }

    /// The latest observation of environment `i`.
    pub fn observation(&self, i: usize) -> Option<&Observation> {
        self.steppers.get(i).map(EpisodeStepper::observation)
    }

    /// The features of environment `i`'s latest observation (the goal measurements,
    /// contacts, previous collision and action, steps left: [`StepFeatures`], the same the
    /// run tables and the LeRobot export hold).
    pub fn features(&self, i: usize) -> Option<StepFeatures> {
        self.steppers.get(i).map(EpisodeStepper::features)
    }

    /// The object goals' categories of the episodes, sorted and distinct (what an index
    /// into a goal-object vocabulary refers to).
    pub fn goal_objects(&self) -> Vec<String> {
        let mut names: Vec<String> = self
            .episodes
            .iter()
            .filter_map(|e| match &e.goal {
                crate::episode::Goal::Object { category, .. } => Some(category.clone()),
                _ => None,
            })
            .collect();
        names.sort();
        names.dedup();
        names
    }

    /// The stepper of environment `i` (its simulator, episode and observation).
    pub fn stepper(&self, i: usize) -> Option<&EpisodeStepper> {
        self.steppers.get(i)
    }

    /// The current episode of every environment (indices into [`VectorEnv::episodes`]; 0
    /// before an environment's first episode).
    pub fn current_episodes(&self) -> Vec<usize> {
        self.slots.iter().map(|s| s.episode).collect()
    }

    /// All episodes, in episode-id order.
    pub fn episodes(&self) -> &[Episode] {
        &self.episodes
    }

    /// The action set (the motion model's single actions, then `stop`).
    pub fn action_set(&self) -> ActionSpace {
        self.actions
    }

    /// The action names, index order.
    pub fn action_names(&self) -> Vec<&'static str> {
        self.actions.names()
    }

    /// Number of environments.
    pub fn num_envs(&self) -> usize {
        self.slots.len()
    }

    /// The position of every environment's agent (the origin before its first episode).
    pub fn positions(&self) -> Vec<[f32; 3]> {
        self.steppers
            .iter()
            .map(|s| s.sim().state().position)
            .collect()
    }
}
