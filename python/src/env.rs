//! `_VecCore`: N simulators over an episode file, stepped together in Rust threads with the GIL
//! released, for `minos.gym.NavEnv` (N = 1) and `minos.gym.VectorNavEnv`: glue over the
//! library's [`VectorEnv`] (episodes end, reward and auto-reset as `minos run` steps them:
//! `minos::run::stepper`). Environment i runs episodes i, i + N, i + 2N, … of the order
//! (episode-id order, or shuffled by the seed given to `reset`).

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use minos::episode::format::read_episodes;
use minos::episode::Episode;
use minos::pipeline::rollout::episodes_on_variant;
use minos::pipeline::vector_env::{EnvOutcome, VectorEnv, VectorEnvConfig, VectorEnvError};
use minos::render::Image;
use minos::run::metrics::Reward;
use minos::run::step_features::StepFeatures;
use minos::sim::CameraSensor;
use minos::sim::{AgentConfig, Observation};
use minos::store::DataDir;

use crate::convert::{bad_input, msg_err, path_of, preset, py_err, sensor_suite, typed_err};
use crate::episodes::PyEpisode;
use crate::sim::{image_shape, sensor_specs};

/// The Rust side of `minos.gym.NavEnv` and `minos.gym.VectorNavEnv`.
#[pyclass(name = "_VecCore", module = "minos")]
pub struct VecCore {
    env: VectorEnv,
    cameras: Vec<CameraSensor>,
    contacts: usize,
}

/// A library error as Python's: the keyword it concerns named as the bindings name it.
fn env_err(e: VectorEnvError) -> PyErr {
    match e {
        VectorEnvError::NoEnvironments => bad_input("num_envs: at least one environment"),
        VectorEnvError::NoEpisodes => bad_input("episodes: no episode to run"),
        VectorEnvError::Threads(e) => bad_input(format!("threads: {e}")),
        VectorEnvError::Actions { .. } => {
            pyo3::exceptions::PyValueError::new_err(minos::escape::error_line(&e))
        }
        e => typed_err(e),
    }
}

/// Concatenates camera `k`'s images of every output into one buffer of shape `(N, *shape)`.
fn batch_images<'py>(
    py: Python<'py>,
    outs: &[&Observation],
    k: usize,
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    let mut dims = vec![outs.len()];
    dims.extend_from_slice(shape);
    macro_rules! gather {
        ($pat:ident, $t:ty) => {{
            let mut v: Vec<$t> = Vec::with_capacity(outs.len() * shape.iter().product::<usize>());
            for o in outs {
                if let Some((_, Image::$pat { data, .. })) = o.images.get(k) {
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
                if let Some((_, Image::$pat(data))) = o.images.get(k) {
                    v.extend_from_slice(data);
                }
            }
            PyArray1::from_vec(py, v).reshape(dims)?.into_any()
        }};
    }
    Ok(match outs.first().and_then(|o| o.images.get(k)) {
        Some((_, Image::U8 { .. })) | None => gather!(U8, u8),
        Some((_, Image::F32 { .. })) => gather!(F32, f32),
        Some((_, Image::U16(_))) => gather_tuple!(U16, u16),
        Some((_, Image::U32(_))) => gather_tuple!(U32, u32),
    })
}

impl VecCore {
    /// Batched observations (a dict of `(N, …)` arrays) and infos of `outs`.
    fn batch<'py>(
        &self,
        py: Python<'py>,
        outs: Vec<EnvOutcome>,
    ) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>)> {
        let n = outs.len();
        let observations: Vec<&Observation> = (0..n)
            .map(|i| {
                self.env
                    .observation(i)
                    .ok_or_else(|| msg_err(format!("environment {i}: no observation")))
            })
            .collect::<PyResult<_>>()?;
        let obs = PyDict::new(py);
        for (k, cam) in self.cameras.iter().enumerate() {
            obs.set_item(
                &cam.name,
                batch_images(py, &observations, k, &image_shape(cam))?,
            )?;
        }
        let features: Vec<StepFeatures> = (0..n)
            .map(|i| {
                self.env
                    .features(i)
                    .ok_or_else(|| msg_err(format!("environment {i}: no observation")))
            })
            .collect::<PyResult<_>>()?;
        let objects = self.env.goal_objects();
        let mut goal = Vec::with_capacity(3 * n);
        let mut goal_room = Vec::with_capacity(9 * n);
        let mut goal_object = Vec::with_capacity(n);
        let mut at_goal = Vec::with_capacity(n);
        let mut contact = Vec::with_capacity(self.contacts * n);
        let mut collision = Vec::with_capacity(n);
        let mut previous = Vec::with_capacity(9 * n);
        let mut steps_left = Vec::with_capacity(n);
        let flag = |b: bool| f32::from(u8::from(b));
        for f in &features {
            goal.extend(f.goal);
            goal_room.extend(f.goal_room_one_hot());
            goal_object.push(
                f.goal_object
                    .as_ref()
                    .and_then(|c| objects.binary_search(c).ok())
                    .map_or(-1, |k| k as i64),
            );
            at_goal.push(flag(f.at_goal));
            contact.extend(f.contacts.iter().map(|&c| i8::from(c)));
            contact.resize(contact.len().next_multiple_of(self.contacts.max(1)), 0);
            collision.push(flag(f.collision));
            previous.extend(f.previous_action_vector());
            steps_left.push(f.steps_left as f32);
        }
        obs.set_item("goal", PyArray1::from_vec(py, goal).reshape([n, 3])?)?;
        obs.set_item(
            "goal_room",
            PyArray1::from_vec(py, goal_room).reshape([n, 9])?,
        )?;
        obs.set_item(
            "goal_object",
            PyArray1::from_vec(py, goal_object).reshape([n, 1])?,
        )?;
        obs.set_item("at_goal", PyArray1::from_vec(py, at_goal).reshape([n, 1])?)?;
        if self.contacts > 0 {
            obs.set_item(
                "contact",
                PyArray1::from_vec(py, contact).reshape([n, self.contacts])?,
            )?;
        }
        obs.set_item(
            "collision",
            PyArray1::from_vec(py, collision).reshape([n, 1])?,
        )?;
        obs.set_item(
            "previous_action",
            PyArray1::from_vec(py, previous).reshape([n, 9])?,
        )?;
        obs.set_item(
            "steps_left",
            PyArray1::from_vec(py, steps_left).reshape([n, 1])?,
        )?;
        let info = PyDict::new(py);
        let col = |f: &dyn Fn(&Observation) -> f32| -> Vec<f32> {
            observations.iter().map(|o| f(o)).collect()
        };
        info.set_item(
            "success",
            PyArray1::from_vec(py, outs.iter().map(|o| o.success).collect::<Vec<bool>>()),
        )?;
        info.set_item(
            "collision",
            PyArray1::from_vec(
                py,
                observations
                    .iter()
                    .map(|o| o.measurements.collision)
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
                col(&|o| o.measurements.goal_geodesic.unwrap_or(f32::NAN)),
            ),
        )?;
        info.set_item(
            "euclidean",
            PyArray1::from_vec(
                py,
                col(&|o| o.measurements.goal_euclidean.unwrap_or(f32::NAN)),
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
        let episodes = self.env.episodes();
        info.set_item(
            "episode_id",
            outs.iter()
                .map(|o| episodes[o.episode].episode_id.clone())
                .collect::<Vec<_>>(),
        )?;
        let pos: Vec<f32> = observations
            .iter()
            .flat_map(|o| o.measurements.position)
            .collect();
        info.set_item("position", PyArray1::from_vec(py, pos).reshape([n, 3])?)?;
        info.set_item("yaw", PyArray1::from_vec(py, col(&|o| o.measurements.yaw)))?;
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
            return Err(env_err(VectorEnvError::NoEnvironments));
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
            eps = episodes_on_variant(&data, Some(name), eps).map_err(|e| {
                crate::convert::py_err(anyhow::Error::new(e).context(format!("variant={name:?}")))
            })?;
        }
        let agent_preset = preset("agent", agent)?;
        let body = AgentConfig::preset(agent_preset);
        let suite = sensor_suite(sensors, size, agent_preset)?;
        let renderer = crate::convert::renderer(renderer)?;
        let reward: Reward = crate::convert::term("reward", reward)?;
        let contacts = suite.contact.map_or(0, |c| c.count as usize);
        let cameras = suite.cameras.clone();
        let cfg = VectorEnvConfig {
            data,
            num_envs,
            agent_config: body,
            sensors: suite,
            renderer,
            reward,
            seed,
            max_steps,
            require_stop,
            allow_body_mismatch,
            threads,
        };
        let env = py.detach(|| VectorEnv::new(&cfg, eps)).map_err(env_err)?;
        Ok(VecCore {
            env,
            cameras,
            contacts,
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
        let env = &mut self.env;
        let outs = py.detach(|| env.reset(seed)).map_err(env_err)?;
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
        let env = &mut self.env;
        let outs = py.detach(|| env.step(&a)).map_err(env_err)?;
        let rewards = PyArray1::from_vec(py, outs.iter().map(|o| o.reward).collect());
        let term = PyArray1::from_vec(py, outs.iter().map(|o| o.terminated).collect());
        let trunc = PyArray1::from_vec(py, outs.iter().map(|o| o.truncated).collect());
        let (obs, info) = self.batch(py, outs)?;
        Ok((obs, rewards, term, trunc, info))
    }

    /// The oracle's next action for every environment (indices into `action_names`; `stop`
    /// once its success test holds; 0 for an environment about to reset; -1 where the oracle
    /// finds no plan from the environment's state).
    fn oracle_actions<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let env = &mut self.env;
        let a = py.detach(|| env.oracle_actions()).map_err(env_err)?;
        Ok(PyArray1::from_vec(
            py,
            a.into_iter().map(|i| i.map_or(-1, |i| i as i64)).collect(),
        ))
    }

    /// Marks environments as ended (a Python success or termination rule): they reset on
    /// their next step.
    fn set_done(&mut self, done: PyReadonlyArray1<'_, bool>) -> PyResult<()> {
        self.env.set_done(done.as_slice()?);
        Ok(())
    }

    /// Whether each environment's agent satisfies its episode's success test now.
    fn reached(&self) -> Vec<bool> {
        self.env.reached()
    }

    /// The current episode of every environment.
    fn current_episodes(&self) -> Vec<PyEpisode> {
        let episodes = self.env.episodes();
        self.env
            .current_episodes()
            .into_iter()
            .map(|e| PyEpisode {
                inner: episodes[e].clone(),
            })
            .collect()
    }

    /// All episodes, in episode-id order.
    #[getter]
    fn episodes(&self) -> Vec<PyEpisode> {
        self.env
            .episodes()
            .iter()
            .map(|e| PyEpisode { inner: e.clone() })
            .collect()
    }

    /// The discrete actions: the agent's single actions, then `stop`.
    #[getter]
    fn action_names(&self) -> Vec<&'static str> {
        self.env.action_names()
    }

    /// Name, modality, shape and dtype of each camera (one environment's images).
    #[getter]
    fn sensor_specs<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        sensor_specs(py, &self.cameras)
    }

    /// The object goals' categories of the episodes, sorted: what the `goal_object`
    /// observation indexes (−1: not an object goal).
    #[getter]
    fn goal_objects(&self) -> Vec<String> {
        self.env.goal_objects()
    }

    /// Contact sensors per environment.
    #[getter]
    fn contact_count(&self) -> usize {
        self.contacts
    }

    /// Number of environments.
    #[getter]
    fn num_envs(&self) -> usize {
        self.env.num_envs()
    }

    /// The position of every environment's agent as an (N, 3) array (for tests and hooks).
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let flat: Vec<f32> = self.env.positions().into_iter().flatten().collect();
        Ok(PyArray1::from_vec(py, flat)
            .reshape([self.env.num_envs(), 3])?
            .into_any())
    }
}
