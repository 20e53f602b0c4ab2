//! `minos.Simulator`: one agent in one scene (or `scene@variant`), with the CLI's agent
//! presets and sensor files. Observations are dicts of NumPy arrays made from the library's
//! image buffers (moved, not copied per pixel); the oracle's next action is the
//! `GreedyFollower` of Habitat, without its failure cases.

use std::sync::Arc;

use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use minos::episode::Episode;
use minos::pipeline::rollout::{load_scene_assets, SceneLoadError};
use minos::render::{Image, PixelType};
use minos::render::{Renderer, RendererChoice};
use minos::run::agents::{action_set, Agent, Decision, STOP};
use minos::run::metrics::reached;
use minos::run::oracle::OracleAgent;
use minos::sim::{dtype_of, CameraSensor};
use minos::sim::{Actions, AgentConfig, GoalSpec, Observation, SceneAssets, SensorSuite};
use minos::store::DataDir;

use crate::convert::{msg_err, point, preset, py_err, sensor_suite, typed_err};
use crate::episodes::PyEpisode;

/// A scene ready for simulators: its assets and renderer, shared by every simulator on it.
#[derive(Clone)]
pub struct LoadedScene {
    /// Triangles, collision mesh, grid.
    pub assets: Arc<SceneAssets>,
    /// The renderer.
    pub renderer: Arc<Renderer>,
}

/// Loads scene `scene_id` and the grid that serves it, checks the grid's body against the
/// agent's (unless `allow_body_mismatch`) and creates the renderer: what `minos run` does
/// for each scene, with its messages.
pub fn load_scene(
    data: &DataDir,
    scene_id: &str,
    agent: &AgentConfig,
    choice: RendererChoice,
    allow_body_mismatch: bool,
) -> Result<LoadedScene, SceneLoadError> {
    let (assets, renderer) = load_scene_assets(data, scene_id, agent, choice, allow_body_mismatch)?;
    Ok(LoadedScene { assets, renderer })
}

/// The shape of a camera's images: `(height, width, channels)` for colour, depth and normals
/// (Habitat's layout), `(height, width)` for label images (semantic, instance, room).
pub fn image_shape(c: &CameraSensor) -> Vec<usize> {
    let (w, h) = (c.resolution[0] as usize, c.resolution[1] as usize);
    match dtype_of(c) {
        (PixelType::U16 | PixelType::U32, _) => vec![h, w],
        (_, ch) => vec![h, w, ch as usize],
    }
}

/// A NumPy array of `shape` owning `image`'s buffer (no per-pixel work).
pub fn image_array<'py>(
    py: Python<'py>,
    image: Image,
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    Ok(match image {
        Image::U8 { data, .. } => PyArray1::from_vec(py, data).reshape(shape)?.into_any(),
        Image::U16(data) => PyArray1::from_vec(py, data).reshape(shape)?.into_any(),
        Image::U32(data) => PyArray1::from_vec(py, data).reshape(shape)?.into_any(),
        Image::F32 { data, .. } => PyArray1::from_vec(py, data).reshape(shape)?.into_any(),
    })
}

/// The measurements of a step as a dict (`None` where a value is unknown).
pub fn measurements_dict<'py>(
    py: Python<'py>,
    m: &minos::sim::Measurements,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("step", m.step)?;
    d.set_item("position", m.position.to_vec())?;
    d.set_item("yaw", m.yaw)?;
    d.set_item("tilt", m.tilt)?;
    d.set_item("velocity", m.velocity.to_vec())?;
    d.set_item("time_fraction", m.time_fraction)?;
    d.set_item("collision", m.collision)?;
    d.set_item("contact_impulses", m.contact_impulses.clone())?;
    d.set_item("goal_euclidean", m.goal_euclidean)?;
    d.set_item("goal_direction", m.goal_direction.map(|v| v.to_vec()))?;
    d.set_item("goal_geodesic", m.goal_geodesic)?;
    d.set_item(
        "waypoint_direction",
        m.waypoint_direction.map(|v| v.to_vec()),
    )?;
    Ok(d)
}

/// An observation as a dict: one array per camera sensor (by its name), `contact` (bool per
/// contact sensor) and `measurements`.
pub fn observation_dict<'py>(
    py: Python<'py>,
    obs: Observation,
    cameras: &[CameraSensor],
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for ((name, image), cam) in obs.images.into_iter().zip(cameras) {
        d.set_item(name, image_array(py, image, &image_shape(cam))?)?;
    }
    d.set_item(
        "contact",
        PyArray1::from_vec(py, obs.measurements.contacts.clone()),
    )?;
    d.set_item("measurements", measurements_dict(py, &obs.measurements)?)?;
    Ok(d)
}

/// The actions an action argument names: a name (`forward`, `turn_left`, …, `idle`), an
/// index into `names`, or a dict of strengths in [0, 1] (`{"forward": 1.0, "turn_left":
/// 0.5}`).
pub fn parse_action(obj: &Bound<'_, PyAny>, names: &[&str]) -> PyResult<Actions> {
    if let Ok(i) = obj.extract::<usize>() {
        let name = names.get(i).ok_or_else(|| {
            pyo3::exceptions::PyValueError::new_err(format!(
                "action {i}: out of range (0..{}: {})",
                names.len(),
                names.join(", ")
            ))
        })?;
        return named_action(name);
    }
    if let Ok(name) = obj.extract::<String>() {
        return named_action(&name);
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut a = Actions::IDLE;
        for (k, v) in d.iter() {
            let k: String = k.extract()?;
            let v: f32 = v.extract()?;
            *a.strength_mut(&k).ok_or_else(|| unknown_action(&k))? = v;
        }
        return Ok(a);
    }
    Err(pyo3::exceptions::PyTypeError::new_err(
        "an action is a name, an index into action_names, or a dict of strengths",
    ))
}

fn unknown_action(name: &str) -> PyErr {
    pyo3::exceptions::PyValueError::new_err(format!(
        "unknown action `{name}` ({})",
        Actions::NAMES.join(", ")
    ))
}

fn named_action(name: &str) -> PyResult<Actions> {
    Actions::single(name).ok_or_else(|| unknown_action(name))
}

/// One agent in one scene: `Simulator(data, scene, agent="habitat", sensors=None, size=84,
/// renderer="cpu", seed=0, max_steps=500, allow_body_mismatch=False)`.
///
/// `scene` may name a variant (`scene@variant`); `sensors` is None or "minos" (RGB, depth,
/// semantic at size² and 4 contacts: `minos run`'s default), "all" (every modality), or a
/// sensor file (TOML/JSON, as `--sensors`).
#[pyclass(module = "minos")]
pub struct Simulator {
    sim: minos::sim::Simulator,
    cameras: Vec<CameraSensor>,
    episode: Option<Episode>,
    oracle: Option<OracleAgent>,
    max_steps: u32,
}

#[pymethods]
impl Simulator {
    #[new]
    #[pyo3(signature = (data, scene, agent = "habitat", sensors = None, size = 84, renderer = "cpu", seed = 0, max_steps = minos::episode::interchange::DEFAULT_MAX_STEPS, allow_body_mismatch = false))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        data: &Bound<'_, PyAny>,
        scene: &str,
        agent: &str,
        sensors: Option<&Bound<'_, PyAny>>,
        size: u32,
        renderer: &str,
        seed: u64,
        max_steps: u32,
        allow_body_mismatch: bool,
    ) -> PyResult<Self> {
        let data = DataDir::new(crate::convert::path_of(data)?);
        let agent_preset = preset("agent", agent)?;
        let body = AgentConfig::preset(agent_preset);
        let suite: SensorSuite = sensor_suite(sensors, size, agent_preset)?;
        let choice = crate::convert::renderer(renderer)?;
        let loaded = py
            .detach(|| load_scene(&data, scene, &body, choice, allow_body_mismatch))
            .map_err(|e| py_err(anyhow::Error::new(e).context(format!("scene {scene}"))))?;
        let cameras = suite.cameras.clone();
        let sim = minos::sim::Simulator::new(
            loaded.assets,
            loaded.renderer,
            body,
            suite,
            max_steps,
            seed,
        );
        Ok(Simulator {
            sim,
            cameras,
            episode: None,
            oracle: None,
            max_steps,
        })
    }

    /// Places the agent and its goal, and returns the first observation: either
    /// `reset(episode)` with an `Episode` of `minos.read_episodes`, or `reset(start=(x, y, z),
    /// yaw=0.0, goal=(x, y, z) or None, success_radius=0.2, episode_id="")`.
    #[pyo3(signature = (episode = None, *, start = None, yaw = 0.0, goal = None, success_radius = 0.2, episode_id = ""))]
    #[allow(clippy::too_many_arguments)]
    fn reset<'py>(
        &mut self,
        py: Python<'py>,
        episode: Option<PyEpisode>,
        start: Option<&Bound<'py, PyAny>>,
        yaw: f32,
        goal: Option<&Bound<'py, PyAny>>,
        success_radius: f32,
        episode_id: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        self.oracle = None;
        match (episode, start) {
            (Some(e), None) => {
                let ep = e.inner;
                py.detach(|| self.sim.reset_episode(&ep));
                self.episode = Some(ep);
            }
            (None, Some(start)) => {
                let start = point(start)?;
                let goal = goal.filter(|g| !g.is_none()).map(point).transpose()?;
                let scene = self.sim.assets().id.clone();
                self.episode = goal.map(|g| {
                    Episode::point(
                        &scene,
                        episode_id,
                        start,
                        yaw,
                        g,
                        success_radius,
                        self.max_steps,
                    )
                });
                let spec = goal.map(GoalSpec::Point);
                py.detach(|| self.sim.reset(start, yaw, spec, episode_id));
            }
            _ => {
                return Err(pyo3::exceptions::PyTypeError::new_err(
                    "reset takes an episode or start=(x, y, z) (with an optional goal)",
                ))
            }
        }
        self.observe(py)
    }

    /// Applies one action (a name such as "forward", an index into `action_names`, or a dict
    /// of strengths) and returns the observation.
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        action: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let a = parse_action(action, action_set(&self.sim))?;
        let obs = py.detach(|| self.sim.step(a)).map_err(typed_err)?;
        observation_dict(py, obs, &self.cameras)
    }

    /// The observation at the current state, without stepping.
    fn observe<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let obs = py.detach(|| self.sim.observe()).map_err(typed_err)?;
        observation_dict(py, obs, &self.cameras)
    }

    /// The single actions of this agent's motion model (what `step(i)` indexes).
    #[getter]
    fn action_names(&self) -> Vec<&'static str> {
        action_set(&self.sim).to_vec()
    }

    /// Scene id (with its variant).
    #[getter]
    fn scene_id(&self) -> String {
        self.sim.assets().id.clone()
    }

    /// The agent's state: position (base, on the floor), yaw, tilt, velocity.
    #[getter]
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.sim.state();
        let d = PyDict::new(py);
        d.set_item("position", s.position.to_vec())?;
        d.set_item("yaw", s.yaw)?;
        d.set_item("tilt", s.tilt)?;
        d.set_item("velocity", s.velocity.to_vec())?;
        d.set_item("angular_velocity", s.angular_velocity)?;
        Ok(d)
    }

    /// The camera sensors: name, modality, array shape and dtype of each.
    #[getter]
    fn sensor_specs<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        sensor_specs(py, &self.cameras)
    }

    /// True when the agent satisfies the current goal's success test (the one `minos run`
    /// uses); False without a goal.
    fn reached(&self) -> bool {
        self.episode
            .as_ref()
            .is_some_and(|e| reached(&self.sim, e, &self.sim.state()))
    }

    /// The oracle's next action towards the current goal: an action name, or "stop" once
    /// the success test holds. It plans over the agent's reachable states with the
    /// simulator's own motion (re-planning when the agent left the plan), so it reaches every
    /// reachable goal; a goal it cannot reach raises MinosError.
    fn oracle_action(&mut self, py: Python<'_>) -> PyResult<&'static str> {
        let ep = self
            .episode
            .as_ref()
            .ok_or_else(|| msg_err("oracle_action: no goal (reset with an episode or a goal)"))?;
        let sim = &self.sim;
        let oracle = &mut self.oracle;
        py.detach(|| -> Result<&'static str, String> {
            if oracle.is_none() {
                let mut o = OracleAgent::new();
                o.reset(ep, sim)
                    .map_err(|e| minos::escape::error_line(&e))?;
                *oracle = Some(o);
            }
            let o = oracle.as_mut().ok_or("oracle")?;
            Ok(
                match o
                    .decide(&Observation::blind(), sim)
                    .map_err(|e| minos::escape::error_line(&e))?
                {
                    Decision::Stop => STOP,
                    Decision::Act(a) => single_name(&a),
                },
            )
        })
        .map_err(msg_err)
    }
}

/// The name of a single full-strength action (`idle` for anything else).
pub fn single_name(a: &Actions) -> &'static str {
    a.single_name().unwrap_or("idle")
}

/// Name, modality, shape and dtype of each camera.
pub fn sensor_specs<'py>(
    py: Python<'py>,
    cameras: &[CameraSensor],
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    cameras
        .iter()
        .map(|c| {
            let d = PyDict::new(py);
            d.set_item("name", &c.name)?;
            d.set_item(
                "modality",
                serde_json::to_value(c.modality)
                    .ok()
                    .and_then(|v| v.as_str().map(String::from))
                    .unwrap_or_default(),
            )?;
            d.set_item("shape", image_shape(c))?;
            d.set_item("dtype", dtype_of(c).0.name())?;
            Ok(d)
        })
        .collect()
}
