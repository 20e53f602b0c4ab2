//! The GPU ray tracer's second pass: the images a batch asks for ([`Channels`]) derived on
//! the GPU from the triangle ids and depth-buffer values the trace pass wrote (`derive.wgsl`,
//! one invocation per pixel, the formulas of [`crate::render::frame`]), so a batch reads back
//! finished images instead of ids the host turns into images. Each scene's per-triangle
//! attributes (normal, colour, texture map, labels: 96 bytes a triangle) and textures are
//! uploaded beside its BVH.
//!
//! The images equal the CPU's derivation from the same frame: labels, normals and the texture
//! index exactly; linear depth and colour within single-precision rounding (the GPU may fuse
//! a multiply and an add; colour differs by at most one level on a few pixels) —
//! `tests/sim.rs` checks both against the CPU.

use wgpu::util::DeviceExt;

use super::GpuError;
use crate::render::derived::{taxonomy_slot, Channel, Channels, Derived};
use crate::render::frame::{AMBIENT, LIGHT};
use crate::render::scene::RenderScene;
use crate::scene::Taxonomy;

/// The shader.
const SHADER: &str = include_str!("derive.wgsl");
/// "Not asked for" in the channel offsets.
pub(super) const EMPTY: u32 = u32::MAX;

/// One dispatch's uniform block (`Derive` in `derive.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct DeriveRecord {
    first: u32,
    total: u32,
    width: u32,
    height: u32,
    light: [f32; 4],
    at: [u32; 12],
}

/// The derivation pipeline and its bind group layouts.
pub(super) struct Deriver {
    pub(super) pipeline: wgpu::ComputePipeline,
    scene_layout: wgpu::BindGroupLayout,
    pub(super) batch_layout: wgpu::BindGroupLayout,
}

/// A scene's attributes and textures, uploaded for derivation.
pub(super) struct DerivedScene {
    pub(super) bind: wgpu::BindGroup,
}

/// Where each asked-for channel's words start in a batch's output buffer, after the ids and
/// depth of `total` views of `pixels` pixels ([`EMPTY`] for the others), and the words of the
/// whole buffer.
pub(super) fn layout(channels: Channels, total: usize, pixels: usize) -> ([u32; 12], usize) {
    let mut at = [EMPTY; 12];
    let mut next = 2 * total * pixels;
    for c in channels.iter() {
        at[c.index()] = next as u32;
        next += c.words() * total * pixels;
    }
    (at, next)
}

/// 32-bit words per pixel of a batch's output: ids, depth and the asked-for channels.
pub(super) fn words_per_pixel(channels: Channels) -> usize {
    2 + channels.iter().map(Channel::words).sum::<usize>()
}

/// The uniform block of a dispatch of views `first..` of a batch of `total` views.
pub(super) fn record(first: u32, total: u32, (w, h): (u32, u32), at: [u32; 12]) -> DeriveRecord {
    let light = glam::Vec3::from_array(LIGHT).normalize();
    DeriveRecord {
        first,
        total,
        width: w,
        height: h,
        light: [light.x, light.y, light.z, AMBIENT],
        at,
    }
}

/// The images of the view in output slot `slot` (of `pixels` pixels), read from the batch's
/// output `words` laid out by [`layout`] (`at`).
pub(super) fn unpack(
    words: &[u32],
    channels: Channels,
    at: &[u32; 12],
    slot: usize,
    pixels: usize,
) -> Derived {
    let region = |c: Channel| {
        let start = at[c.index()] as usize + c.words() * slot * pixels;
        &words[start..start + c.words() * pixels]
    };
    let mut d = Derived::default();
    for c in channels.iter() {
        let r = region(c);
        match c {
            Channel::Color => {
                d.color = Some(
                    r.iter()
                        .map(|&p| [p as u8, (p >> 8) as u8, (p >> 16) as u8])
                        .collect(),
                )
            }
            Channel::Depth => d.linear_depth = Some(r.iter().map(|&b| f32::from_bits(b)).collect()),
            Channel::Normal => {
                d.normals = Some(
                    r.chunks_exact(3)
                        .map(|n| [n[0], n[1], n[2]].map(f32::from_bits))
                        .collect(),
                )
            }
            Channel::Semantic(t) => {
                d.semantic[taxonomy_slot(t)] = Some(r.iter().map(|&v| v as u16).collect())
            }
            Channel::Instance => d.instance = Some(r.to_vec()),
            Channel::Room => d.room = Some(r.to_vec()),
            Channel::RoomClass => d.room_class = Some(r.iter().map(|&v| v as u8).collect()),
        }
    }
    d
}

/// A storage-buffer binding of the layouts.
fn storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

impl Deriver {
    /// Builds the pipeline on `device`.
    pub(super) fn new(device: &wgpu::Device) -> Deriver {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("minos derive"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let scene_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("derive scene"),
            entries: &[storage(0, true), storage(1, true)],
        });
        let batch_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("derive batch"),
            entries: &[
                storage(0, true),
                storage(1, false),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: true,
                        min_binding_size: wgpu::BufferSize::new(
                            std::mem::size_of::<DeriveRecord>() as u64,
                        ),
                    },
                    count: None,
                },
            ],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("minos derive"),
            bind_group_layouts: &[Some(&scene_layout), Some(&batch_layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("minos derive"),
            layout: Some(&layout),
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        Deriver {
            pipeline,
            scene_layout,
            batch_layout,
        }
    }

    /// Uploads `scene`'s triangle attributes and textures; fails when a buffer exceeds the
    /// device's storage-binding limit.
    pub(super) fn upload(
        &self,
        device: &wgpu::Device,
        scene: &RenderScene,
    ) -> Result<DerivedScene, GpuError> {
        let limit = device.limits().max_storage_buffer_binding_size;
        let buffer = |label, words: &[u32]| {
            let bytes = 4 * words.len() as u64;
            if bytes > limit {
                return Err(GpuError::Render(format!(
                    "the scene's {label} take {bytes} bytes, over the device's storage-buffer \
                     limit of {limit} bytes ({} triangles)",
                    scene.triangle_count()
                )));
            }
            Ok(
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: bytemuck::cast_slice(words),
                    usage: wgpu::BufferUsages::STORAGE,
                }),
            )
        };
        let tris = buffer("triangle attributes", &triangle_words(scene))?;
        let texels = buffer("textures", &texture_words(scene))?;
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("derive scene"),
            layout: &self.scene_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: tris.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: texels.as_entire_binding(),
                },
            ],
        });
        Ok(DerivedScene { bind })
    }
}

/// Words per triangle record (`Tri` in `derive.wgsl`).
const TRI_WORDS: usize = 24;

/// The scene's triangle records as `derive.wgsl` reads them (at least one record: a binding
/// is never empty).
fn triangle_words(scene: &RenderScene) -> Vec<u32> {
    let mut words = Vec::with_capacity(TRI_WORDS * scene.tris.len().max(1));
    let f = |v: f32| v.to_bits();
    for (i, t) in scene.tris.iter().enumerate() {
        let map = scene.uv_maps.get(i).copied().unwrap_or_default();
        let semantic = |tax| match tax {
            Taxonomy::Nyu40 => u32::from(t.nyu40),
            Taxonomy::Mpcat40 => u32::from(t.mpcat40),
            Taxonomy::Coarse => u32::from(t.coarse),
        };
        words.extend_from_slice(&[
            f(t.normal[0]),
            f(t.normal[1]),
            f(t.normal[2]),
            t.texture,
            f(t.color[0]),
            f(t.color[1]),
            f(t.color[2]),
            t.object,
            f(map.origin.x),
            f(map.origin.y),
            f(map.origin.z),
            t.room,
            f(map.uv0[0]),
            f(map.uv0[1]),
            semantic(Taxonomy::Nyu40) | semantic(Taxonomy::Mpcat40) << 16,
            semantic(Taxonomy::Coarse) | u32::from(t.room_class) << 16,
            f(map.du.x),
            f(map.du.y),
            f(map.du.z),
            0,
            f(map.dv.x),
            f(map.dv.y),
            f(map.dv.z),
            0,
        ]);
    }
    if words.is_empty() {
        words.resize(TRI_WORDS, 0);
    }
    words
}

/// The scene's textures as `derive.wgsl` reads them: the count, a record per texture, then
/// the texels.
fn texture_words(scene: &RenderScene) -> Vec<u32> {
    let n = scene.textures.len();
    let mut words = vec![0u32; 4 + 4 * n];
    words[0] = n as u32;
    for (k, tex) in scene.textures.iter().enumerate() {
        let first = words.len() as u32;
        words[4 + 4 * k..8 + 4 * k].copy_from_slice(&[first, tex.width, tex.height, 0]);
        words.extend(
            tex.texels
                .iter()
                .map(|&[r, g, b]| u32::from(r) | u32::from(g) << 8 | u32::from(b) << 16),
        );
    }
    words
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shader_reads_the_records_the_host_writes() {
        assert_eq!(std::mem::size_of::<DeriveRecord>(), 80);
        assert!(SHADER.contains("at: array<vec4<u32>, 3>"));
        assert_eq!(TRI_WORDS * 4, 6 * 16, "six vec4<u32> in `Tri`");
        let scene = RenderScene::default();
        assert_eq!(triangle_words(&scene).len(), TRI_WORDS);
        assert_eq!(texture_words(&scene), vec![0; 4]);
    }

    #[test]
    fn channels_are_laid_out_after_ids_and_depth_in_order() {
        let c = Channels::NONE
            .with(Channel::RoomClass)
            .with(Channel::Normal)
            .with(Channel::Color);
        let (at, words) = layout(c, 3, 10);
        assert_eq!(at[Channel::Color.index()], 60);
        assert_eq!(at[Channel::Normal.index()], 90);
        assert_eq!(at[Channel::RoomClass.index()], 180);
        assert_eq!(at[Channel::Depth.index()], EMPTY);
        assert_eq!(words, 210);
        assert_eq!(words_per_pixel(c), 7);
        // Unpacking slot 1 reads its own part of each region.
        let mut out = vec![0u32; words];
        out[60 + 10] = 1 | 2 << 8 | 3 << 16;
        out[90 + 30..90 + 33].copy_from_slice(&[0.5f32.to_bits(), 0, 1.0f32.to_bits()]);
        out[180 + 10] = 7;
        let d = unpack(&out, c, &at, 1, 10);
        assert_eq!(d.color.as_ref().unwrap()[0], [1, 2, 3]);
        assert_eq!(d.normals.as_ref().unwrap()[0], [0.5, 0.0, 1.0]);
        assert_eq!(d.room_class.as_ref().unwrap()[0], 7);
        assert_eq!(d.linear_depth, None);
    }
}
