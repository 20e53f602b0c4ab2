//! `minos render`'s job: what an agent's sensors see at one pose of a scene, one PNG per
//! camera. Without a pose the agent stands where the view is most open
//! ([`most_open_pose`]), so a first look at a scene never faces a wall.

use crate::file_error::FileError;
use std::path::PathBuf;
use std::sync::Arc;

use glam::Vec3;

use crate::navmesh::NavGrid;
use crate::render::gpu::GpuError;
use crate::render::visualize::write_png;
use crate::render::{Image, Modality, Renderer, RendererChoice};
use crate::scene::SceneRef;
use crate::sim::SimError;
use crate::sim::{AgentConfig, SceneAssets, SensorSuite, Simulator};
use crate::store::{DataDir, StoreError};

/// What to render.
#[derive(Debug, Clone)]
pub struct RenderJob {
    /// The DATA folder (ingested and baked).
    pub data: DataDir,
    /// The scene (or variant).
    pub scene: SceneRef,
    /// The agent (body, eye height).
    pub agent: AgentConfig,
    /// Accept a grid baked for another body.
    pub allow_body_mismatch: bool,
    /// Position (x, floor y, z) and yaw; `None`: [`most_open_pose`].
    pub pose: Option<[f32; 4]>,
    /// Tilt (radians, positive up).
    pub tilt: f32,
    /// Renderer.
    pub renderer: RendererChoice,
    /// Sensors (at least one camera).
    pub sensors: SensorSuite,
    /// Output folder: `<camera name>.png` per camera.
    pub out: PathBuf,
}

/// What was rendered.
#[derive(Debug, Clone)]
pub struct RenderReport {
    /// The images written, in the sensors' order.
    pub images: Vec<PathBuf>,
    /// The renderer's name.
    pub renderer: String,
    /// The pose rendered (x, floor y, z, yaw): the job's or the one chosen.
    pub pose: [f32; 4],
}

/// Why nothing (or not everything) was rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The scene, its variant or its grid could not be read.
    #[error("scene {scene}")]
    Store {
        /// The scene.
        scene: SceneRef,
        /// The cause.
        #[source]
        source: StoreError,
    },
    /// The scene cannot carry the agent (its grid was baked for another body, …).
    #[error("scene {scene}")]
    Sim {
        /// The scene.
        scene: SceneRef,
        /// The cause.
        #[source]
        source: SimError,
    },
    /// The renderer failed.
    #[error(transparent)]
    Render(#[from] GpuError),
    /// The scene's grid has no walkable place to stand (only when no pose was given).
    #[error("scene {0}: its grid has no walkable place to stand; give a pose")]
    NowhereToStand(SceneRef),
    /// An image could not be written.
    #[error("{0}")]
    Write(#[source] FileError),
}

/// Renders `job`: one PNG per camera in `job.out`.
pub fn render_views(job: &RenderJob) -> Result<RenderReport, RenderError> {
    let store = |source| RenderError::Store {
        scene: job.scene.clone(),
        source,
    };
    let (scene, _) = job.data.load_scene(&job.scene).map_err(store)?;
    let grid = job.data.read_grid(&job.scene).map_err(store)?;
    let assets = if job.allow_body_mismatch {
        SceneAssets::new_allowing_body_mismatch(&scene, grid, &job.agent)
    } else {
        SceneAssets::new(&scene, grid, &job.agent)
    }
    .map_err(|source| RenderError::Sim {
        scene: job.scene.clone(),
        source,
    })?;
    let assets = Arc::new(assets);
    let renderer = Arc::new(Renderer::new(job.renderer, &assets.render)?);
    let pose = match job.pose {
        Some(p) => p,
        None => most_open_pose(&assets, &renderer, &job.agent)?
            .ok_or_else(|| RenderError::NowhereToStand(job.scene.clone()))?,
    };
    let sensors = job.sensors.clone();
    let mut sim = Simulator::new(assets, renderer.clone(), job.agent, sensors.clone(), 1, 0);
    let [x, y, z, yaw] = pose;
    sim.reset(Vec3::new(x, y, z), yaw, None, "render");
    sim.set_tilt(job.tilt);
    let obs = sim.observe()?;
    let mut images = Vec::new();
    for ((name, image), sensor) in obs.images.iter().zip(&sensors.cameras) {
        let path = job.out.join(format!("{name}.png"));
        let [w, h] = sensor.resolution;
        write_png(&path, sensor.modality, image, w, h)
            .map_err(|source| RenderError::Write(FileError::new(&path, source)))?;
        images.push(path);
    }
    Ok(RenderReport {
        images,
        renderer: renderer.name().to_string(),
        pose,
    })
}

/// Places tried by [`most_open_pose`]: the walkable spans farthest from any edge.
const CANDIDATE_PLACES: usize = 24;
/// Headings tried at each place.
const CANDIDATE_YAWS: usize = 8;
/// Side of the depth image each candidate view is judged by.
const PROBE_SIZE: u32 = 32;

/// The pose (x, floor y, z, yaw) with the most open view: among the 24
/// walkable spans of largest clearance (inside rooms when there are rooms; ties by span
/// index), at 8 headings each, the one whose depth image (at the agent's eye,
/// 90° field of view) has the largest median depth, pixels that see nothing counting as 0 —
/// deterministic for a scene and agent. `None` when nothing is walkable.
pub fn most_open_pose(
    assets: &Arc<SceneAssets>,
    renderer: &Arc<Renderer>,
    agent: &AgentConfig,
) -> Result<Option<[f32; 4]>, GpuError> {
    let grid: &NavGrid = &assets.grid;
    // Inside rooms when the scene has any (not on a balcony's edge or the ground outside).
    let in_room = |i: usize| grid.spans[i].room != crate::navmesh::NONE;
    let any_room = (0..grid.spans.len()).any(|i| grid.spans[i].walkable && in_room(i));
    let mut places: Vec<usize> = (0..grid.spans.len())
        .filter(|&i| grid.spans[i].walkable && (!any_room || in_room(i)))
        .collect();
    places.sort_by(|&a, &b| {
        grid.spans[b]
            .clearance
            .total_cmp(&grid.spans[a].clearance)
            .then(a.cmp(&b))
    });
    places.truncate(CANDIDATE_PLACES);
    let mut probe = SensorSuite::minos(PROBE_SIZE);
    probe.cameras.retain(|c| c.modality == Modality::Depth);
    probe.contact = None;
    for c in &mut probe.cameras {
        c.vfov = 90.0;
    }
    let mut sim = Simulator::new(assets.clone(), renderer.clone(), *agent, probe, 1, 0);
    let mut best: Option<(f32, [f32; 4])> = None;
    for span in places {
        let p = grid.span_position(span);
        for k in 0..CANDIDATE_YAWS {
            let yaw = k as f32 * std::f32::consts::TAU / CANDIDATE_YAWS as f32;
            sim.reset(p, yaw, None, "render");
            let obs = sim.observe()?;
            let Some((_, Image::F32 { data, .. })) = obs.images.first() else {
                continue;
            };
            let score = median(data);
            if best.is_none_or(|(b, _)| score > b) {
                best = Some((score, [p.x, p.y, p.z, yaw]));
            }
        }
    }
    Ok(best.map(|(_, pose)| pose))
}

/// The median of a depth image's values, a pixel that hit nothing (depth 0: a view out of
/// the scene, into the void) counting as 0: what a view's typical distance to the scene is.
fn median(values: &[f32]) -> f32 {
    let mut v: Vec<f32> = values.iter().copied().filter(|x| !x.is_nan()).collect();
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f32::total_cmp);
    *m
}
