//! `minos.PathFinder`: path queries on a baked grid like Habitat's `sim.pathfinder`, with the
//! answers of `minos nav query` (the same library calls: `route` for one pair, `route_many`
//! on one shared `Geodesic` for arrays of pairs).

use glam::Vec3;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use minos::navmesh::geodesic::Geodesic;
use minos::navmesh::route::{route, route_many, Route};
use minos::navmesh::NavGrid;
use minos::scene::SceneRef;
use minos::seed::{derive_seed, Rng};
use minos::store::DataDir;

use crate::convert::{bad_input, msg_err, path_of, point};

/// Path queries on the navigation grid of one scene: `PathFinder(data, scene, seed=0)`.
///
/// Points are (x, y, z) in world metres with y the floor height under the agent; they snap
/// to the nearest walkable span within 2 m, as in `minos nav query`.
#[pyclass(module = "minos")]
pub struct PathFinder {
    grid: NavGrid,
    file: String,
    rng: Rng,
}

/// `(N, 3)` float32 points from an array or a sequence of points.
fn points(obj: &Bound<'_, PyAny>) -> PyResult<Vec<Vec3>> {
    if let Some(points) = array_points::<f32>(obj) {
        return points;
    }
    if let Some(points) = array_points::<f64>(obj) {
        return points;
    }
    obj.try_iter()?.map(|p| point(&p?)).collect()
}

/// The rows of `obj` as points when it is a 2-D array of `T`; `None` when it is not one.
fn array_points<T>(obj: &Bound<'_, PyAny>) -> Option<PyResult<Vec<Vec3>>>
where
    T: numpy::Element + Copy + Into<f64>,
{
    let a = obj.extract::<PyReadonlyArray2<'_, T>>().ok()?;
    if a.shape()[1] != 3 {
        return Some(Err(pyo3::exceptions::PyValueError::new_err(
            "expected an (N, 3) array of points",
        )));
    }
    let f = |v: T| v.into() as f32;
    Some(Ok(a
        .as_array()
        .rows()
        .into_iter()
        .map(|r| Vec3::new(f(r[0]), f(r[1]), f(r[2])))
        .collect()))
}

/// True when `obj` is a 2-D array (the batched form).
fn is_batch(obj: &Bound<'_, PyAny>) -> bool {
    obj.getattr("ndim")
        .and_then(|n| n.extract::<usize>())
        .is_ok_and(|n| n == 2)
}

impl PathFinder {
    fn route(&self, a: Vec3, b: Vec3) -> PyResult<Route> {
        route(&self.grid, a, b)
            .map_err(|e| msg_err(format!("{}: {}", self.file, minos::escape::error_line(&e))))
    }

    fn distances(&self, py: Python<'_>, a: Vec<Vec3>, b: Vec<Vec3>) -> PyResult<Vec<f32>> {
        if a.len() != b.len() {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "{} start points but {} goal points",
                a.len(),
                b.len()
            )));
        }
        let pairs: Vec<(Vec3, Vec3)> = a.into_iter().zip(b).collect();
        let grid = &self.grid;
        Ok(py.detach(|| {
            let geo = Geodesic::new(grid);
            route_many(&geo, &pairs)
                .into_iter()
                .map(|r| r.ok().and_then(|r| r.geodesic).unwrap_or(f32::INFINITY))
                .collect()
        }))
    }
}

#[pymethods]
impl PathFinder {
    #[new]
    #[pyo3(signature = (data, scene, seed = 0))]
    fn new(py: Python<'_>, data: &Bound<'_, PyAny>, scene: &str, seed: u64) -> PyResult<Self> {
        let data = DataDir::new(path_of(data)?);
        let scene_ref = SceneRef::parse(scene);
        let file = data.grid_path(&scene_ref).display().to_string();
        let grid = py
            .detach(|| data.read_grid(&scene_ref))
            .map_err(|e| msg_err(format!("scene {scene}: {}", minos::escape::error_line(&e))))?;
        let rng = Rng::new(derive_seed(seed, &[&grid.scene, "pathfinder"]));
        Ok(PathFinder { grid, file, rng })
    }

    /// Geodesic (shortest-path) distance in metres between two points; `inf` when no path
    /// joins them. With (N, 3) arrays, the distances of every pair as an (N,) float32 array
    /// (`inf` also for points far from walkable floor); a single point far from walkable
    /// floor raises MinosError.
    fn geodesic_distance<'py>(
        &self,
        py: Python<'py>,
        a: &Bound<'py, PyAny>,
        b: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        if is_batch(a) || is_batch(b) {
            return Ok(self.geodesic_distances(py, a, b)?.into_any());
        }
        let r = self.route(point(a)?, point(b)?)?;
        Ok(r.geodesic
            .map_or(f64::INFINITY, f64::from)
            .into_pyobject(py)?
            .into_any())
    }

    /// Geodesic distances of many pairs ((N, 3) arrays or lists of points), answered on one
    /// shared set of query structures in parallel: an (N,) float32 array, `inf` where
    /// unreachable.
    fn geodesic_distances<'py>(
        &self,
        py: Python<'py>,
        a: &Bound<'py, PyAny>,
        b: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let d = self.distances(py, points(a)?, points(b)?)?;
        Ok(PyArray1::from_vec(py, d))
    }

    /// The shortest path between two points, as `nav query --json` reports it: `reachable`,
    /// `geodesic` (None when unreachable), `euclidean`, `rooms` ([{"id", "class"}]), `doors`
    /// (ids) and `path` (a (K, 3) float32 array of points from a to b).
    fn find_path<'py>(
        &self,
        py: Python<'py>,
        a: &Bound<'py, PyAny>,
        b: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (a, b) = (point(a)?, point(b)?);
        let r = self.route(a, b)?;
        let d = PyDict::new(py);
        d.set_item("reachable", r.reachable)?;
        d.set_item("geodesic", r.geodesic)?;
        d.set_item("euclidean", a.distance(b))?;
        let rooms: Vec<Bound<'py, PyDict>> = r
            .room_names(&self.grid)
            .into_iter()
            .map(|(id, class)| {
                let e = PyDict::new(py);
                e.set_item("id", id)?;
                e.set_item("class", class)?;
                Ok(e)
            })
            .collect::<PyResult<_>>()?;
        d.set_item("rooms", rooms)?;
        d.set_item("doors", r.door_ids(&self.grid))?;
        let flat: Vec<f32> = r.points.iter().flat_map(|p| p.to_array()).collect();
        let n = r.points.len();
        d.set_item("path", PyArray1::from_vec(py, flat).reshape([n, 3])?)?;
        Ok(d)
    }

    /// Room ids passed on the shortest path from a to b, in order.
    fn rooms_on_path(&self, a: &Bound<'_, PyAny>, b: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
        let r = self.route(point(a)?, point(b)?)?;
        Ok(r.room_names(&self.grid)
            .into_iter()
            .map(|(id, _)| id)
            .collect())
    }

    /// Door ids passed on the shortest path from a to b, in order.
    fn doors_on_path(&self, a: &Bound<'_, PyAny>, b: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
        let r = self.route(point(a)?, point(b)?)?;
        Ok(r.door_ids(&self.grid))
    }

    /// True when an agent standing at p (y = floor height) is on walkable floor.
    fn is_navigable(&self, p: &Bound<'_, PyAny>) -> PyResult<bool> {
        Ok(self.grid.is_walkable(point(p)?))
    }

    /// The centre of the walkable span nearest to p (within 2 m) as (x, y, z), or None.
    fn snap_point(&self, p: &Bound<'_, PyAny>) -> PyResult<Option<(f32, f32, f32)>> {
        Ok(self.grid.snap(point(p)?).map(|s| {
            let v = self.grid.span_position(s as usize);
            (v.x, v.y, v.z)
        }))
    }

    /// A walkable point drawn uniformly by area (on `island` when given) as (x, y, z). With
    /// `seed`, the draw comes from a generator seeded with (seed, scene) alone, so the same
    /// seed gives the same point; without, from this PathFinder's own generator (seeded at
    /// construction). None when there is no walkable floor.
    #[pyo3(signature = (seed = None, island = None))]
    fn sample_navigable_point(
        &mut self,
        seed: Option<u64>,
        island: Option<u32>,
    ) -> Option<(f32, f32, f32)> {
        let mut fresh;
        let rng = match seed {
            Some(s) => {
                fresh = Rng::new(derive_seed(
                    s,
                    &[&self.grid.scene, "sample_navigable_point"],
                ));
                &mut fresh
            }
            None => &mut self.rng,
        };
        self.grid
            .random_point(rng, island)
            .map(|(_, p)| (p.x, p.y, p.z))
    }

    /// `n` walkable points as an (n, 3) float32 array, drawn like `sample_navigable_point`.
    #[pyo3(signature = (n, seed = None, island = None))]
    fn sample_navigable_points<'py>(
        &mut self,
        py: Python<'py>,
        n: usize,
        seed: Option<u64>,
        island: Option<u32>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let mut fresh;
        let rng = match seed {
            Some(s) => {
                fresh = Rng::new(derive_seed(
                    s,
                    &[&self.grid.scene, "sample_navigable_point"],
                ));
                &mut fresh
            }
            None => &mut self.rng,
        };
        let spans = self.grid.walkable_spans(island);
        let mut flat = Vec::with_capacity(3 * n);
        for _ in 0..n {
            let Some((_, p)) = self.grid.random_point_from(rng, &spans) else {
                break;
            };
            flat.extend(p.to_array());
        }
        let rows = flat.len() / 3;
        PyArray1::from_vec(py, flat).reshape([rows, 3])
    }

    /// The island (connected walkable region) of the span nearest to p, or None.
    fn island_id(&self, p: &Bound<'_, PyAny>) -> PyResult<Option<u32>> {
        Ok(self.grid.island_of(point(p)?))
    }

    /// The radius (m) of an island: the largest distance of its spans from its centroid.
    /// Takes an island id or a point (its island).
    fn island_radius(&self, island: &Bound<'_, PyAny>) -> PyResult<f32> {
        let id = match island.extract::<u32>() {
            Ok(i) => i,
            Err(_) => self
                .grid
                .island_of(point(island)?)
                .ok_or_else(|| bad_input("island_radius: the point is not near walkable floor"))?,
        };
        self.grid
            .islands
            .get(id as usize)
            .map(|i| i.radius)
            .ok_or_else(|| bad_input(format!("island {id}: no such island")))
    }

    /// Number of islands.
    #[getter]
    fn num_islands(&self) -> usize {
        self.grid.islands.len()
    }

    /// Walkable floor area (m²).
    #[getter]
    fn navigable_area(&self) -> f32 {
        self.grid.islands.iter().map(|i| i.area).sum()
    }

    /// The scene id of the grid.
    #[getter]
    fn scene_id(&self) -> &str {
        &self.grid.scene
    }
}
