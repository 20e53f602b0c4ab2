//! The wgpu renderer: offscreen, headless (no surface or window), on any adapter wgpu finds —
//! a GPU, or lavapipe on a CPU. One pass writes, per pixel, the triangle id and the depth
//! (as bits, so it also works where float targets cannot be rendered or depth cannot be
//! copied); the images are then derived exactly as for the CPU renderer. Several scenes can be
//! uploaded side by side, and a batch of views — each a camera on one of them, all of one
//! resolution — renders into one atlas texture (a grid of images) with one command encoder,
//! one submission and one read-back buffer; batches larger than the atlas limit are split
//! into as few submissions as fit.

use wgpu::util::DeviceExt;

use super::camera::Camera;
use super::frame::Frame;
use super::scene::RenderScene;

/// Why the GPU renderer is unavailable or failed.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter (install `mesa-vulkan-drivers` for lavapipe, or use the CPU renderer).
    #[error("no GPU adapter found ({0}); the CPU renderer works without one")]
    NoAdapter(String),
    /// The device could not be created.
    #[error("GPU device: {0}")]
    Device(String),
    /// Rendering or read-back failed.
    #[error("GPU render: {0}")]
    Render(String),
}

/// The environment variable to set, before any thread starts, so that looking for an adapter
/// prints nothing on a machine without a desktop session, or `None` when nothing needs to
/// change. `var` reads the environment.
///
/// Mesa's Vulkan device-select layer (installed with lavapipe and Mesa's drivers) asks the
/// Wayland display for its default GPU, and libwayland prints `error: XDG_RUNTIME_DIR is
/// invalid or not set in the environment.` when there is no session. Without a usable
/// `XDG_RUNTIME_DIR` there is no display to choose by, so the layer is turned off with Mesa's
/// own switch, `NODEVICE_SELECT=1` — unless the user picked a device (`MESA_VK_DEVICE_SELECT`)
/// or set `NODEVICE_SELECT` already. Adapters are still chosen by wgpu's power preference.
pub fn quiet_probe_env(
    var: impl Fn(&'static str) -> Option<std::ffi::OsString>,
) -> Option<(&'static str, &'static str)> {
    let session = var("XDG_RUNTIME_DIR").is_some_and(|d| std::path::Path::new(&d).is_absolute());
    let chosen = var("MESA_VK_DEVICE_SELECT").is_some() || var("NODEVICE_SELECT").is_some();
    (!session && !chosen).then_some(("NODEVICE_SELECT", "1"))
}

const SHADER: &str = r#"
struct Cam { vp: mat4x4<f32> };
@group(0) @binding(0) var<uniform> cam: Cam;
struct VOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) @interpolate(flat) id: u32,
};
@vertex
fn vs(@location(0) p: vec3<f32>, @builtin(vertex_index) vi: u32) -> VOut {
    var o: VOut;
    o.pos = cam.vp * vec4<f32>(p, 1.0);
    o.id = vi / 3u;
    return o;
}
struct FOut {
    @location(0) id: u32,
    @location(1) depth: u32,
};
@fragment
fn fs(i: VOut) -> FOut {
    var o: FOut;
    o.id = i.id;
    o.depth = bitcast<u32>(i.pos.z);
    return o;
}
"#;

/// Largest atlas edge (pixels).
const ATLAS_MAX: u32 = 4096;

/// Uniform block stride (dynamic offsets must be 256-aligned).
const UNIFORM_STRIDE: u64 = 256;

/// A wgpu device with the id/depth pipeline and the uploaded scenes' vertices.
pub struct GpuRenderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    adapter: wgpu::AdapterInfo,
    /// Vertex buffer and vertex count of each uploaded scene, by [`SceneSlot`].
    scenes: Vec<(wgpu::Buffer, u32)>,
}

/// An uploaded scene of a [`GpuRenderer`] (see [`GpuRenderer::add_scene`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SceneSlot(pub usize);

/// One image of a batch: a camera looking at an uploaded scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// The scene.
    pub scene: SceneSlot,
    /// The camera (every view of a batch has the same resolution).
    pub camera: Camera,
}

impl GpuRenderer {
    /// Finds an adapter (any backend wgpu is built with; `WGPU_BACKEND` and friends are
    /// honoured) and builds the pipeline.
    pub fn new() -> Result<Self, GpuError> {
        // Primary backends (Vulkan, Metal, DX12) first: probing GL/EGL on a headless box prints
        // warnings and is only worth it when nothing else exists. `WGPU_BACKEND` overrides.
        let from_env = std::env::var_os("WGPU_BACKEND").is_some();
        let attempt = |backends: Option<wgpu::Backends>| {
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
            if let Some(b) = backends {
                desc.backends = b;
            }
            let instance = wgpu::Instance::new(desc);
            pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter: false,
                compatible_surface: None,
                apply_limit_buckets: false,
            }))
        };
        let adapter = if from_env {
            attempt(None)
        } else {
            attempt(Some(wgpu::Backends::PRIMARY)).or_else(|_| attempt(Some(wgpu::Backends::all())))
        }
        .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("minos"),
            required_features: wgpu::Features::empty(),
            required_limits: wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits()),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("minos id/depth"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("camera"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: wgpu::BufferSize::new(64),
                },
                count: None,
            }],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("minos"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let target = |format| {
            Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })
        };
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("minos id/depth"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: 12,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &[wgpu::VertexAttribute {
                        format: wgpu::VertexFormat::Float32x3,
                        offset: 0,
                        shader_location: 0,
                    }],
                })],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[
                    target(wgpu::TextureFormat::R32Uint),
                    target(wgpu::TextureFormat::R32Uint),
                ],
            }),
            multiview_mask: None,
            cache: None,
        });
        Ok(GpuRenderer {
            device,
            queue,
            pipeline,
            layout,
            adapter: info,
            scenes: Vec::new(),
        })
    }

    /// "name (backend, device type)" of the adapter in use.
    pub fn adapter_name(&self) -> String {
        format!(
            "{} ({:?}, {:?})",
            self.adapter.name, self.adapter.backend, self.adapter.device_type
        )
    }

    /// Uploads the scene's triangles, replacing every scene uploaded before; it becomes
    /// `SceneSlot(0)`, the scene [`GpuRenderer::render_batch`] renders.
    pub fn upload(&mut self, scene: &RenderScene) {
        self.scenes.clear();
        self.add_scene(scene);
    }

    /// Uploads one more scene beside those already uploaded and returns its slot.
    pub fn add_scene(&mut self, scene: &RenderScene) -> SceneSlot {
        let data: Vec<[f32; 3]> = scene.positions.iter().map(|p| p.to_array()).collect();
        let buffer = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("scene vertices"),
                contents: bytemuck::cast_slice(if data.is_empty() {
                    &[[0.0f32; 3]]
                } else {
                    &data[..]
                }),
                usage: wgpu::BufferUsages::VERTEX,
            });
        self.scenes.push((buffer, data.len() as u32));
        SceneSlot(self.scenes.len() - 1)
    }

    /// Number of uploaded scenes.
    pub fn scene_count(&self) -> usize {
        self.scenes.len()
    }

    /// Renders cameras of one resolution on the scene of [`GpuRenderer::upload`] (slot 0)
    /// in one submission. Frames come back in camera order.
    pub fn render_batch(&self, cameras: &[Camera]) -> Result<Vec<Frame>, GpuError> {
        let views: Vec<View> = cameras
            .iter()
            .map(|&camera| View {
                scene: SceneSlot(0),
                camera,
            })
            .collect();
        self.render_views(&views)
    }

    /// Renders views (cameras on any uploaded scenes, one resolution) with one command
    /// encoder, one submission and one read-back per atlas of views; frames come back in
    /// view order, each frame's triangle ids those of its own scene.
    pub fn render_views(&self, views: &[View]) -> Result<Vec<Frame>, GpuError> {
        let Some(first) = views.first() else {
            return Ok(Vec::new());
        };
        let (w, h) = (first.camera.width, first.camera.height);
        if views
            .iter()
            .any(|v| v.camera.width != w || v.camera.height != h)
        {
            return Err(GpuError::Render(
                "all cameras of a batch need the same resolution".into(),
            ));
        }
        if let Some(v) = views.iter().find(|v| v.scene.0 >= self.scenes.len()) {
            return Err(GpuError::Render(format!(
                "scene slot {} not uploaded ({} scenes)",
                v.scene.0,
                self.scenes.len()
            )));
        }
        // Atlases up to 4096² (64 MB per target): larger ones cost memory, not speed.
        let max_dim = self.device.limits().max_texture_dimension_2d.min(ATLAS_MAX);
        if w == 0 || h == 0 {
            return Ok(views.iter().map(|_| Frame::new(w, h)).collect());
        }
        if w > max_dim || h > max_dim {
            return Err(GpuError::Render(format!(
                "images {w}x{h} exceed the texture limit {max_dim}"
            )));
        }
        // A grid of images: as many columns and rows as the texture limit allows.
        let cols = (max_dim / w).max(1);
        let per_atlas = (cols * (max_dim / h).max(1)) as usize;
        let mut frames = Vec::with_capacity(views.len());
        for chunk in views.chunks(per_atlas) {
            frames.extend(self.render_atlas(chunk, w, h, cols)?);
        }
        Ok(frames)
    }

    /// Renders up to one atlas of views (`cols` images per row of the atlas).
    fn render_atlas(
        &self,
        views: &[View],
        w: u32,
        h: u32,
        cols: u32,
    ) -> Result<Vec<Frame>, GpuError> {
        let n = views.len() as u32;
        let cols = cols.min(n);
        let rows = n.div_ceil(cols);
        let atlas = wgpu::Extent3d {
            width: w * cols,
            height: h * rows,
            depth_or_array_layers: 1,
        };
        let texture = |format, usage, label| {
            self.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: atlas,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let copy = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        let ids = texture(wgpu::TextureFormat::R32Uint, copy, "ids");
        let depth_bits = texture(wgpu::TextureFormat::R32Uint, copy, "depth bits");
        let depth = texture(
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
            "depth",
        );
        let mut uniforms = vec![0u8; (UNIFORM_STRIDE * u64::from(n)) as usize];
        for (i, v) in views.iter().enumerate() {
            let m = v.camera.view_projection().to_cols_array();
            let at = i * UNIFORM_STRIDE as usize;
            uniforms[at..at + 64].copy_from_slice(bytemuck::cast_slice(&m));
        }
        let uniform = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("cameras"),
                contents: &uniforms,
                usage: wgpu::BufferUsages::UNIFORM,
            });
        let bind = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cameras"),
            layout: &self.layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &uniform,
                    offset: 0,
                    size: wgpu::BufferSize::new(64),
                }),
            }],
        });
        let views_tex = [
            ids.create_view(&Default::default()),
            depth_bits.create_view(&Default::default()),
        ];
        let depth_view = depth.create_view(&Default::default());
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("render"),
            });
        {
            let clear = |v: f64| wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color {
                    r: v,
                    g: 0.0,
                    b: 0.0,
                    a: 0.0,
                }),
                store: wgpu::StoreOp::Store,
            };
            let color = [
                Some(wgpu::RenderPassColorAttachment {
                    view: &views_tex[0],
                    depth_slice: None,
                    resolve_target: None,
                    ops: clear(f64::from(u32::MAX)),
                }),
                Some(wgpu::RenderPassColorAttachment {
                    view: &views_tex[1],
                    depth_slice: None,
                    resolve_target: None,
                    ops: clear(f64::from(1.0f32.to_bits())),
                }),
            ];
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("ids"),
                color_attachments: &color,
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            let mut bound = usize::MAX;
            for (i, v) in views.iter().enumerate() {
                let (x, y) = ((i as u32 % cols) * w, (i as u32 / cols) * h);
                let (buffer, count) = &self.scenes[v.scene.0];
                if bound != v.scene.0 {
                    pass.set_vertex_buffer(0, buffer.slice(..));
                    bound = v.scene.0;
                }
                pass.set_viewport(x as f32, y as f32, w as f32, h as f32, 0.0, 1.0);
                pass.set_scissor_rect(x, y, w, h);
                pass.set_bind_group(0, &bind, &[(i as u64 * UNIFORM_STRIDE) as u32]);
                pass.draw(0..*count, 0..1);
            }
        }
        // One read-back buffer: the ids, then the depth bits.
        let row = (atlas.width * 4).div_ceil(256) * 256;
        let plane = u64::from(row) * u64::from(atlas.height);
        let readback = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read-back"),
            size: 2 * plane,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        for (k, tex) in [&ids, &depth_bits].into_iter().enumerate() {
            encoder.copy_texture_to_buffer(
                wgpu::TexelCopyTextureInfo {
                    texture: tex,
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::TexelCopyBufferInfo {
                    buffer: &readback,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: k as u64 * plane,
                        bytes_per_row: Some(row),
                        rows_per_image: Some(atlas.height),
                    },
                },
                atlas,
            );
        }
        self.queue.submit([encoder.finish()]);
        let slice = readback.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Render(e.to_string()))?;
        rx.recv()
            .map_err(|e| GpuError::Render(e.to_string()))?
            .map_err(|e| GpuError::Render(e.to_string()))?;
        let data = slice
            .get_mapped_range()
            .map_err(|e| GpuError::Render(e.to_string()))?;
        let words: &[u32] = bytemuck::cast_slice(&data);
        let (row_words, plane_words) = (row as usize / 4, plane as usize / 4);
        let frames = (0..n as usize)
            .map(|i| {
                let (x0, y0) = (
                    (i % cols as usize) * w as usize,
                    (i / cols as usize) * h as usize,
                );
                let mut frame = Frame::new(w, h);
                for y in 0..h as usize {
                    let at = (y0 + y) * row_words + x0;
                    let out = y * w as usize..(y + 1) * w as usize;
                    frame.tri[out.clone()].copy_from_slice(&words[at..at + w as usize]);
                    for (d, b) in frame.depth[out]
                        .iter_mut()
                        .zip(&words[plane_words + at..plane_words + at + w as usize])
                    {
                        *d = f32::from_bits(*b);
                    }
                }
                frame
            })
            .collect();
        drop(data);
        readback.unmap();
        Ok(frames)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<std::ffi::OsString> + 'a {
        move |k| vars.iter().find(|(n, _)| *n == k).map(|(_, v)| v.into())
    }

    #[test]
    fn the_device_select_layer_is_turned_off_only_without_a_session_or_a_choice() {
        assert_eq!(quiet_probe_env(env(&[])), Some(("NODEVICE_SELECT", "1")));
        assert_eq!(
            quiet_probe_env(env(&[("XDG_RUNTIME_DIR", "relative")])),
            Some(("NODEVICE_SELECT", "1")),
            "libwayland refuses a relative runtime dir too"
        );
        assert_eq!(
            quiet_probe_env(env(&[("XDG_RUNTIME_DIR", "/run/user/1000")])),
            None
        );
        assert_eq!(
            quiet_probe_env(env(&[("MESA_VK_DEVICE_SELECT", "10de:2330")])),
            None
        );
        assert_eq!(quiet_probe_env(env(&[("NODEVICE_SELECT", "0")])), None);
    }
}
