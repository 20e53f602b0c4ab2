//! `_VecCore`: N simulators over an episode file, stepped together in Rust threads with the GIL
//! released, for `minos.gym.NavEnv` (N = 1) and `minos.gym.VectorNavEnv`. An episode ends as
//! in `minos run`: on arrival (the success test after a step; unless `require_stop`), on the
//! `stop` action (success when the test holds), or at the step limit; rewards are the run's
//! reward functions. Ended environments reset on their next step (Gymnasium's next-step
//! auto-reset), to their next episode: environment i runs episodes i, i + N, i + 2N, … of the
//! order (episode-id order, or shuffled by the seed given to `reset`).

use glam::Vec3;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;

use minos::episode::format::read_episodes;
use minos::episode::Episode;
use minos::run::agents::{Agent, Decision};
use minos::run::metrics::{reached, Reward};
use minos::run::oracle::OracleAgent;
use minos::seed::{derive_seed, Rng};
use minos::sim::sensors::{CameraSensor, Image};
use minos::sim::{Actions, AgentConfig, Observation, SensorSuite, Simulator};
use minos::store::DataDir;

use crate::convert::{msg_err, path_of, preset, py_err, sensor_suite};
use crate::episodes::PyEpisode;
use crate::sim::{blind, image_shape, load_scene, sensor_specs, single_name, LoadedScene};

/// The name of the action that ends an episode.
const STOP: &str = "stop";

/// One environment.
struct Slot {
    /// Its index (which episodes of the order it runs).
    index: usize,
    /// Episodes started so far since the last seeding.
    started: usize,
    /// The simulator of the current scene and that scene's index.
    sim: Option<(usize, Simulator)>,
    /// The current episode (index into the episodes).
    episode: usize,
    oracle: Option<OracleAgent>,
    needs_reset: bool,
    /// Euclidean and geodesic distance to the goal before the next step.
    before: (f32, Option<f32>),
    steps: u32,
    max_steps: u32,
}

/// What one environment's step produced.
struct Out {
    obs: Observation,
    reward: f32,
    terminated: bool,
    truncated: bool,
    success: bool,
    reset: bool,
    episode: usize,
    steps: u32,
}

/// Settings every environment shares.
struct Shared {
    episodes: Vec<Episode>,
    /// Scene index of each episode.
    scene_of: Vec<usize>,
    scenes: Vec<LoadedScene>,
    order: Vec<usize>,
    agent: AgentConfig,
    sensors: SensorSuite,
    reward: Reward,
    seed: u64,
    max_steps: Option<u32>,
    require_stop: bool,
    names: Vec<&'static str>,
    num_envs: usize,
}

impl Shared {
    /// Starts the slot's next episode and observes.
    fn start(&self, slot: &mut Slot) -> Result<Out, String> {
        let e = self.order[(slot.index + slot.started * self.num_envs) % self.order.len()];
        slot.started += 1;
        let ep = &self.episodes[e];
        let scene = self.scene_of[e];
        if slot.sim.as_ref().is_none_or(|(s, _)| *s != scene) {
            let loaded = &self.scenes[scene];
            let sim = Simulator::new(
                loaded.assets.clone(),
                loaded.renderer.clone(),
                self.agent,
                self.sensors.clone(),
                self.max_steps.unwrap_or(500),
                self.seed,
            );
            slot.sim = Some((scene, sim));
        }
        let (_, sim) = slot.sim.as_mut().ok_or("no simulator")?;
        sim.reset_episode(ep);
        let obs = sim.observe().map_err(|e| e.to_string())?;
        let m = &obs.measurements;
        slot.before = (m.goal_euclidean.unwrap_or(f32::NAN), m.goal_geodesic);
        slot.episode = e;
        slot.oracle = None;
        slot.needs_reset = false;
        slot.steps = 0;
        slot.max_steps = self.max_steps.unwrap_or(ep.max_steps).max(1);
        Ok(Out {
            obs,
            reward: 0.0,
            terminated: false,
            truncated: false,
            success: false,
            reset: true,
            episode: e,
            steps: 0,
        })
    }

    /// Applies action `a` (an index into `names`), or resets an environment that ended.
    fn step(&self, slot: &mut Slot, a: usize) -> Result<Out, String> {
        if slot.needs_reset || slot.sim.is_none() {
            return self.start(slot);
        }
        let name = *self.names.get(a).ok_or_else(|| {
            format!(
                "action {a}: out of range (0..{}: {})",
                self.names.len(),
                self.names.join(", ")
            )
        })?;
        let ep = &self.episodes[slot.episode];
        let (_, sim) = slot.sim.as_mut().ok_or("no simulator")?;
        let out = if name == STOP {
            let success = reached(sim, ep, &sim.state());
            let obs = sim.observe().map_err(|e| e.to_string())?;
            Out {
                obs,
                reward: self
                    .reward
                    .of_step(slot.before, slot.before, slot.max_steps, success),
                terminated: true,
                truncated: false,
                success,
                reset: false,
                episode: slot.episode,
                steps: slot.steps,
            }
        } else {
            let actions = Actions::single(name).unwrap_or(Actions::IDLE);
            let obs = sim.step(actions).map_err(|e| e.to_string())?;
            slot.steps += 1;
            let arrived = !self.require_stop && reached(sim, ep, &sim.state());
            let m = &obs.measurements;
            let after = (m.goal_euclidean.unwrap_or(f32::NAN), m.goal_geodesic);
            let reward = self
                .reward
                .of_step(slot.before, after, slot.max_steps, arrived);
            slot.before = after;
            Out {
                obs,
                reward,
                terminated: arrived,
                truncated: !arrived && slot.steps >= slot.max_steps,
                success: arrived,
                reset: false,
                episode: slot.episode,
                steps: slot.steps,
            }
        };
        slot.needs_reset = out.terminated || out.truncated;
        Ok(out)
    }

    /// The oracle's next action for the slot (an index into `names`; `stop` at the goal).
    fn oracle(&self, slot: &mut Slot) -> Result<usize, String> {
        let Some((_, sim)) = slot.sim.as_ref() else {
            return Ok(0);
        };
        if slot.needs_reset {
            return Ok(0);
        }
        let ep = &self.episodes[slot.episode];
        if slot.oracle.is_none() {
            let mut o = OracleAgent::new();
            o.reset(ep, sim).map_err(|e| e.to_string())?;
            slot.oracle = Some(o);
        }
        let o = slot.oracle.as_mut().ok_or("oracle")?;
        let name = match o.decide(&blind(), sim).map_err(|e| e.to_string())? {
            Decision::Stop => STOP,
            Decision::Act(a) => single_name(&a),
        };
        Ok(self.names.iter().position(|n| *n == name).unwrap_or(0))
    }
}

/// The Rust side of `minos.gym.NavEnv` and `minos.gym.VectorNavEnv`.
#[pyclass(name = "_VecCore", module = "minos")]
pub struct VecCore {
    shared: Shared,
    slots: Vec<Slot>,
    cameras: Vec<CameraSensor>,
    contacts: usize,
    pool: Option<rayon::ThreadPool>,
}

/// Concatenates camera `k`'s images of every output into one buffer of shape `(N, *shape)`.
fn batch_images<'py>(
    py: Python<'py>,
    outs: &[Out],
    k: usize,
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    let mut dims = vec![outs.len()];
    dims.extend_from_slice(shape);
    macro_rules! gather {
        ($pat:ident, $t:ty) => {{
            let mut v: Vec<$t> = Vec::with_capacity(outs.len() * shape.iter().product::<usize>());
            for o in outs {
                if let Some((_, Image::$pat { data, .. })) = o.obs.images.get(k) {
                    v.extend_from_slice(data);
                }
            }
            PyArray1::from_vec(py, v).reshape(dims)?.into_any()
        }};
    }
    macro_rules! gather_tuple {
        ($pat:ident, $t:ty) => {{
            let mut v: Vec<$t> = Vec::with_capacity(outs.len() * shape.iter().product::<usize>());
            for o in outs {
                if let Some((_, Image::$pat(data))) = o.obs.images.get(k) {
                    v.extend_from_slice(data);
                }
            }
            PyArray1::from_vec(py, v).reshape(dims)?.into_any()
        }};
    }
    Ok(match outs.first().and_then(|o| o.obs.images.get(k)) {
        Some((_, Image::U8 { .. })) | None => gather!(U8, u8),
        Some((_, Image::F32 { .. })) => gather!(F32, f32),
        Some((_, Image::U16(_))) => gather_tuple!(U16, u16),
        Some((_, Image::U32(_))) => gather_tuple!(U32, u32),
    })
}

impl VecCore {
    /// Runs `f` on the core's pool (or rayon's global pool) with the GIL released.
    fn parallel<R: Send>(
        &mut self,
        py: Python<'_>,
        f: impl Fn(&Shared, usize, &mut Slot) -> Result<R, String> + Sync + Send,
    ) -> PyResult<Vec<R>> {
        let (shared, slots, pool) = (&self.shared, &mut self.slots, &self.pool);
        let mut work = move || -> Result<Vec<R>, String> {
            slots
                .par_iter_mut()
                .enumerate()
                .map(|(i, s)| f(shared, i, s))
                .collect()
        };
        py.detach(|| match pool {
            Some(p) => p.install(work),
            None => work(),
        })
        .map_err(msg_err)
    }

    /// Batched observations (a dict of `(N, …)` arrays) and infos of `outs`.
    fn batch<'py>(
        &self,
        py: Python<'py>,
        outs: Vec<Out>,
    ) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>)> {
        let n = outs.len();
        let obs = PyDict::new(py);
        for (k, cam) in self.cameras.iter().enumerate() {
            obs.set_item(&cam.name, batch_images(py, &outs, k, &image_shape(cam))?)?;
        }
        let mut goal = Vec::with_capacity(3 * n);
        let mut contact = Vec::with_capacity(self.contacts * n);
        for o in &outs {
            let m = &o.obs.measurements;
            let d = m.goal_direction.unwrap_or([0.0, 0.0]);
            goal.extend([m.goal_euclidean.unwrap_or(0.0), d[0], d[1]]);
            contact.extend(m.contacts.iter().map(|&c| i8::from(c)));
            contact.resize(contact.len().next_multiple_of(self.contacts.max(1)), 0);
        }
        obs.set_item("goal", PyArray1::from_vec(py, goal).reshape([n, 3])?)?;
        if self.contacts > 0 {
            obs.set_item(
                "contact",
                PyArray1::from_vec(py, contact).reshape([n, self.contacts])?,
            )?;
        }
        let info = PyDict::new(py);
        let col = |f: &dyn Fn(&Out) -> f32| -> Vec<f32> { outs.iter().map(f).collect() };
        info.set_item(
            "success",
            PyArray1::from_vec(py, outs.iter().map(|o| o.success).collect::<Vec<bool>>()),
        )?;
        info.set_item(
            "collision",
            PyArray1::from_vec(
                py,
                outs.iter()
                    .map(|o| o.obs.measurements.collision)
                    .collect::<Vec<bool>>(),
            ),
        )?;
        info.set_item(
            "reset",
            PyArray1::from_vec(py, outs.iter().map(|o| o.reset).collect::<Vec<bool>>()),
        )?;
        info.set_item(
            "geodesic",
            PyArray1::from_vec(
                py,
                col(&|o| o.obs.measurements.goal_geodesic.unwrap_or(f32::NAN)),
            ),
        )?;
        info.set_item(
            "euclidean",
            PyArray1::from_vec(
                py,
                col(&|o| o.obs.measurements.goal_euclidean.unwrap_or(f32::NAN)),
            ),
        )?;
        info.set_item(
            "steps",
            PyArray1::from_vec(py, outs.iter().map(|o| i64::from(o.steps)).collect()),
        )?;
        info.set_item(
            "episode_index",
            PyArray1::from_vec(py, outs.iter().map(|o| o.episode as i64).collect()),
        )?;
        info.set_item(
            "episode_id",
            outs.iter()
                .map(|o| self.shared.episodes[o.episode].episode_id.clone())
                .collect::<Vec<_>>(),
        )?;
        let pos: Vec<f32> = outs
            .iter()
            .flat_map(|o| o.obs.measurements.position)
            .collect();
        info.set_item("position", PyArray1::from_vec(py, pos).reshape([n, 3])?)?;
        info.set_item(
            "yaw",
            PyArray1::from_vec(py, col(&|o| o.obs.measurements.yaw)),
        )?;
        Ok((obs, info))
    }
}

#[pymethods]
impl VecCore {
    #[new]
    #[pyo3(signature = (data, episodes, num_envs = 1, agent = "habitat", sensors = None, size = 84, renderer = "cpu", reward = "dist_time", seed = 0, max_steps = None, require_stop = false, allow_body_mismatch = false, threads = None, variant = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        data: &Bound<'_, PyAny>,
        episodes: &Bound<'_, PyAny>,
        num_envs: usize,
        agent: &str,
        sensors: Option<&Bound<'_, PyAny>>,
        size: u32,
        renderer: &str,
        reward: &str,
        seed: u64,
        max_steps: Option<u32>,
        require_stop: bool,
        allow_body_mismatch: bool,
        threads: Option<usize>,
        variant: Option<&str>,
    ) -> PyResult<Self> {
        if num_envs == 0 {
            return Err(msg_err("num_envs: at least one environment"));
        }
        let data = DataDir::new(path_of(data)?);
        let mut eps: Vec<Episode> = match episodes.extract::<Vec<PyEpisode>>() {
            Ok(list) => list.into_iter().map(|e| e.inner).collect(),
            Err(_) => {
                let p = path_of(episodes)?;
                read_episodes(&p).map_err(|e| py_err(e.into()))?
            }
        };
        if let Some(name) = variant {
            data.read_variant(name)
                .map_err(|e| msg_err(format!("--variant {name}: {e}")))?;
            eps = eps.into_iter().map(|e| e.on_variant(name)).collect();
        }
        if eps.is_empty() {
            return Err(msg_err("episodes: no episode to run"));
        }
        eps.sort_by(|a, b| a.episode_id.cmp(&b.episode_id));
        let body = AgentConfig::preset(preset(agent)?);
        let suite = sensor_suite(sensors, size, preset(agent)?)?;
        let choice = crate::convert::renderer(renderer)?;
        let reward = Reward::from_name(reward).ok_or_else(|| {
            msg_err(format!(
                "reward: unknown reward `{reward}` (dist_time, path_delta, geodesic)"
            ))
        })?;
        let mut scene_ids: Vec<String> = eps.iter().map(|e| e.scene_id.clone()).collect();
        scene_ids.sort();
        scene_ids.dedup();
        let pool = threads
            .map(|n| rayon::ThreadPoolBuilder::new().num_threads(n).build())
            .transpose()
            .map_err(|e| msg_err(format!("threads: {e}")))?;
        let load = || -> Vec<Result<LoadedScene, String>> {
            scene_ids
                .par_iter()
                .map(|id| {
                    load_scene(&data, id, &body, choice, allow_body_mismatch)
                        .map_err(|e| format!("scene {id}: {e}"))
                })
                .collect()
        };
        let loaded = py.detach(|| match &pool {
            Some(p) => p.install(load),
            None => load(),
        });
        let problems: Vec<&String> = loaded.iter().filter_map(|r| r.as_ref().err()).collect();
        if let Some(first) = problems.first() {
            return Err(msg_err(format!(
                "{} of the {} scenes of the episodes cannot run: {first}",
                problems.len(),
                scene_ids.len()
            )));
        }
        let scenes: Vec<LoadedScene> = loaded.into_iter().filter_map(Result::ok).collect();
        let scene_of = eps
            .iter()
            .map(|e| scene_ids.binary_search(&e.scene_id).unwrap_or(0))
            .collect();
        let contacts = suite.contact.map_or(0, |c| c.count as usize);
        let cameras = suite.cameras.clone();
        let mut names: Vec<&'static str> = body.action_names().to_vec();
        names.push(STOP);
        let order = (0..eps.len()).collect();
        let slots = (0..num_envs)
            .map(|index| Slot {
                index,
                started: 0,
                sim: None,
                episode: 0,
                oracle: None,
                needs_reset: true,
                before: (f32::NAN, None),
                steps: 0,
                max_steps: 1,
            })
            .collect();
        Ok(VecCore {
            shared: Shared {
                episodes: eps,
                scene_of,
                scenes,
                order,
                agent: body,
                sensors: suite,
                reward,
                seed,
                max_steps,
                require_stop,
                names,
                num_envs,
            },
            slots,
            cameras,
            contacts,
            pool,
        })
    }

    /// Resets every environment to its next episode; with `seed`, the episode order is
    /// shuffled by it and every environment starts over. Returns `(observations, infos)`.
    #[pyo3(signature = (seed = None))]
    fn reset<'py>(
        &mut self,
        py: Python<'py>,
        seed: Option<u64>,
    ) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>)> {
        if let Some(s) = seed {
            let mut order: Vec<usize> = (0..self.shared.episodes.len()).collect();
            Rng::new(derive_seed(s, &["gym", "episode order"])).shuffle(&mut order);
            self.shared.order = order;
            for slot in &mut self.slots {
                slot.started = 0;
            }
        }
        let outs = self.parallel(py, |sh, _, slot| sh.start(slot))?;
        self.batch(py, outs)
    }

    /// Steps every environment with its action (an integer array, indices into
    /// `action_names`); environments that ended reset instead. Returns `(observations,
    /// rewards, terminated, truncated, infos)`.
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray1<'py, i64>,
    ) -> PyResult<(
        Bound<'py, PyDict>,
        Bound<'py, PyArray1<f32>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyDict>,
    )> {
        let a: Vec<usize> = actions
            .as_slice()?
            .iter()
            .map(|&v| usize::try_from(v).unwrap_or(usize::MAX))
            .collect();
        if a.len() != self.slots.len() {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "{} actions for {} environments",
                a.len(),
                self.slots.len()
            )));
        }
        let outs = self.parallel(py, |sh, i, slot| sh.step(slot, a[i]))?;
        let rewards = PyArray1::from_vec(py, outs.iter().map(|o| o.reward).collect());
        let term = PyArray1::from_vec(py, outs.iter().map(|o| o.terminated).collect());
        let trunc = PyArray1::from_vec(py, outs.iter().map(|o| o.truncated).collect());
        let (obs, info) = self.batch(py, outs)?;
        Ok((obs, rewards, term, trunc, info))
    }

    /// The oracle's next action for every environment (indices into `action_names`; `stop`
    /// once its success test holds; 0 for an environment about to reset).
    fn oracle_actions<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let a = self.parallel(py, |sh, _, slot| sh.oracle(slot).map(|i| i as i64))?;
        Ok(PyArray1::from_vec(py, a))
    }

    /// Marks environments as ended (a Python success or termination rule): they reset on
    /// their next step.
    fn set_done(&mut self, done: PyReadonlyArray1<'_, bool>) -> PyResult<()> {
        for (slot, &d) in self.slots.iter_mut().zip(done.as_slice()?) {
            slot.needs_reset |= d;
        }
        Ok(())
    }

    /// Whether each environment's agent satisfies its episode's success test now.
    fn reached(&self) -> Vec<bool> {
        self.slots
            .iter()
            .map(|s| {
                s.sim.as_ref().is_some_and(|(_, sim)| {
                    reached(sim, &self.shared.episodes[s.episode], &sim.state())
                })
            })
            .collect()
    }

    /// The current episode of every environment.
    fn current_episodes(&self) -> Vec<PyEpisode> {
        self.slots
            .iter()
            .map(|s| PyEpisode {
                inner: self.shared.episodes[s.episode].clone(),
            })
            .collect()
    }

    /// All episodes, in episode-id order.
    #[getter]
    fn episodes(&self) -> Vec<PyEpisode> {
        self.shared
            .episodes
            .iter()
            .map(|e| PyEpisode { inner: e.clone() })
            .collect()
    }

    /// The discrete actions: the agent's single actions, then `stop`.
    #[getter]
    fn action_names(&self) -> Vec<&'static str> {
        self.shared.names.clone()
    }

    /// Name, modality, shape and dtype of each camera (one environment's images).
    #[getter]
    fn sensor_specs<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        sensor_specs(py, &self.cameras)
    }

    /// Contact sensors per environment.
    #[getter]
    fn contact_count(&self) -> usize {
        self.contacts
    }

    /// Number of environments.
    #[getter]
    fn num_envs(&self) -> usize {
        self.slots.len()
    }

    /// The position of every environment's agent as an (N, 3) array (for tests and hooks).
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let flat: Vec<f32> = self
            .slots
            .iter()
            .flat_map(|s| {
                s.sim
                    .as_ref()
                    .map_or(Vec3::ZERO.to_array(), |(_, sim)| sim.state().position)
            })
            .collect();
        Ok(PyArray1::from_vec(py, flat)
            .reshape([self.slots.len(), 3])?
            .into_any())
    }
}
