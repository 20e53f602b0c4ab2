//! Choosing a renderer: the CPU renderer, wgpu, or `auto` (wgpu when a hardware adapter
//! exists, else the CPU, saying why in the log). Both produce the same frames.

use super::gpu::{GpuError, GpuRenderer};
use super::{cpu, Camera, Channels, Frame, RenderScene};

/// Which renderer to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RendererChoice {
    /// The CPU rasteriser.
    Cpu,
    /// wgpu (fails when no adapter exists).
    Wgpu,
    /// wgpu when a hardware adapter exists, else the CPU renderer (a software adapter such
    /// as lavapipe is slower than the CPU renderer it would replace).
    #[default]
    Auto,
}

impl crate::vocab::Vocabulary for RendererChoice {
    const WHAT: &'static str = "renderer";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: RendererChoice::Auto,
            name: "auto",
            aliases: &[],
            help:
                "wgpu when a hardware GPU adapter exists, else the CPU renderer (the log says why)",
        },
        crate::vocab::Term {
            value: RendererChoice::Cpu,
            name: "cpu",
            aliases: &[],
            help: "the built-in CPU renderer",
        },
        crate::vocab::Term {
            value: RendererChoice::Wgpu,
            name: "wgpu",
            aliases: &[],
            help: "wgpu (fails without an adapter)",
        },
    ];
}

crate::vocab::name_traits!(RendererChoice);

/// A renderer instance.
pub enum Renderer {
    /// The CPU rasteriser.
    Cpu,
    /// wgpu, with the scene uploaded.
    Gpu(Box<GpuRenderer>),
}

impl Renderer {
    /// Creates the chosen renderer for `scene`.
    pub fn new(choice: RendererChoice, scene: &RenderScene) -> Result<Renderer, GpuError> {
        let gpu = || -> Result<Renderer, GpuError> {
            let mut g = GpuRenderer::new()?;
            g.upload(scene)?;
            Ok(Renderer::Gpu(Box::new(g)))
        };
        match choice {
            RendererChoice::Cpu => Ok(Renderer::Cpu),
            RendererChoice::Wgpu => gpu(),
            RendererChoice::Auto => Ok(match GpuRenderer::new() {
                Ok(g) if g.is_software() => {
                    tracing::info!(
                        "renderer auto: the only adapter is a software one ({}); using the CPU renderer",
                        g.adapter_name()
                    );
                    Renderer::Cpu
                }
                Ok(mut g) => match g.upload(scene) {
                    Ok(()) => Renderer::Gpu(Box::new(g)),
                    Err(e) => {
                        tracing::info!("renderer auto: the GPU cannot hold the scene ({}); using the CPU renderer", crate::escape::error_line(&e));
                        Renderer::Cpu
                    }
                },
                Err(e) => {
                    tracing::info!(
                        "renderer auto: no usable GPU ({}); using the CPU renderer",
                        crate::escape::error_line(&e)
                    );
                    Renderer::Cpu
                }
            }),
        }
    }

    /// `cpu` or the adapter's name.
    pub fn name(&self) -> String {
        match self {
            Renderer::Cpu => "cpu".into(),
            Renderer::Gpu(g) => format!("wgpu: {}", g.adapter_name()),
        }
    }

    /// Renders cameras (any resolutions) in order.
    pub fn render(&self, scene: &RenderScene, cameras: &[Camera]) -> Result<Vec<Frame>, GpuError> {
        self.render_with(scene, cameras, Channels::NONE)
    }

    /// [`Renderer::render`], asking a GPU renderer that derives images
    /// ([`GpuRenderer::derives_images`]) for those of `channels` too; the CPU renderer's
    /// frames carry none (its images are derived from the frame when read).
    pub fn render_with(
        &self,
        scene: &RenderScene,
        cameras: &[Camera],
        channels: Channels,
    ) -> Result<Vec<Frame>, GpuError> {
        self.render_as(scene, cameras, channels, true)
    }

    /// [`Renderer::render_with`] for callers that will ask each frame for the images of
    /// `channels` only: a GPU renderer that derives them reads back just those
    /// ([`GpuRenderer::render_views_derived`]; frames without ids or depth), the others
    /// render as [`Renderer::render_with`].
    pub fn render_derived(
        &self,
        scene: &RenderScene,
        cameras: &[Camera],
        channels: Channels,
    ) -> Result<Vec<Frame>, GpuError> {
        self.render_as(scene, cameras, channels, false)
    }

    fn render_as(
        &self,
        scene: &RenderScene,
        cameras: &[Camera],
        channels: Channels,
        ids: bool,
    ) -> Result<Vec<Frame>, GpuError> {
        match self {
            Renderer::Cpu => Ok(cameras.iter().map(|c| cpu::render(scene, c)).collect()),
            Renderer::Gpu(g) => {
                // Batch cameras of equal resolution.
                let mut frames: Vec<Option<Frame>> = vec![None; cameras.len()];
                let mut done = vec![false; cameras.len()];
                for i in 0..cameras.len() {
                    if done[i] {
                        continue;
                    }
                    let group: Vec<usize> = (i..cameras.len())
                        .filter(|&j| {
                            !done[j]
                                && cameras[j].width == cameras[i].width
                                && cameras[j].height == cameras[i].height
                        })
                        .collect();
                    let cams: Vec<Camera> = group.iter().map(|&j| cameras[j]).collect();
                    let channels = if g.derives_images() {
                        channels
                    } else {
                        Channels::NONE
                    };
                    let rendered = match ids {
                        true => g.render_batch_with(&cams, channels)?,
                        false => g.render_batch_derived(&cams, channels)?,
                    };
                    for (j, f) in group.iter().zip(rendered) {
                        frames[*j] = Some(f);
                        done[*j] = true;
                    }
                }
                Ok(frames.into_iter().flatten().collect())
            }
        }
    }
}
