//! `verify` and `diff` for scripts: the library's checks of an output and comparison of two,
//! with the problems and differences as the CLI prints them (one line each).

use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{path_of, py_err, PyProgress};

/// `minos verify PATH`: checks a run folder, LeRobot dataset, episode file (with `data`, the
/// DATA folder its scenes were baked in) or DATA folder. Returns `{"kind", "clean",
/// "problems": [line, …], "summary", "files", "bytes"}`; raises `MinosError` only when the
/// path is no output minos knows.
#[pyfunction]
#[pyo3(signature = (path, data = None, progress = None))]
pub fn verify<'py>(
    py: Python<'py>,
    path: &Bound<'py, PyAny>,
    data: Option<&Bound<'py, PyAny>>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let path = path_of(path)?;
    let options = minos::verify::VerifyOptions {
        data: data.filter(|d| !d.is_none()).map(path_of).transpose()?,
    };
    let bar = PyProgress::new(progress, 0);
    let report = py
        .detach(|| minos::verify::verify(&path, &options, &bar))
        .map_err(|e| py_err(e.into()))?;
    let d = PyDict::new(py);
    d.set_item("kind", report.kind.name())?;
    d.set_item("clean", report.is_clean())?;
    let lines: Vec<String> = report.problems.iter().map(|p| p.to_string()).collect();
    d.set_item("problems", lines)?;
    d.set_item("summary", report.summary())?;
    d.set_item("files", report.files)?;
    d.set_item("bytes", report.bytes)?;
    Ok(d)
}

/// `minos diff A B`: `{"identical", "differences": [line, …], "summary"}`.
#[pyfunction]
pub fn diff<'py>(
    py: Python<'py>,
    a: &Bound<'py, PyAny>,
    b: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    let (a, b) = (path_of(a)?, path_of(b)?);
    let report = py
        .detach(|| minos::diff::diff(&a, &b))
        .map_err(|e| py_err(e.into()))?;
    let d = PyDict::new(py);
    d.set_item("identical", report.identical())?;
    let lines: Vec<String> = report.differences.iter().map(|x| x.to_string()).collect();
    d.set_item("differences", lines)?;
    d.set_item("summary", report.summary())?;
    Ok(d)
}
