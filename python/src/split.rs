//! `minos.split`: keyword arguments → [`SplitJob`] → [`make_split`] → a dict.

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

use minos::lock::LockMode;
use minos::pipeline::split::{make_split, Method, SplitJob, SplitJobError};
use minos::split::{Expr, Ratios, SplitLists, Subset};
use minos::store::DataDir;
use minos::vocab::Vocabulary;

use crate::convert::{bad_input, path_of, py_err, typed_err};

/// The lists `lists=` gives: a dict of id lists by subset (`train`, `val`, `test`; a subset
/// left out is empty), or a folder of `train.txt`, `val.txt` and `test.txt` (or built-in
/// lists: `"mp3d"`, `"suncg-multiroom"`).
fn method_of(lists: &Bound<'_, PyAny>) -> PyResult<Method> {
    let Ok(dict) = lists.cast::<PyDict>() else {
        return Ok(Method::ListsFrom(path_of(lists)?));
    };
    let mut given = SplitLists::default();
    for (key, ids) in dict.iter() {
        let key: String = key.extract()?;
        let subset: Subset = crate::convert::term("lists", &key)?;
        if ids.is_instance_of::<PyString>() {
            return Err(bad_input(format!(
                "lists[{key:?}]: a list of scene ids, not a string"
            )));
        }
        let ids: Vec<String> = ids.extract()?;
        match subset {
            Subset::Train => given.train = ids,
            Subset::Val => given.val = ids,
            Subset::Test => given.test = ids,
        }
    }
    Ok(Method::Lists(given))
}

/// `minos split`: writes split `name` of the DATA folder, `data/splits/<name>/{train,val,test}.txt`,
/// from `lists` (a dict `{"train": [ids], "val": [...], "test": [...]}`, a folder of the three
/// files, or `"mp3d"` / `"suncg-multiroom"`, MINOS's official lists) or from `ratios`
/// (`(train, val, test)` summing to 1, each id placed by its own hash under `seed`); `where`
/// keeps the scenes an expression is true for (`'nrooms > 2 && has_room("kitchen")'`, the
/// CLI's `--where`). Scenes that failed to ingest never enter a split. Returns
/// `{"train": [ids], "val": [...], "test": [...], "filtered_out": n, "failed": n,
/// "unlisted": n, "missing": [ids], "dir": path}` (`unlisted`: scenes in no list;
/// `missing`: listed ids not in DATA).
#[pyfunction]
#[pyo3(signature = (data, name, lists = None, ratios = None, seed = 0, r#where = None, wait = false))]
#[allow(clippy::too_many_arguments)]
pub fn split<'py>(
    py: Python<'py>,
    data: &Bound<'py, PyAny>,
    name: &str,
    lists: Option<&Bound<'py, PyAny>>,
    ratios: Option<(f64, f64, f64)>,
    seed: u64,
    r#where: Option<&str>,
    wait: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let method = match (lists.filter(|l| !l.is_none()), ratios) {
        (Some(lists), None) => method_of(lists)?,
        (None, Some((a, b, c))) => {
            let ratios = Ratios::new([a, b, c]).map_err(typed_err)?;
            Method::Ratios(ratios, seed)
        }
        _ => return Err(bad_input("give exactly one of lists= and ratios=")),
    };
    let filter = r#where
        .map(Expr::parse)
        .transpose()
        .map_err(|e| py_err(anyhow::Error::new(e).context("where")))?;
    let job = SplitJob {
        data: DataDir::new(path_of(data)?),
        name: name.to_string(),
        filter,
        method,
    };
    let mode = LockMode::waiting_if(wait);
    let report = py.detach(|| make_split(&job, mode)).map_err(|e| match e {
        SplitJobError::Name(_) => py_err(anyhow::Error::new(e).context("name")),
        // The keyword in place of the library's "lists DIR".
        SplitJobError::Lists { given, source } => py_err(
            anyhow::Error::new(source).context(format!("lists={:?}", given.display().to_string())),
        ),
        SplitJobError::GivenLists(source) => py_err(anyhow::Error::new(source).context("lists")),
        other => typed_err(other),
    })?;
    let d = PyDict::new(py);
    for s in Subset::ALL {
        d.set_item(s.term_name(), report.result.lists.get(s))?;
    }
    d.set_item("filtered_out", report.result.filtered_out)?;
    d.set_item("failed", report.result.failed)?;
    d.set_item("unlisted", report.result.unlisted)?;
    d.set_item("missing", &report.result.missing)?;
    d.set_item("dir", report.dir)?;
    Ok(d)
}
