//! `bench render`'s batched GPU stages: the scene's views rendered in batches of
//! [`BenchConfig::batch`] views with one submission and one read-back each, as batched
//! stepping renders, then the same with colour, linear depth and semantic images derived from
//! the frames on all threads, and with those images derived on the GPU (its second compute
//! pass) and read back finished. All are timed by the wall clock, which — unlike this
//! thread's CPU time — includes waiting for the GPU.

use std::hint::black_box;
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use super::{BenchConfig, BenchError, Stage};
use crate::render::gpu::{GpuRenderer, SceneSlot, View};
use crate::render::{Channel, Channels, RenderScene};
use crate::scene::Taxonomy;
use crate::sim::Simulator;

/// Name of the stage that renders batches (triangle ids and depth, read back).
pub const GPU_BATCH: &str = "gpu batch: ids + depth";
/// Name of the stage that renders batches and derives the images on all threads.
pub const GPU_IMAGES: &str = "gpu batch + colour, depth, semantic (all threads)";
/// Name of the stage that renders batches with the images derived on the GPU.
pub const GPU_DERIVED: &str = "gpu batch + colour, depth, semantic derived on the GPU";

/// Batches are repeated for at least this long (seconds), after one batch to warm up.
const MIN_SECONDS: f64 = 1.0;

/// The batched stages on `gpu` (whose slot 0 is `scene`, the simulator's scene): each pose's
/// distinct cameras (those of the first camera's resolution), poses in turn until a batch is
/// full.
pub(super) fn batches(
    cfg: &BenchConfig,
    sim: &mut Simulator,
    poses: &[(Vec3, f32)],
    gpu: &GpuRenderer,
    scene: &RenderScene,
) -> Result<Vec<Stage>, BenchError> {
    let views = batch_views(sim, poses, cfg.batch)?;
    // Both on all threads: frames are copied out of the read-back buffer in parallel.
    let pool = super::thread_pool(cfg.threads)?;
    let ids = pool.install(|| {
        repeat(views.len(), || {
            gpu.render_views(&views).map(drop).map_err(BenchError::from)
        })
    })?;
    let images = pool.install(|| {
        repeat(views.len(), || {
            let frames = gpu.render_views(&views)?;
            frames.par_iter().zip(&views).for_each(|(f, v)| {
                black_box(f.color(scene, &v.camera));
                black_box(f.linear_depth(&v.camera));
                black_box(f.semantic(scene, Taxonomy::Nyu40));
            });
            Ok(())
        })
    })?;
    // The same images, derived by the GPU's second pass and read back with the frames (the
    // frames' methods hand them out; a view whose rays overflowed is derived here).
    let channels = Channels::NONE
        .with(Channel::Color)
        .with(Channel::Depth)
        .with(Channel::Semantic(Taxonomy::Nyu40));
    let mut stages = vec![stage(GPU_BATCH, ids), stage(GPU_IMAGES, images)];
    if gpu.method() != crate::render::gpu::GpuMethod::RayTrace {
        return Ok(stages);
    }
    let derived = pool.install(|| {
        repeat(views.len(), || {
            let frames = gpu.render_views_with(&views, channels)?;
            frames.par_iter().zip(&views).for_each(|(f, v)| {
                black_box(f.color(scene, &v.camera));
                black_box(f.linear_depth(&v.camera));
                black_box(f.semantic(scene, Taxonomy::Nyu40));
            });
            Ok(())
        })
    })?;
    stages.push(stage(GPU_DERIVED, derived));
    Ok(stages)
}

/// A wall-clock stage of `(frames, seconds)`.
fn stage(name: &'static str, (count, seconds): (u64, f64)) -> Stage {
    Stage {
        name,
        count,
        unit: "frames",
        seconds,
        wall: true,
    }
}

/// Runs `batch` once to warm up, then again until [`MIN_SECONDS`] have passed (at least
/// twice): the frames rendered (`views` per batch) and the wall-clock seconds.
fn repeat(
    views: usize,
    mut batch: impl FnMut() -> Result<(), BenchError>,
) -> Result<(u64, f64), BenchError> {
    batch()?;
    let start = Instant::now();
    let mut runs = 0u64;
    while runs < 2 || start.elapsed().as_secs_f64() < MIN_SECONDS {
        batch()?;
        runs += 1;
    }
    Ok((runs * views as u64, start.elapsed().as_secs_f64()))
}

/// `size` views of scene slot 0: the distinct cameras of each pose in turn (those of the
/// first camera's resolution, as a batch has one resolution).
fn batch_views(
    sim: &mut Simulator,
    poses: &[(Vec3, f32)],
    size: usize,
) -> Result<Vec<View>, BenchError> {
    let mut views: Vec<View> = Vec::with_capacity(size);
    let mut resolution = None;
    for (p, yaw) in poses.iter().cycle() {
        sim.reset(*p, *yaw, None, "bench");
        // The cameras an observation renders (sensors sharing an eye share one).
        let mut cameras = sim.views().unique;
        let r = *resolution.get_or_insert_with(|| cameras.first().map(|c| (c.width, c.height)));
        cameras.retain(|c| Some((c.width, c.height)) == r);
        if cameras.is_empty() {
            return Err(BenchError::GpuBatch("the sensors have no camera to render"));
        }
        for camera in cameras {
            if views.len() == size {
                return Ok(views);
            }
            views.push(View {
                scene: SceneSlot(0),
                camera,
            });
        }
        if views.len() == size {
            return Ok(views);
        }
    }
    Err(BenchError::GpuBatch("no pose to render from"))
}
