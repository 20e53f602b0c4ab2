//! Translations shared by every binding: errors as `MinosError` with the CLI's one-line
//! message, points, agent presets, renderers, sensor suites, thread pools, and the progress
//! sink that forwards to a Python callback or a tqdm bar.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, PoisonError};

use glam::Vec3;
use numpy::PyReadonlyArray1;
use pyo3::prelude::*;

use minos::body::AgentPreset;
use minos::progress::Progress;
use minos::render::RendererChoice;
use minos::shard::{Shard, ShardSpec};
use minos::sim::SensorSuite;
use minos::vocab::Vocabulary;

use crate::{
    BadInputError, BodyMismatchError, LockedError, MinosError, NotFoundError, NotReadyError,
};

/// The error and its causes on one line ([`minos::escape::error_line`]): exactly what
/// `minos` prints after `error: `.
pub fn one_line(e: &anyhow::Error) -> String {
    minos::escape::error_line(e.as_ref())
}

/// An anyhow error as a `MinosError`, or the subclass its kind asks for (see [`kind`]).
pub fn py_err(e: anyhow::Error) -> PyErr {
    let hint = minos::pipeline::rollout::body_mismatch_of(e.as_ref())
        .map(rebake_hint)
        .or_else(|| minos::store::remedy::remedy_of(e.as_ref()).map(remedy_hint))
        .unwrap_or_default();
    let line = one_line(&e) + &hint;
    // A step of the pipeline not taken yet (no manifest, no grid) is not ready, whatever
    // file turned out to be missing.
    let not_ready = matches!(
        minos::store::remedy::remedy_of(e.as_ref()),
        Some(minos::store::remedy::Remedy::Ingest | minos::store::remedy::Remedy::Bake)
    )
    .then_some(Kind::NotReady);
    // The most specific kind anywhere in the chain: a missing file under a format error is
    // a missing file.
    match e.chain().filter_map(kind).chain(not_ready).min() {
        Some(Kind::BadInput) => BadInputError::new_err(line),
        Some(Kind::Body) => BodyMismatchError::new_err(line),
        Some(Kind::Locked) => LockedError::new_err(line),
        Some(Kind::NotFound) => NotFoundError::new_err(line),
        Some(Kind::NotReady) => NotReadyError::new_err(line),
        None => MinosError::new_err(line),
    }
}

/// The step that fixes an error, as the bindings spell it.
fn remedy_hint(r: minos::store::remedy::Remedy) -> String {
    use minos::store::remedy::Remedy;
    let what = match r {
        Remedy::Ingest => "call minos.ingest(...) first",
        Remedy::Reingest => "ingest it again: minos.ingest(..., force=True)",
        Remedy::Bake => "call minos.bake(data) first (variant=NAME for a variant's grids)",
        Remedy::Rebake => {
            "rebake it: minos.bake(data, force=True) (variant=NAME for a variant's grid)"
        }
        Remedy::DefineVariant => "define it with minos.variants(data, name=NAME, ...)",
        Remedy::MaterialStats => "compute them with minos.variants(data, ..., refresh_stats=True)",
        Remedy::Wait => "or pass wait=True to wait for it",
    };
    format!(" ({what})")
}

/// How to rebake for the agent's body, as the bindings spell it.
fn rebake_hint(b: minos::body::BodyMismatch) -> String {
    let agent = b.agent;
    let bake = match agent.preset() {
        Some(p) => format!("minos.bake(data, preset=\"{}\", force=True)", p.name()),
        None => format!(
            "minos.bake(data, config=FILE, force=True) where FILE sets agent_radius = {}, \
             agent_height = {}, max_climb = {}",
            agent.radius, agent.height, agent.max_climb
        ),
    };
    format!(" (rebake with {bake}, or pass allow_body_mismatch=True)")
}

/// A library error as a `MinosError` or its subclass, with its one line.
pub fn typed_err(e: impl std::error::Error + Send + Sync + 'static) -> PyErr {
    py_err(anyhow::Error::new(e))
}

/// Any displayable error as a `MinosError`.
pub fn msg_err(e: impl std::fmt::Display) -> PyErr {
    MinosError::new_err(e.to_string().replace('\n', " "))
}

/// A keyword argument's value that cannot be used, as a `BadInputError` (the CLI's one-line
/// error for a bad flag).
pub fn bad_input(e: impl std::fmt::Display) -> PyErr {
    BadInputError::new_err(e.to_string().replace('\n', " "))
}

/// The Python exception classes below `MinosError`, most specific first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    Body,
    Locked,
    NotReady,
    NotFound,
    BadInput,
}

/// The kind of one error of a chain, when it has one: a body mismatch, a lock held, scenes
/// not ready, a file that does not exist, or input that is not valid.
fn kind(e: &(dyn std::error::Error + 'static)) -> Option<Kind> {
    use minos::pipeline::rollout::{RolloutError, SceneLoadError};
    use minos::pipeline::vector_env::VectorEnvError;
    use minos::sim::SimError;
    if e.is::<minos::body::BodyMismatch>() {
        return Some(Kind::Body);
    }
    if let Some(e) = e.downcast_ref::<SimError>() {
        return matches!(e, SimError::Body(_)).then_some(Kind::Body);
    }
    if let Some(e) = e.downcast_ref::<SceneLoadError>() {
        return Some(match e {
            SceneLoadError::Assets(SimError::Body(_)) => Kind::Body,
            SceneLoadError::Scene(_) | SceneLoadError::Grid(_) => Kind::NotReady,
            _ => return None,
        });
    }
    if e.is::<minos::lock::LockError>() {
        return Some(Kind::Locked);
    }
    if matches!(
        e.downcast_ref::<RolloutError>(),
        Some(RolloutError::NotReady { .. })
    ) || matches!(
        e.downcast_ref::<VectorEnvError>(),
        Some(VectorEnvError::NotReady { .. })
    ) {
        return Some(Kind::NotReady);
    }
    if e.downcast_ref::<std::io::Error>()
        .is_some_and(|io| io.kind() == std::io::ErrorKind::NotFound)
    {
        return Some(Kind::NotFound);
    }
    if let Some(minos::invalid::SettingsFileError::NotNamed { .. }) = e.downcast_ref() {
        return Some(Kind::BadInput);
    }
    if let Some(minos::pipeline::episodes::ImportJobError::Read(
        minos::episode::import::ImportError::Task { .. },
    )) = e.downcast_ref()
    {
        return Some(Kind::BadInput);
    }
    if let Some(minos::pipeline::split::SplitJobError::Name(_)) = e.downcast_ref() {
        return Some(Kind::BadInput);
    }
    if let Some(e) = e.downcast_ref::<minos::split::SplitError>() {
        use minos::split::SplitError;
        return matches!(
            e,
            SplitError::BadRatios(_)
                | SplitError::ListedTwice { .. }
                | SplitError::NoLists { .. }
                | SplitError::BadName(_)
        )
        .then_some(Kind::BadInput);
    }
    if let Some(e) = e.downcast_ref::<minos::pipeline::variants::VariantsError>() {
        use minos::pipeline::variants::VariantsError;
        return matches!(
            e,
            VariantsError::NoChange { .. } | VariantsError::Spec { .. }
        )
        .then_some(Kind::BadInput);
    }
    let bad_input = e.is::<minos::invalid::Invalid>()
        || e.is::<minos::invalid::SettingsCause>()
        || e.is::<minos::invalid::TomlError>()
        || e.is::<minos::split::ExprError>()
        || e.is::<minos::scene::formats::LoadError>()
        || e.is::<minos::parquet_io::ParquetFileError>()
        || e.is::<minos::episode::format::EpisodeFileError>()
        || e.is::<minos::store::scene_file::SceneFileError>();
    bad_input.then_some(Kind::BadInput)
}

/// A point `(x, y, z)` from any sequence of three numbers (tuple, list, NumPy array).
pub fn point(obj: &Bound<'_, PyAny>) -> PyResult<Vec3> {
    let v: Vec<f32> = if let Ok(a) = obj.extract::<PyReadonlyArray1<'_, f32>>() {
        a.as_slice()?.to_vec()
    } else {
        obj.extract()?
    };
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(pyo3::exceptions::PyValueError::new_err(
            "expected a point: three finite numbers (x, y, z)",
        )),
    }
}

/// The value of the library vocabulary `T` that keyword argument `kwarg` names (`text`): the
/// names the command line's flags take, declared once on the library's enum.
pub fn term<T: Vocabulary>(kwarg: &str, text: &str) -> PyResult<T> {
    T::parse_name(text).map_err(|e| bad_input(format!("{kwarg}: {e}")))
}

/// An agent preset by name (`habitat`, `minos`/`minos-continuous`, `minos-gridworld`,
/// `minos-paper`), given as keyword argument `kwarg` (`agent=` or `preset=`).
pub fn preset(kwarg: &str, name: &str) -> PyResult<AgentPreset> {
    term(kwarg, name)
}

/// A renderer by name (`cpu`, `wgpu`, `auto`).
pub fn renderer(name: &str) -> PyResult<RendererChoice> {
    term("renderer", name)
}

/// A path argument (`str` or `os.PathLike`).
pub fn path_of(obj: &Bound<'_, PyAny>) -> PyResult<PathBuf> {
    obj.extract::<PathBuf>()
}

/// The sensor suite `sensors` names: `None` (the agent preset's default, as the CLI's:
/// `"minos-paper"` for `minos-paper`, else `"minos"`), `"minos"` (MINOS's RGB, depth and
/// semantic at `size`² with 4 contacts), `"minos-paper"` (the paper's grey,
/// depth and semantic at 90° with 4 contacts), `"all"` (every modality), or a sensor
/// file (TOML/JSON, as `--sensors FILE`).
pub fn sensor_suite(
    sensors: Option<&Bound<'_, PyAny>>,
    size: u32,
    preset: AgentPreset,
) -> PyResult<SensorSuite> {
    let Some(obj) = sensors.filter(|o| !o.is_none()) else {
        return Ok(SensorSuite::for_preset(preset, size));
    };
    SensorSuite::from_spec(&path_of(obj)?, size).map_err(typed_err)
}

/// A shard `i/n` or `auto` (from the scheduler's environment), as `--shard`.
pub fn shard(spec: &str) -> PyResult<Shard> {
    ShardSpec::parse(spec)
        .and_then(|s| s.resolve(|k| std::env::var(k).ok()))
        .map_err(|e| bad_input(format!("shard: {e}")))
}

/// Runs `f` on a pool of `threads` workers (0: all cores), or on rayon's global pool.
pub fn with_threads<R: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> R + Send,
) -> Result<R, String> {
    match threads {
        None => Ok(f()),
        Some(n) => Ok(rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| format!("threads: {e}"))?
            .install(f)),
    }
}

/// Forwards the library's progress to Python: a tqdm-like object (`update(n)`, `total`) or a
/// callable `f(done, total)`; `None` reports nothing. Errors the callback raises are printed
/// as unraisable and do not stop the work. Calls come one at a time, in the order the work
/// was counted, so `done` never goes back (workers on several threads finish at once).
pub struct PyProgress {
    target: Option<Py<PyAny>>,
    /// Units done; held while the callback runs.
    done: Mutex<u64>,
    total: AtomicU64,
}

impl PyProgress {
    /// A sink for `target` (may be `None`), starting with `total` units.
    pub fn new(target: Option<Bound<'_, PyAny>>, total: u64) -> Self {
        let p = PyProgress {
            target: target.filter(|t| !t.is_none()).map(Bound::unbind),
            done: Mutex::new(0),
            total: AtomicU64::new(0),
        };
        if total > 0 {
            p.set_total(total);
        }
        p
    }

    fn call(&self, f: impl FnOnce(&Bound<'_, PyAny>) -> PyResult<()>) {
        if let Some(t) = &self.target {
            Python::attach(|py| {
                if let Err(e) = f(t.bind(py)) {
                    e.write_unraisable(py, Some(t.bind(py)));
                }
            });
        }
    }
}

impl Progress for PyProgress {
    fn set_total(&self, total: u64) {
        self.total.store(total, Ordering::Relaxed);
        self.call(|t| {
            if t.hasattr("update")? && t.hasattr("total")? {
                t.setattr("total", total)?;
                if t.hasattr("refresh")? {
                    t.call_method0("refresh")?;
                }
            }
            Ok(())
        });
    }

    fn advance(&self, n: u64) {
        // Counted and reported under one lock (taken before the interpreter, never inside
        // it), so two threads cannot report their counts in the opposite order.
        let mut count = self.done.lock().unwrap_or_else(PoisonError::into_inner);
        *count += n;
        let (done, total) = (*count, self.total.load(Ordering::Relaxed));
        self.call(|t| {
            if t.hasattr("update")? {
                t.call_method1("update", (n,))?;
            } else {
                t.call1((done, total))?;
            }
            Ok(())
        });
    }
}
