//! `minos.variants`: keyword arguments → [`VariantsJob`] → [`define_variants`] → a dict.

use pyo3::prelude::*;
use pyo3::types::PyDict;

use minos::lock::LockMode;
use minos::pipeline::variants::{define_variants, read_spec_file, VariantsError, VariantsJob};
use minos::scene::variants::{KeepOnly, Retexture, TextureSet, VariantSpec};
use minos::store::DataDir;

use crate::convert::{bad_input, path_of, py_err, term, typed_err, PyProgress};

/// `minos variants`: defines scene variants in the DATA folder `data`, from `spec` (a TOML
/// file of named tables, the CLI's `--spec`) or as the one variant `name` with these changes:
/// `remove` / `hide` (categories removed), `keep_only` (categories kept besides architecture;
/// `["arch"]` keeps architecture alone), `empty` (MINOS's emptyRoom: doors, arches and windows
/// kept), `open_doors`, `retexture_seed` (redraw every material slot from `texture_set`'s
/// materials: `"train"`, `"val"` or `"test"`). The material statistics retexturing needs are
/// computed on first use (or with `refresh_stats`, partitioned with `partition_seed`).
/// Scenes load a variant as `<scene>@<name>`; bake a variant that changes geometry with
/// `minos.bake(data, variant=name)`. Returns `{"variants": {name: {"path", "scenes",
/// "removed", "doors_swapped", "doors_cleared", "slots_redrawn", "slots_kept",
/// "changes_geometry", "failed": {scene: error}, "unmatched": [[scene, entry]]}},
/// "stats": {"path", "scenes", "materials", "categories", "per_set", "left_out"} or None}`.
#[pyfunction]
#[pyo3(signature = (data, name = None, spec = None, remove = vec![], keep_only = vec![], empty = false, hide = vec![], open_doors = false, retexture_seed = None, texture_set = "train", refresh_stats = false, partition_seed = 0, wait = false, progress = None))]
#[allow(clippy::too_many_arguments)]
pub fn variants<'py>(
    py: Python<'py>,
    data: &Bound<'py, PyAny>,
    name: Option<String>,
    spec: Option<&Bound<'py, PyAny>>,
    remove: Vec<String>,
    keep_only: Vec<String>,
    empty: bool,
    hide: Vec<String>,
    open_doors: bool,
    retexture_seed: Option<u64>,
    texture_set: &str,
    refresh_stats: bool,
    partition_seed: u64,
    wait: bool,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let texture_set: TextureSet = term("texture_set", texture_set)?;
    let spec = spec.filter(|s| !s.is_none());
    let from_kwargs = spec.is_none();
    let variants = match (spec, name) {
        (Some(file), None) => read_spec_file(&path_of(file)?)
            .map_err(|e| py_err(anyhow::Error::new(e).context("spec")))?,
        (None, Some(name)) => {
            let rules = VariantSpec {
                remove,
                keep_only: KeepOnly::from_names(keep_only),
                empty,
                hide,
                open_doors,
                doors: Default::default(),
                retexture: retexture_seed.map(|seed| Retexture { seed, texture_set }),
            };
            vec![(name, rules)]
        }
        _ => return Err(bad_input("give exactly one of spec=FILE and name=NAME")),
    };
    let job = VariantsJob {
        data: DataDir::new(path_of(data)?),
        variants,
        refresh_stats,
        partition_seed,
    };
    let mode = LockMode::waiting_if(wait);
    let bar = PyProgress::new(progress, 0);
    let report = py
        .detach(|| define_variants(&job, mode, &bar))
        .map_err(|e| match e {
            VariantsError::NoChange { .. } if from_kwargs => bad_input(format!(
                "{} (pass remove=, keep_only=, empty=True, hide=, open_doors=True or \
                 retexture_seed=)",
                minos::escape::error_line(&e)
            )),
            e => typed_err(e),
        })?;
    let out = PyDict::new(py);
    let by_name = PyDict::new(py);
    for v in &report.variants {
        let d = PyDict::new(py);
        d.set_item("path", &v.path)?;
        d.set_item("scenes", v.scenes)?;
        d.set_item("removed", v.removed)?;
        d.set_item("doors_swapped", v.swapped)?;
        d.set_item("doors_cleared", v.cleared)?;
        d.set_item("slots_redrawn", v.redrawn)?;
        d.set_item("slots_kept", v.kept)?;
        d.set_item("changes_geometry", v.changes_geometry)?;
        let failed = PyDict::new(py);
        for (id, e) in &v.failures {
            failed.set_item(id, e)?;
        }
        d.set_item("failed", failed)?;
        d.set_item("unmatched", &v.unmatched)?;
        by_name.set_item(&v.name, d)?;
    }
    out.set_item("variants", by_name)?;
    match &report.stats {
        None => out.set_item("stats", py.None())?,
        Some(s) => {
            let d = PyDict::new(py);
            d.set_item("path", &s.path)?;
            d.set_item("scenes", s.scenes)?;
            d.set_item("materials", s.materials)?;
            d.set_item("categories", s.categories)?;
            let per_set = PyDict::new(py);
            for (set, n) in TextureSet::ALL.iter().zip(s.per_set) {
                per_set.set_item(set.name(), n)?;
            }
            d.set_item("per_set", per_set)?;
            d.set_item("left_out", &s.left_out)?;
            out.set_item("stats", d)?;
        }
    }
    Ok(out)
}
