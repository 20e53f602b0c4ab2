//! The wgpu renderer: offscreen, headless (no surface or window), on any adapter wgpu finds —
//! a GPU, or lavapipe on a CPU. One pass writes, per pixel, the triangle id and the depth
//! (as bits, so it also works where float targets cannot be rendered or depth cannot be
//! copied); the images are then derived exactly as for the CPU renderer. A batch of cameras
//! renders into one atlas texture in one submission with one read-back.

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

/// Uniform block stride (dynamic offsets must be 256-aligned).
const UNIFORM_STRIDE: u64 = 256;

/// A wgpu device with the id/depth pipeline and the current scene's vertices.
pub struct GpuRenderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    adapter: wgpu::AdapterInfo,
    vertices: Option<(wgpu::Buffer, u32)>,
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
            vertices: None,
        })
    }

    /// "name (backend, device type)" of the adapter in use.
    pub fn adapter_name(&self) -> String {
        format!(
            "{} ({:?}, {:?})",
            self.adapter.name, self.adapter.backend, self.adapter.device_type
        )
    }

    /// Uploads the scene's triangles (replacing any previous scene).
    pub fn upload(&mut self, scene: &RenderScene) {
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
        self.vertices = Some((buffer, data.len() as u32));
    }

    /// Renders cameras of one resolution in one submission (call [`GpuRenderer::upload`]
    /// first). Frames come back in camera order.
    pub fn render_batch(&self, cameras: &[Camera]) -> Result<Vec<Frame>, GpuError> {
        let Some((vertices, count)) = &self.vertices else {
            return Err(GpuError::Render("no scene uploaded".into()));
        };
        let Some(first) = cameras.first() else {
            return Ok(Vec::new());
        };
        let (w, h) = (first.width, first.height);
        if cameras.iter().any(|c| c.width != w || c.height != h) {
            return Err(GpuError::Render(
                "all cameras of a batch need the same resolution".into(),
            ));
        }
        let n = cameras.len() as u32;
        let max_dim = self.device.limits().max_texture_dimension_2d;
        if w > max_dim || h * n > max_dim {
            return Err(GpuError::Render(format!(
                "batch of {n} images {w}x{h} exceeds the texture limit {max_dim}"
            )));
        }
        let atlas = wgpu::Extent3d {
            width: w,
            height: h * n,
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
        for (i, c) in cameras.iter().enumerate() {
            let m = c.view_projection().to_cols_array();
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
        let views = [
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
                    view: &views[0],
                    depth_slice: None,
                    resolve_target: None,
                    ops: clear(f64::from(u32::MAX)),
                }),
                Some(wgpu::RenderPassColorAttachment {
                    view: &views[1],
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
            pass.set_vertex_buffer(0, vertices.slice(..));
            for i in 0..n {
                pass.set_viewport(0.0, (i * h) as f32, w as f32, h as f32, 0.0, 1.0);
                pass.set_scissor_rect(0, i * h, w, h);
                pass.set_bind_group(0, &bind, &[(u64::from(i) * UNIFORM_STRIDE) as u32]);
                pass.draw(0..*count, 0..1);
            }
        }
        let row = (w * 4).div_ceil(256) * 256;
        let readback = |label| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: u64::from(row) * u64::from(h * n),
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            })
        };
        let (id_buf, depth_buf) = (readback("ids read-back"), readback("depth read-back"));
        for (tex, buf) in [(&ids, &id_buf), (&depth_bits, &depth_buf)] {
            encoder.copy_texture_to_buffer(
                wgpu::TexelCopyTextureInfo {
                    texture: tex,
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::TexelCopyBufferInfo {
                    buffer: buf,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(row),
                        rows_per_image: Some(h * n),
                    },
                },
                atlas,
            );
        }
        self.queue.submit([encoder.finish()]);
        let read = |buf: &wgpu::Buffer| -> Result<Vec<u32>, GpuError> {
            let slice = buf.slice(..);
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
            let view = slice
                .get_mapped_range()
                .map_err(|e| GpuError::Render(e.to_string()))?;
            let mut out = Vec::with_capacity((w * h * n) as usize);
            for y in 0..(h * n) as usize {
                let start = y * row as usize;
                out.extend_from_slice(bytemuck::cast_slice(&view[start..start + (w * 4) as usize]));
            }
            drop(view);
            buf.unmap();
            Ok(out)
        };
        let (tri, bits) = (read(&id_buf)?, read(&depth_buf)?);
        let per = (w * h) as usize;
        Ok((0..n as usize)
            .map(|i| Frame {
                width: w,
                height: h,
                tri: tri[i * per..(i + 1) * per].to_vec(),
                depth: bits[i * per..(i + 1) * per]
                    .iter()
                    .map(|b| f32::from_bits(*b))
                    .collect(),
            })
            .collect())
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
