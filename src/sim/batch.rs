//! Many simulators stepped and observed at once, the shape batched rendering needs: the
//! motion of every simulator on all threads, then every simulator's cameras rendered together
//! — one call per renderer they share, so one submission and one read-back for all the
//! simulators of a scene on a GPU renderer —, then the images and measurements derived on all
//! threads. Each observation is the one [`Simulator::step`] / [`Simulator::observe`] gives
//! on that simulator alone (a frame does not depend on the batch it was rendered in).

use std::sync::Arc;
use std::time::{Duration, Instant};

use rayon::prelude::*;

use super::agent::Actions;
use super::simulator::{Observation, Simulator, Views};
use crate::render::gpu::GpuError;
use crate::render::Renderer;
use crate::render::{Camera, Channels, Frame};

/// Applies each simulator's actions (`actions[i]` to `sims[i]`) and observes them all.
pub fn step_many(
    sims: &mut [&mut Simulator],
    actions: &[Actions],
) -> Vec<Result<Observation, GpuError>> {
    sims.par_iter_mut()
        .zip(actions.par_iter())
        .for_each(|(sim, a)| sim.advance(*a));
    observe_many(sims)
}

/// Wall-clock time of the phases of batched steps, summed over calls: which part of a
/// lockstep step bounds it (for benchmarks; timing costs a few clock reads per batch).
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct PhaseTimes {
    /// Moving the agents (and resets, stops), in parallel.
    pub motion: Duration,
    /// The cameras' poses, in parallel.
    pub views: Duration,
    /// The shared renderers' calls, one after another: on a GPU the submission, the GPU's
    /// work, the read-back and unpacking the frames.
    pub render: Duration,
    /// Observations from the frames (images derived on the host where the GPU did not,
    /// measurements; CPU-rendered simulators render here), in parallel.
    pub observe: Duration,
    /// Bookkeeping after the observations (rewards, episode ends), in parallel.
    pub finish: Duration,
    /// Batched steps timed.
    pub batches: u64,
}

impl PhaseTimes {
    /// Adds the time since `start` to `phase` and returns now.
    pub fn lap(phase: &mut Duration, start: Instant) -> Instant {
        let now = Instant::now();
        *phase += now - start;
        now
    }
}

/// Observes every simulator: the cameras of simulators sharing a GPU renderer in one render
/// call, the others (CPU renderer) each on its own, in parallel.
pub fn observe_many(sims: &mut [&mut Simulator]) -> Vec<Result<Observation, GpuError>> {
    observe_many_timed(sims, &mut PhaseTimes::default())
}

/// [`observe_many`], adding the time of its phases to `times`.
pub fn observe_many_timed(
    sims: &mut [&mut Simulator],
    times: &mut PhaseTimes,
) -> Vec<Result<Observation, GpuError>> {
    let t = Instant::now();
    let views: Vec<Views> = sims.par_iter().map(|s| s.views()).collect();
    let t = PhaseTimes::lap(&mut times.views, t);
    let mut frames: Vec<Option<Result<Vec<Frame>, GpuError>>> = sims.iter().map(|_| None).collect();
    // Simulators sharing a GPU renderer (and so its scene), in order of first appearance.
    let mut groups: Vec<(*const Renderer, Vec<usize>)> = Vec::new();
    for (i, sim) in sims.iter().enumerate() {
        if !matches!(**sim.renderer(), Renderer::Gpu(_)) {
            continue;
        }
        let key = Arc::as_ptr(sim.renderer());
        match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, members)) => members.push(i),
            None => groups.push((key, vec![i])),
        }
    }
    for (_, members) in &groups {
        let first = &sims[members[0]];
        let cameras: Vec<Camera> = members
            .iter()
            .flat_map(|&i| views[i].unique.iter().copied())
            .collect();
        let channels = members
            .iter()
            .fold(Channels::NONE, |c, &i| c.union(sims[i].image_channels()));
        // Each simulator asks its frames for its sensors' images only, which are these
        // channels: the GPU reads back just those.
        match first
            .renderer()
            .render_derived(&first.assets().render, &cameras, channels)
        {
            Ok(rendered) => {
                let mut rendered = rendered.into_iter();
                for &i in members {
                    let own = rendered.by_ref().take(views[i].unique.len()).collect();
                    frames[i] = Some(Ok(own));
                }
            }
            Err(e) => {
                for &i in members {
                    frames[i] = Some(Err(e.clone()));
                }
            }
        }
    }
    let t = PhaseTimes::lap(&mut times.render, t);
    let observations = sims
        .par_iter_mut()
        .zip(views.par_iter())
        .zip(frames.into_par_iter())
        .map(|((sim, v), rendered)| {
            let frames = match rendered {
                Some(Ok(f)) => f,
                Some(Err(e)) => return Err(e),
                None => sim.renderer().render_with(
                    &sim.assets().render,
                    &v.unique,
                    sim.image_channels(),
                )?,
            };
            Ok(sim.observation_from(v, &frames))
        })
        .collect();
    PhaseTimes::lap(&mut times.observe, t);
    observations
}
