//! The rasterising path of the wgpu renderer: every triangle of the view's scene drawn into
//! one image of an atlas (a grid of images), writing the triangle id and the depth as bits
//! (so it also works where float targets cannot be rendered or depth cannot be copied). Its
//! cost follows the scene's triangles, once per view; [`super::trace`]'s follows the pixels.

use wgpu::util::DeviceExt;

use super::{GpuError, View};
use crate::render::frame::Frame;
use crate::render::scene::RenderScene;

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

/// The id/depth render pipeline.
pub(super) struct Raster {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
}

/// A scene uploaded for rasterising: its vertex buffer and vertex count.
pub(super) type RasterScene = (wgpu::Buffer, u32);

impl Raster {
    /// Builds the pipeline on `device`.
    pub(super) fn new(device: &wgpu::Device) -> Raster {
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
        Raster { pipeline, layout }
    }

    /// Uploads the scene's triangle corners.
    pub(super) fn upload(device: &wgpu::Device, scene: &RenderScene) -> RasterScene {
        let data: Vec<[f32; 3]> = scene.positions.iter().map(|p| p.to_array()).collect();
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("scene vertices"),
            contents: bytemuck::cast_slice(if data.is_empty() {
                &[[0.0f32; 3]]
            } else {
                &data[..]
            }),
            usage: wgpu::BufferUsages::VERTEX,
        });
        (buffer, data.len() as u32)
    }

    /// Renders views of one resolution `w` × `h` (both non-zero), one atlas per submission.
    pub(super) fn render(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scenes: &[&RasterScene],
        views: &[View],
        (w, h): (u32, u32),
    ) -> Result<Vec<Frame>, GpuError> {
        // Atlases up to 4096² (64 MB per target): larger ones cost memory, not speed.
        let max_dim = device.limits().max_texture_dimension_2d.min(ATLAS_MAX);
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
            frames.extend(self.render_atlas(device, queue, scenes, chunk, w, h, cols)?);
        }
        Ok(frames)
    }

    /// Renders up to one atlas of views (`cols` images per row of the atlas).
    #[allow(clippy::too_many_arguments)]
    fn render_atlas(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scenes: &[&RasterScene],
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
            device.create_texture(&wgpu::TextureDescriptor {
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
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("cameras"),
            contents: &uniforms,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
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
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
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
                let (buffer, count) = &scenes[v.scene.0];
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
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
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
        queue.submit([encoder.finish()]);
        let slice = readback.slice(..);
        let data = super::map_read(device, &slice)?;
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
