//! `minos._minos`: the Python bindings of minos, a front door like the command line. Every
//! call translates Python arguments into the library's configuration, calls the same library
//! function the CLI calls, and translates the answer back (images as NumPy arrays built from
//! Rust buffers). No behaviour lives here: the library stays the single source of it.
//!
//! - [`sim`]: `Simulator` (reset, step, observations, the oracle's next action);
//! - [`env`]: `_VecCore`, the Rust side of `minos.gym.NavEnv` and `minos.gym.VectorNavEnv`;
//! - [`pathfinder`]: `PathFinder` (geodesics, paths, snapping, sampling, islands);
//! - [`pipeline`]: `generate`, `ingest`, `bake`, `sample_episodes`, `run`;
//! - [`split`] and [`variants`]: `split` and `variants` of a DATA folder;
//! - [`convert`]: the shared translations (errors, points, presets, sensors, progress).

use pyo3::prelude::*;

mod convert;
mod env;
mod episodes;
mod pathfinder;
mod pipeline;
mod sim;
mod split;
mod variants;
mod verify;

pyo3::create_exception!(
    _minos,
    MinosError,
    pyo3::exceptions::PyException,
    "An error of minos: the same one-line message the command line prints."
);
pyo3::create_exception!(
    _minos,
    BadInputError,
    MinosError,
    "A file minos reads is not valid (a scene, a table, a grid, a setting), or a value given is not."
);
pyo3::create_exception!(
    _minos,
    BodyMismatchError,
    MinosError,
    "The navigation grid was baked for another agent body than the one asked for."
);
pyo3::create_exception!(
    _minos,
    LockedError,
    MinosError,
    "Another process writes the folder (its lock names the holder)."
);
pyo3::create_exception!(
    _minos,
    NotFoundError,
    MinosError,
    "A file or folder minos needs does not exist."
);
pyo3::create_exception!(
    _minos,
    NotReadyError,
    MinosError,
    "Scenes are not ingested or not baked yet for what was asked."
);

/// Logging to stderr as the CLI does: `RUST_LOG` wins, else warnings of minos; no ANSI
/// colours unless stderr is a terminal. Only the first call installs it.
fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("minos=warn,warn"));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_target(false)
        .try_init();
}

/// The extension module.
#[pymodule]
fn _minos(m: &Bound<'_, PyModule>) -> PyResult<()> {
    init_logging();
    m.add("MinosError", m.py().get_type::<MinosError>())?;
    m.add("BadInputError", m.py().get_type::<BadInputError>())?;
    m.add("BodyMismatchError", m.py().get_type::<BodyMismatchError>())?;
    m.add("LockedError", m.py().get_type::<LockedError>())?;
    m.add("NotFoundError", m.py().get_type::<NotFoundError>())?;
    m.add("NotReadyError", m.py().get_type::<NotReadyError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<sim::Simulator>()?;
    m.add_class::<episodes::PyEpisode>()?;
    m.add_class::<pathfinder::PathFinder>()?;
    m.add_class::<env::VecCore>()?;
    m.add_function(wrap_pyfunction!(episodes::read_episodes, m)?)?;
    m.add_function(wrap_pyfunction!(episodes::import_episodes, m)?)?;
    m.add_function(wrap_pyfunction!(pipeline::generate, m)?)?;
    m.add_function(wrap_pyfunction!(pipeline::ingest, m)?)?;
    m.add_function(wrap_pyfunction!(split::split, m)?)?;
    m.add_function(wrap_pyfunction!(variants::variants, m)?)?;
    m.add_function(wrap_pyfunction!(pipeline::bake, m)?)?;
    m.add_function(wrap_pyfunction!(pipeline::sample_episodes, m)?)?;
    m.add_function(wrap_pyfunction!(pipeline::run, m)?)?;
    m.add_function(wrap_pyfunction!(verify::verify, m)?)?;
    m.add_function(wrap_pyfunction!(verify::diff, m)?)?;
    Ok(())
}
