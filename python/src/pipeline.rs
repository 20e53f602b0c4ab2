//! The pipeline for scripts: `generate`, `ingest`, `bake`, `sample_episodes` and `run`, with
//! the CLI's options (same names, Python types), calling the library functions the CLI calls
//! and raising `MinosError` with the CLI's one-line message when the command as a whole fails.
//! Per-scene or per-episode problems are returned in the report, as the CLI prints them and
//! goes on. `progress` takes a tqdm bar (`update`, `total`) or a callable `f(done, total)`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context as _};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use minos::body::{AgentPreset, BodyRule};
use minos::episode::habitat::SceneIdStyle;
use minos::episode::sample::{SampleConfig, Select};
use minos::episode::vln::export::{EpisodeExport, VlnFormat};
use minos::episode::Task;
use minos::generate::{GenerateConfig, HouseFormat};
use minos::io::image_codec::ImageEncoding;
use minos::io::lerobot::video::VideoSettings;
use minos::io::lerobot::video::MAX_QP;
use minos::lock::LockMode;
use minos::navmesh::NavParams;
use minos::pipeline::bake::{
    self as bake_driver, grid_params, BakeConfig, BakeOutcome, GridParamsError,
};
use minos::pipeline::episodes::{
    check_options, default_min_geodesic, default_min_rooms, default_same_level,
    default_success_radius, expand_categories, parse_room_classes, run_job, select_scenes,
    EpisodeOptionsError, EpisodesJob, Stratify,
};
use minos::pipeline::ingest::{ingest_with, read_id_list, DatasetFormat, IngestConfig, Outcome};
use minos::pipeline::rollout::{
    run_episodes_of, AgentKind, Provenance, RerunOutput, RunConfig, RunEpisodesError, RunFormat,
};
use minos::pipeline::split::{scenes_of, ScenesError};
use minos::run::metrics::Reward;
use minos::shard::Shard;
use minos::sim::AgentConfig;
use minos::split::Subset;
use minos::store::DataDir;
use minos::vocab::Vocabulary;

use crate::convert::{
    bad_input, msg_err, path_of, py_err, sensor_suite, term, with_threads, PyProgress,
};

fn to_py<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    let json = py.import("json")?;
    json.call_method1("loads", (v.to_string(),))
}

/// The scenes of split `name` (all subsets, sorted, distinct), or every ingested scene; a
/// split that cannot be read is blamed on the `split=` keyword.
fn split_or_all(data: &DataDir, split: Option<&str>) -> anyhow::Result<Vec<String>> {
    scenes_of(data, split).map_err(|e| match e {
        // The flag (or keyword) in place of the library's "split `NAME`".
        ScenesError::Split { name, source } => {
            anyhow::Error::new(source).context(format!("split={name:?}"))
        }
        other => other.into(),
    })
}

/// `minos generate`: procedural houses in SUNCG's (or Matterport3D's) layout into `out`;
/// `format="mp3d-scan"` writes scan-like Matterport3D houses (`--scan`, about
/// `scan_triangles` triangles each); `furnishing="dense"` furnishes rooms as densely as real
/// SUNCG and 3D-FRONT rooms. Returns `{"written": [ids], "skipped": [ids]}`.
#[pyfunction]
#[pyo3(signature = (out, houses = 10, seed = 0, rooms = (3, 8), levels = (1, 2), closed_doors = 0.25, furnishing = "standard", format = "suncg", force = false, scan_triangles = minos::generate::scan::DEFAULT_TRIANGLES, progress = None))]
#[allow(clippy::too_many_arguments)]
pub fn generate<'py>(
    py: Python<'py>,
    out: &Bound<'py, PyAny>,
    houses: usize,
    seed: u64,
    rooms: (usize, usize),
    levels: (usize, usize),
    closed_doors: f64,
    furnishing: &str,
    format: &str,
    force: bool,
    scan_triangles: u64,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let out = path_of(out)?;
    let format = term::<HouseFormat>("format", format)?.output(minos::generate::ScanOptions {
        triangles: scan_triangles,
        ..Default::default()
    });
    let cfg = GenerateConfig {
        houses,
        seed,
        rooms,
        levels,
        closed_door_prob: closed_doors,
        furnishing: term::<minos::generate::Furnishing>("furnishing", furnishing)?,
    };
    let bar = PyProgress::new(progress, houses as u64);
    let report = py
        .detach(|| {
            minos::generate::generate(&cfg, format, &out, force, &bar)
                .with_context(|| format!("generating into {}", out.display()))
        })
        .map_err(py_err)?;
    let d = PyDict::new(py);
    d.set_item("written", report.written)?;
    d.set_item("skipped", report.skipped)?;
    Ok(d)
}

/// `minos ingest`: compiles the scenes of a dataset root into the DATA folder `data`.
/// `ids` is a file of ids (as `--ids`) or a list of ids. Returns the scenes with their outcome
/// (`compiled`, `up_to_date`, `failed`) and error, missing ids, warnings and the manifest.
#[pyfunction]
#[pyo3(signature = (root, data, dataset = "suncg", ids = None, jobs = None, categories = None, models = None, force = false, wait = false, progress = None))]
#[allow(clippy::too_many_arguments)]
pub fn ingest<'py>(
    py: Python<'py>,
    root: &Bound<'py, PyAny>,
    data: &Bound<'py, PyAny>,
    dataset: &str,
    ids: Option<&Bound<'py, PyAny>>,
    jobs: Option<usize>,
    categories: Option<&Bound<'py, PyAny>>,
    models: Option<&Bound<'py, PyAny>>,
    force: bool,
    wait: bool,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let root = path_of(root)?;
    let format: DatasetFormat = term("dataset", dataset)?;
    let ids = match ids.filter(|i| !i.is_none()) {
        None => None,
        Some(obj) => match obj.extract::<Vec<String>>() {
            Ok(list) if !obj.is_instance_of::<pyo3::types::PyString>() => Some(list),
            _ => Some(read_id_list(&path_of(obj)?).map_err(|e| py_err(e.into()))?),
        },
    };
    let opt_path = |o: Option<&Bound<'py, PyAny>>| -> PyResult<Option<PathBuf>> {
        o.filter(|o| !o.is_none()).map(path_of).transpose()
    };
    let cfg = IngestConfig {
        format,
        root: root.clone(),
        data: DataDir::new(path_of(data)?),
        ids,
        force,
        categories: opt_path(categories)?,
        models: opt_path(models)?,
    };
    let bar = PyProgress::new(progress, 0);
    let report = py
        .detach(|| {
            with_threads(jobs, || {
                ingest_with(&cfg, LockMode::waiting_if(wait), &bar)
                    .with_context(|| format!("ingesting {}", root.display()))
            })
            .map_err(|e| anyhow!("jobs=: {e}"))?
        })
        .map_err(py_err)?;
    for w in &report.warnings {
        tracing::warn!("{w}");
    }
    let d = PyDict::new(py);
    let scenes: Vec<Bound<'py, PyDict>> = report
        .scenes
        .iter()
        .map(|(row, o)| {
            let e = PyDict::new(py);
            e.set_item("id", &row.id)?;
            e.set_item("outcome", o.term_name())?;
            e.set_item("error", row.error.clone())?;
            Ok(e)
        })
        .collect::<PyResult<_>>()?;
    d.set_item("scenes", scenes)?;
    for t in Outcome::TERMS {
        d.set_item(t.name, report.count(t.value))?;
    }
    d.set_item("missing_ids", report.missing_ids.clone())?;
    d.set_item("warnings", report.warnings.clone())?;
    d.set_item("manifest", report.manifest.clone())?;
    Ok(d)
}

/// The grid parameters of `bake` (as the CLI's flags and `--config` file).
fn bake_params(
    preset_name: &str,
    cell_size: Option<f32>,
    config: Option<&Path>,
) -> anyhow::Result<NavParams> {
    let preset: AgentPreset = preset_name.parse().map_err(anyhow::Error::msg)?;
    grid_params(preset, cell_size, config).map_err(|e| match e {
        GridParamsError::CellSize(source) => anyhow::Error::new(source).context("cell_size="),
        other => anyhow::Error::new(other).context("config="),
    })
}

/// `minos bake`: navigation grids for the ingested scenes (of `split`, on `variant`).
/// Returns `{"baked": n, "up_to_date": n, "failed": {id: error}, "replaced_body": {id: body}}`
/// (grids this bake replaced that were baked for another body); a grid that cannot be
/// written raises MinosError.
#[pyfunction]
#[pyo3(signature = (data, split = None, preset = "habitat", cell_size = None, config = None, variant = None, force = false, previews = true, wait = false, threads = None, progress = None))]
#[allow(clippy::too_many_arguments)]
pub fn bake<'py>(
    py: Python<'py>,
    data: &Bound<'py, PyAny>,
    split: Option<&str>,
    preset: &str,
    cell_size: Option<f32>,
    config: Option<&Bound<'py, PyAny>>,
    variant: Option<&str>,
    force: bool,
    previews: bool,
    wait: bool,
    threads: Option<usize>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let data = DataDir::new(path_of(data)?);
    let config = config.filter(|c| !c.is_none()).map(path_of).transpose()?;
    let bar = PyProgress::new(progress, 0);
    let report = py
        .detach(|| -> anyhow::Result<_> {
            let ids = split_or_all(&data, split)?;
            let scenes = data
                .refs(&ids, variant)
                .with_context(|| format!("variant={:?}", variant.unwrap_or_default()))?;
            let cfg = BakeConfig {
                params: bake_params(preset, cell_size, config.as_deref())?,
                scenes,
                data: data.clone(),
                force,
                previews,
            };
            minos::progress::Progress::set_total(&bar, cfg.scenes.len() as u64);
            let report = with_threads(threads, || {
                bake_driver::bake(&cfg, Shard::ALL, LockMode::waiting_if(wait), &bar)
            })
            .map_err(anyhow::Error::msg)??;
            if let Some(e) = report.write_failure() {
                return Err(anyhow::Error::new(e.clone()));
            }
            Ok(report)
        })
        .map_err(py_err)?;
    let failed: BTreeMap<&str, String> = report.failures().collect();
    let baked = report
        .scenes
        .iter()
        .filter(|(_, o)| matches!(o, BakeOutcome::Baked { .. }))
        .count();
    let d = PyDict::new(py);
    d.set_item("baked", baked)?;
    d.set_item("up_to_date", report.scenes.len() - baked - failed.len())?;
    d.set_item("failed", failed)?;
    let replaced: BTreeMap<&str, String> = report
        .replaced_bodies()
        .map(|(id, body)| (id, body.to_string()))
        .collect();
    d.set_item("replaced_body", replaced)?;
    Ok(d)
}

/// `minos episodes`: samples `task` (`pointgoal`, `objectgoal`, `roomgoal`, `vln`) episodes
/// into the Parquet file `out` (statistics in `out.stats.json`, provenance in
/// `out.provenance.json`; with `export_habitat=DIR`, Habitat-Lab's layout too; VLN episodes
/// with `export_vlnce=DIR` or `export_r2r=DIR`). Options as the CLI's flags (`same_level`
/// defaults to True for ObjectGoal, as in Habitat's 2023 challenge, False otherwise;
/// `min_geodesic` and `min_rooms` to 4 m and 2 rooms for VLN, else 1 m and none;
/// `categories` takes presets and `["all"]`; `starts=FILE` takes each scene's starts from an
/// episode file, as `--starts`). Returns the statistics (total, means, rejected
/// draws, per scene) with `out`, `stats`, `provenance` and `warnings`.
// `max_steps = 500` is `episode::interchange::DEFAULT_MAX_STEPS` spelled as a literal, so
// that Python's signature shows it (tests/python_api.rs checks that the two agree).
#[pyfunction]
#[pyo3(signature = (data, task, out, split = None, subset = None, variant = None, preset = "habitat", allow_body_mismatch = false, per_scene = 10, seed = 0, min_island_radius = 1.5, success_radius = None, categories = vec!["door".to_string(), "arch".to_string()], min_instances = 1, instructions = 3, room_types = vec!["any".to_string()], select = "any", min_geodesic = None, max_geodesic = 30.0, ratio_rule = true, min_doors = 0, min_rooms = None, same_level = None, bins = (3.0, 6.0), stratify = "auto", max_steps = 500, shard = "0/1", export_habitat = None, export_vlnce = None, export_r2r = None, scene_prefix = "", scene_suffix = "", starts = None, threads = None, progress = None))]
#[allow(clippy::too_many_arguments)]
pub fn sample_episodes<'py>(
    py: Python<'py>,
    data: &Bound<'py, PyAny>,
    task: &str,
    out: &Bound<'py, PyAny>,
    split: Option<&str>,
    subset: Option<&str>,
    variant: Option<&str>,
    preset: &str,
    allow_body_mismatch: bool,
    per_scene: usize,
    seed: u64,
    min_island_radius: f32,
    success_radius: Option<f32>,
    categories: Vec<String>,
    min_instances: u32,
    instructions: usize,
    room_types: Vec<String>,
    select: &str,
    min_geodesic: Option<f32>,
    max_geodesic: f32,
    ratio_rule: bool,
    min_doors: u32,
    min_rooms: Option<u32>,
    same_level: Option<bool>,
    bins: (f32, f32),
    stratify: &str,
    max_steps: u32,
    shard: &str,
    export_habitat: Option<&Bound<'py, PyAny>>,
    export_vlnce: Option<&Bound<'py, PyAny>>,
    export_r2r: Option<&Bound<'py, PyAny>>,
    scene_prefix: &str,
    scene_suffix: &str,
    starts: Option<&Bound<'py, PyAny>>,
    threads: Option<usize>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let data = DataDir::new(path_of(data)?);
    let out = path_of(out)?;
    let starts = starts.map(path_of).transpose()?;
    let task: Task = term("task", task)?;
    let subset: Option<Subset> = subset.map(|s| term("subset", s)).transpose()?;
    let select: Select = term("select", select)?;
    let stratified = term::<Stratify>("stratify", stratify)?.applies(subset);
    let (categories, all_categories) = expand_categories(&categories)
        .ok_or_else(|| bad_input("categories: give [\"all\"] alone"))?;
    let room_classes =
        parse_room_classes(&room_types).map_err(|e| bad_input(format!("room_types: {e}")))?;
    let agent_preset = crate::convert::preset("preset", preset)?;
    let dir_of =
        |e: Option<&Bound<'py, PyAny>>| e.filter(|e| !e.is_none()).map(path_of).transpose();
    let habitat_export = dir_of(export_habitat)?;
    let vln_export = match (dir_of(export_vlnce)?, dir_of(export_r2r)?) {
        (Some(_), Some(_)) => return Err(bad_input("give export_vlnce or export_r2r, not both")),
        (Some(d), None) => Some((VlnFormat::VlnCe, d)),
        (None, Some(d)) => Some((VlnFormat::R2r, d)),
        (None, None) => None,
    };
    let exports = EpisodeExport::requested(
        habitat_export.is_some(),
        vln_export.as_ref().map(|(f, _)| *f),
    );
    let scene_names = SceneIdStyle {
        prefix: scene_prefix.to_string(),
        suffix: scene_suffix.to_string(),
    };
    scene_names
        .check()
        .map_err(|e| bad_input(format!("scene_suffix: {e}")))?;
    let sample = SampleConfig {
        task,
        per_scene,
        seed,
        min_island_radius,
        success_radius: success_radius
            .unwrap_or_else(|| default_success_radius(task, agent_preset)),
        categories,
        all_categories,
        min_instances,
        instructions,
        room_classes,
        select,
        min_geodesic: min_geodesic.unwrap_or_else(|| default_min_geodesic(task)),
        max_geodesic,
        ratio_rule,
        min_doors,
        min_rooms: min_rooms.unwrap_or_else(|| default_min_rooms(task)),
        same_level: same_level.unwrap_or_else(|| default_same_level(task)),
        bins: [bins.0, bins.1],
        stratified,
        max_steps,
        ..SampleConfig::default()
    };
    check_options(&sample, exports).map_err(|e| match e {
        EpisodeOptionsError::BinsOutOfOrder { .. } => bad_input(format!("bins: {e}, e.g. (3, 6)")),
        EpisodeOptionsError::VlnExportOfOtherTask { format, .. } => bad_input(format!(
            "export_{}: {e} (task=\"vln\")",
            EpisodeExport::Vln(format).term_name()
        )),
        EpisodeOptionsError::HabitatExportOfVln => bad_input(format!(
            "export_habitat: {e} (export_vlnce= or export_r2r=)"
        )),
        EpisodeOptionsError::MinInstancesOfOtherTask { .. } => {
            bad_input(format!("min_instances: {e}"))
        }
    })?;
    let shard: Shard = crate::convert::shard(shard)?;
    let bar = PyProgress::new(progress, 0);
    let outcome = py
        .detach(|| -> anyhow::Result<_> {
            let job = EpisodesJob {
                scenes: select_scenes(&data, split, subset, variant)?,
                data: data.clone(),
                sample,
                body_rule: BodyRule {
                    body: agent_preset.body(),
                    allow_mismatch: allow_body_mismatch,
                },
                shard,
                out: out.clone(),
                habitat_export,
                vln_export,
                scene_names,
                command: vec!["minos.sample_episodes".to_string()],
                starts,
            };
            Ok(with_threads(threads, || run_job(&job, &bar)).map_err(anyhow::Error::msg)??)
        })
        .map_err(py_err)?;
    for w in &outcome.warnings {
        tracing::warn!("{w}");
    }
    let stats = serde_json::to_value(&outcome.batch).map_err(msg_err)?;
    let d = to_py(py, &stats)?.cast_into::<PyDict>()?;
    d.set_item("out", out)?;
    d.set_item("stats", &outcome.stats_path)?;
    d.set_item("provenance", &outcome.provenance_path)?;
    d.set_item("warnings", &outcome.warnings)?;
    Ok(d)
}

/// `minos run`: rolls out the episodes of `episodes` (a file) with `agent` into `out`
/// (Parquet tables, metrics.json, manifest.json; LeRobot with `format="lerobot"`; a rerun
/// recording with `rerun=FILE`; colour cameras as H.264 video features with `video=True`, at
/// H.264 quantiser `video_qp` (0–51, as `--video-qp`);
/// `batch` environments per scene stepped in lockstep, as `--batch`). Returns `{"episodes": n, "resumed": n, "steps": n,
/// "seconds": s, "failures": [(id, error)], "groups": {group: aggregates}, "metrics": [per
/// episode]}`; a run that cannot start raises MinosError.
#[pyfunction]
#[pyo3(signature = (data, episodes, agent, out, variant = None, preset = "habitat", allow_body_mismatch = false, sensors = None, size = 84, max_steps = None, seed = 0, shard = "0/1", resume = false, reward = "dist_time", image_encoding = "raw", format = "parquet", video = false, video_qp = 26, renderer = "cpu", batch = None, rerun = None, rerun_episodes = 1, threads = None, wait = false, progress = None))]
#[allow(clippy::too_many_arguments)]
pub fn run<'py>(
    py: Python<'py>,
    data: &Bound<'py, PyAny>,
    episodes: &Bound<'py, PyAny>,
    agent: &str,
    out: &Bound<'py, PyAny>,
    variant: Option<&str>,
    preset: &str,
    allow_body_mismatch: bool,
    sensors: Option<&Bound<'py, PyAny>>,
    size: u32,
    max_steps: Option<u32>,
    seed: u64,
    shard: &str,
    resume: bool,
    reward: &str,
    image_encoding: &str,
    format: &str,
    video: bool,
    video_qp: u8,
    renderer: &str,
    batch: Option<usize>,
    rerun: Option<&Bound<'py, PyAny>>,
    rerun_episodes: usize,
    threads: Option<usize>,
    wait: bool,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let data = DataDir::new(path_of(data)?);
    let episodes_file = path_of(episodes)?;
    let out = path_of(out)?;
    let preset_value = crate::convert::preset("preset", preset)?;
    let sensors = sensor_suite(sensors, size, preset_value)?;
    let shard = crate::convert::shard(shard)?;
    let reward: Reward = term("reward", reward)?;
    let encoding: ImageEncoding = term("image_encoding", image_encoding)?;
    let lerobot = term::<RunFormat>("format", format)?.writes_lerobot();
    let renderer = crate::convert::renderer(renderer)?;
    let video_settings = match (video, VideoSettings::with_qp(video_qp)) {
        (true, Some(settings)) => Some(settings),
        (false, Some(settings)) if settings == VideoSettings::default() => None,
        (false, _) => {
            return Err(pyo3::exceptions::PyValueError::new_err(
                "video_qp: the quantiser of video features needs video=True",
            ))
        }
        (true, None) => {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "video_qp: {video_qp} is not an H.264 quantiser (0–{MAX_QP})"
            )))
        }
    };
    let rerun = rerun
        .filter(|r| !r.is_none())
        .map(path_of)
        .transpose()?
        .map(|path| RerunOutput {
            path,
            episodes: rerun_episodes,
        });
    let command: Vec<String> = py
        .import("sys")?
        .getattr("argv")?
        .extract()
        .unwrap_or_default();
    let bar = PyProgress::new(progress, 0);
    let start = std::time::Instant::now();
    let report = py
        .detach(|| -> anyhow::Result<_> {
            let kind = AgentKind::from_name(agent).context("agent")?;
            let eps = run_episodes_of(&data, &episodes_file, variant, &kind, agent, shard)
                .map_err(|e| match e {
                    RunEpisodesError::Variant(_) => anyhow::Error::new(e)
                        .context(format!("variant={:?}", variant.unwrap_or_default())),
                    RunEpisodesError::Agent(_) => anyhow::Error::new(e).context("agent"),
                    e => e.into(),
                })?;
            let cfg = RunConfig {
                batch,
                data: data.clone(),
                out: out.clone(),
                agent: kind,
                agent_config: AgentConfig::preset(preset_value),
                sensors,
                renderer,
                max_steps,
                seed,
                shard,
                resume,
                reward,
                encoding,
                lerobot,
                lerobot_video: video_settings,
                rerun,
                allow_body_mismatch,
                provenance: Provenance {
                    command,
                    episodes_file: Some(episodes_file.clone()),
                    variant: variant.map(String::from),
                    agent: agent.to_string(),
                    preset: Some(preset_value),
                },
            };
            minos::progress::Progress::set_total(&bar, eps.len() as u64);
            let r = with_threads(threads, || {
                minos::pipeline::rollout::rollout_with(&cfg, &eps, LockMode::waiting_if(wait), &bar)
            })
            .map_err(anyhow::Error::msg)??;
            Ok(r)
        })
        .map_err(py_err)?;
    let seconds = start.elapsed().as_secs_f64();
    let steps: u64 = report
        .episodes
        .iter()
        .map(|(_, m)| u64::from(m.steps))
        .sum();
    let d = PyDict::new(py);
    d.set_item("episodes", report.episodes.len())?;
    d.set_item("resumed", report.resumed)?;
    d.set_item("steps", steps)?;
    d.set_item("seconds", seconds)?;
    let failures: Vec<(&str, String)> = report
        .failures
        .iter()
        .map(|(id, e)| (id.as_str(), minos::escape::error_line(e)))
        .collect();
    d.set_item("failures", failures)?;
    d.set_item("recorded", report.recorded)?;
    let groups = serde_json::to_value(&report.groups).map_err(msg_err)?;
    d.set_item("groups", to_py(py, &groups)?)?;
    let per: Vec<serde_json::Value> = report
        .episodes
        .iter()
        .map(|(e, m)| {
            let mut v = serde_json::to_value(m).unwrap_or_default();
            if let Some(o) = v.as_object_mut() {
                o.insert("episode_id".into(), e.episode_id.clone().into());
            }
            v
        })
        .collect();
    d.set_item("metrics", to_py(py, &serde_json::Value::Array(per))?)?;
    Ok(d)
}
