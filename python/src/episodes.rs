//! Episodes in Python: `minos.read_episodes(path)` and the read-only `Episode` it returns
//! (the library's [`Episode`], fields as properties), and `minos.import_episodes` (`minos
//! episodes import`).

use pyo3::prelude::*;
use pyo3::types::PyDict;

use minos::episode::format::read_episodes as read_file;
use minos::episode::{Episode, Goal};

use crate::convert::{path_of, py_err, term};

/// One episode of an episode file (`minos.read_episodes`): a start pose and a goal.
#[pyclass(name = "Episode", module = "minos", frozen, from_py_object)]
#[derive(Clone)]
pub struct PyEpisode {
    /// The library's episode.
    pub inner: Episode,
}

#[pymethods]
impl PyEpisode {
    /// Stable id `<scene>:<task>:<index>`.
    #[getter]
    fn episode_id(&self) -> &str {
        &self.inner.episode_id
    }
    /// Scene id (`<scene>@<variant>` for variants).
    #[getter]
    fn scene_id(&self) -> &str {
        &self.inner.scene_id
    }
    /// Split subset (`train`, `val`, `test`) or empty.
    #[getter]
    fn split(&self) -> &str {
        &self.inner.split
    }
    /// `pointgoal`, `objectgoal` or `roomgoal`.
    #[getter]
    fn task(&self) -> &'static str {
        self.inner.task.name()
    }
    /// Start position (x, floor height, z).
    #[getter]
    fn start_position(&self) -> (f32, f32, f32) {
        let [x, y, z] = self.inner.start_position;
        (x, y, z)
    }
    /// Start yaw (radians, counter-clockwise about +Y, 0 faces -Z).
    #[getter]
    fn start_yaw(&self) -> f32 {
        self.inner.start_yaw
    }
    /// The goal as a dict: `{"kind": "point", "position": (x, y, z)}`, or `{"kind":
    /// "object"|"room", "category"|"class": name, "targets": [{"id", "position"}]}`.
    #[getter]
    fn goal<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let targets = |t: &[minos::episode::GoalTarget]| -> PyResult<Vec<Bound<'py, PyDict>>> {
            t.iter()
                .map(|t| {
                    let e = PyDict::new(py);
                    e.set_item("id", &t.id)?;
                    e.set_item("position", t.position.to_vec())?;
                    Ok(e)
                })
                .collect()
        };
        match &self.inner.goal {
            Goal::Point { position } => {
                d.set_item("kind", "point")?;
                d.set_item("position", position.to_vec())?;
            }
            Goal::Object {
                category,
                targets: t,
            } => {
                d.set_item("kind", "object")?;
                d.set_item("category", category)?;
                d.set_item("targets", targets(t)?)?;
            }
            Goal::Room { class, targets: t } => {
                d.set_item("kind", "room")?;
                d.set_item("class", class)?;
                d.set_item("targets", targets(t)?)?;
            }
        }
        Ok(d)
    }
    /// Straight-line distance from start to goal (m).
    #[getter]
    fn euclidean_distance(&self) -> f32 {
        self.inner.euclidean_distance
    }
    /// Shortest-path distance from start to goal (m).
    #[getter]
    fn geodesic_distance(&self) -> f32 {
        self.inner.geodesic_distance
    }
    /// `easy`, `medium` or `hard`.
    #[getter]
    fn difficulty(&self) -> &'static str {
        self.inner.difficulty.name()
    }
    /// Success radius (m).
    #[getter]
    fn success_radius(&self) -> f32 {
        self.inner.success_radius
    }
    /// Step limit.
    #[getter]
    fn max_steps(&self) -> u32 {
        self.inner.max_steps
    }
    /// The same episode on variant `name` of its scene (ids become `<scene>@name`).
    fn on_variant(&self, name: &str) -> PyEpisode {
        PyEpisode {
            inner: self.inner.clone().on_variant(name),
        }
    }
    fn __repr__(&self) -> String {
        format!(
            "Episode({}, start=({:.2}, {:.2}, {:.2}), geodesic={:.2} m)",
            self.inner.episode_id,
            self.inner.start_position[0],
            self.inner.start_position[1],
            self.inner.start_position[2],
            self.inner.geodesic_distance
        )
    }
}

/// Reads an episode file (`minos episodes --out FILE`) into a list of `Episode`.
#[pyfunction]
pub fn read_episodes(path: &Bound<'_, PyAny>) -> PyResult<Vec<PyEpisode>> {
    let p = path_of(path)?;
    let eps = read_file(&p).map_err(|e| py_err(e.into()))?;
    Ok(eps.into_iter().map(|inner| PyEpisode { inner }).collect())
}

/// `minos episodes import`: reads `file`, a Habitat-Lab (`format="habitat"`) or MINOS
/// (`"minos-csv"`) episode file, each row as the file says or, with `task="roomgoal"`, a MINOS
/// table as MINOS's RoomGoal configurations read it. With `out`, writes the episode file and
/// its provenance record. Returns `{"episodes": [Episode], "scenes", "out", "provenance"}`
/// (`out` and `provenance` are `None` without `out`).
#[pyfunction]
#[pyo3(signature = (file, format, out = None, task = None))]
pub fn import_episodes<'py>(
    py: Python<'py>,
    file: &Bound<'py, PyAny>,
    format: &str,
    out: Option<&Bound<'py, PyAny>>,
    task: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    use minos::pipeline::episodes::{import_job, ImportJob};
    let job = ImportJob {
        from: term("format", format)?,
        file: path_of(file)?,
        task: task.map(|t| term("task", t)).transpose()?,
        out: out.filter(|o| !o.is_none()).map(path_of).transpose()?,
        command: vec!["minos.import_episodes".to_string()],
    };
    let report = py
        .detach(|| import_job(&job))
        .map_err(|e| py_err(e.into()))?;
    let d = PyDict::new(py);
    let list: Vec<PyEpisode> = report
        .episodes
        .into_iter()
        .map(|inner| PyEpisode { inner })
        .collect();
    d.set_item("episodes", list)?;
    d.set_item("scenes", report.scenes)?;
    let (out, provenance) = report.written.unzip();
    d.set_item("out", out)?;
    d.set_item("provenance", provenance)?;
    Ok(d)
}
