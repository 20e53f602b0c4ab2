//! The ray-tracing path of the wgpu renderer: the BVH the CPU ray caster builds
//! ([`crate::render::bvh`]) uploaded as two storage buffers per scene and traversed by a
//! compute shader (`trace.wgsl`), one invocation per pixel, 8×8 pixels per workgroup, one
//! workgroup layer per view. A batch's views — on any uploaded scenes — are sorted by scene
//! and rendered by one dispatch per scene in one compute pass, then read back with one copy:
//! so the cost follows the pixels (and the logarithm of the triangles), not the triangles.
//!
//! The shader computes each pixel centre's ray with [`RayBasis`]'s formula, tests triangles
//! with the same watertight test as the CPU (in single precision only: WGSL has no double, so
//! a ray through an edge value of exactly 0 counts as inside) and keeps the nearest hit, ties
//! to the lowest id; frames therefore agree with the CPU ray caster's within the parity
//! tolerances (`tests/sim.rs`), not bit for bit. Its traversal stack holds [`STACK`] entries;
//! a scene whose tree is deeper than that guarantees keeps a CPU copy of its hierarchy, and
//! the rare pixels whose stack overflowed are cast again on the CPU.
//!
//! Where a batch asks for images ([`Channels`]), a second pass (`derive.rs`) derives them on
//! the GPU from the ids and depth in the same submission, and they are read back with them.

use rayon::prelude::*;
use wgpu::util::DeviceExt;

use super::derive::{self, DerivedScene, Deriver};
use super::pool::{Room, SizedPool};
use super::{GpuError, View};
use crate::render::bvh::{Bvh, Ray};
use crate::render::derived::Channels;
use crate::render::frame::{Frame, PixelRays, RayBasis, NO_HIT};
use crate::render::scene::RenderScene;

/// The shader.
const SHADER: &str = include_str!("trace.wgsl");
/// Pixels per workgroup edge (`@workgroup_size(8, 8, 1)`).
const TILE: u32 = 8;
/// Traversal stack entries of the shader (`STACK` there).
const STACK: usize = 64;
/// Triangle id the shader writes where a ray's stack overflowed.
const OVERFLOW: u32 = 0xffff_fffe;
/// Stride of the per-dispatch uniform blocks (dynamic offsets must be 256-aligned).
const BATCH_STRIDE: u64 = 256;
/// Buffer sets the pool keeps (batches in flight at once, from several threads).
const POOLED_SETS: usize = 4;

/// One view as the shader reads it (`View` in `trace.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ViewRecord {
    origin: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    forward: [f32; 4],
    /// near, far, tan(vfov / 2), aspect.
    lens: [f32; 4],
    /// The projection's depth row (a, b).
    depth: [f32; 4],
    /// The view's place in the batch.
    slot: [u32; 4],
}

/// One dispatch's uniform block (`Batch` in `trace.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct BatchRecord {
    first: u32,
    total: u32,
    width: u32,
    height: u32,
    /// Where the per-view overflow flags start in the output (words).
    flags: u32,
    pad: [u32; 3],
}

/// The compute pipeline and its bind group layouts.
pub(super) struct Tracer {
    pipeline: wgpu::ComputePipeline,
    scene_layout: wgpu::BindGroupLayout,
    batch_layout: wgpu::BindGroupLayout,
    /// Entries of the shader's traversal stack.
    stack: usize,
    /// Buffer sets of earlier batches, reused by later ones (one per batch in flight).
    pool: std::sync::Mutex<SizedPool<BufferSet>>,
    /// The second pass, deriving images from the ids and depth.
    deriver: Deriver,
    /// Nanoseconds spent from submission until the read-back was mapped, and unpacking the
    /// frames, summed over batches ([`Tracer::times`]).
    waited_ns: std::sync::atomic::AtomicU64,
    unpacked_ns: std::sync::atomic::AtomicU64,
}

/// The buffers of one batch in flight and their bind group.
struct BufferSet {
    views: wgpu::Buffer,
    uniform: wgpu::Buffer,
    out: wgpu::Buffer,
    readback: wgpu::Buffer,
    bind: wgpu::BindGroup,
    /// The derivation pass's uniform blocks (one per dispatch) and bind group.
    derive_uniform: wgpu::Buffer,
    derive_bind: wgpu::BindGroup,
}

/// A scene uploaded for ray tracing.
pub(super) struct TracedScene {
    bind: wgpu::BindGroup,
    /// The hierarchy, kept on the CPU only when it is deeper than the shader's stack
    /// guarantees (to cast the pixels whose stack overflowed).
    fallback: Option<Bvh>,
    /// Attributes and textures for deriving images on the GPU (`None` where they did not
    /// fit the device: the host derives that scene's images).
    derive: Option<DerivedScene>,
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

impl Tracer {
    /// Builds the pipeline on `device`.
    pub(super) fn new(device: &wgpu::Device) -> Tracer {
        Tracer::with_stack(device, STACK)
    }

    /// Builds the pipeline with a traversal stack of `stack` entries (tests make it small
    /// to reach the overflow path).
    pub(super) fn with_stack(device: &wgpu::Device, stack: usize) -> Tracer {
        let source = SHADER.replace(
            &format!("const STACK: u32 = {STACK}u;"),
            &format!("const STACK: u32 = {stack}u;"),
        );
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("minos trace"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let scene_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("trace scene"),
            entries: &[storage(0, true), storage(1, true)],
        });
        let batch_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("trace batch"),
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
                            std::mem::size_of::<BatchRecord>() as u64
                        ),
                    },
                    count: None,
                },
            ],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("minos trace"),
            bind_group_layouts: &[Some(&scene_layout), Some(&batch_layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("minos trace"),
            layout: Some(&layout),
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        Tracer {
            pipeline,
            scene_layout,
            batch_layout,
            stack,
            pool: std::sync::Mutex::new(SizedPool::new(POOLED_SETS)),
            deriver: Deriver::new(device),
            waited_ns: Default::default(),
            unpacked_ns: Default::default(),
        }
    }

    /// Time spent from submission until the read-back was mapped (the GPU's work and the
    /// copy to host memory), and unpacking the frames from it, summed over every batch.
    pub(super) fn times(&self) -> (std::time::Duration, std::time::Duration) {
        use std::sync::atomic::Ordering::Relaxed;
        let d = std::time::Duration::from_nanos;
        (
            d(self.waited_ns.load(Relaxed)),
            d(self.unpacked_ns.load(Relaxed)),
        )
    }

    /// A buffer set with room for `need`: the smallest in the pool that holds it, or a new
    /// one with room to grow ([`Room::grown`], at most `max_views` views); with its room.
    fn buffers(&self, device: &wgpu::Device, need: Room, max_views: usize) -> (Room, BufferSet) {
        {
            let mut pool = self.pool.lock().unwrap_or_else(|e| e.into_inner());
            if let Some(set) = pool.take(&need) {
                return set;
            }
        }
        let room = need.grown(max_views);
        let buffer = |label, size: u64, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        let view_bytes = (room.views * std::mem::size_of::<ViewRecord>()) as u64;
        let views_buffer = buffer("trace views", view_bytes, U::STORAGE | U::COPY_DST);
        let uniform_bytes = room.groups as u64 * BATCH_STRIDE;
        let uniform = buffer("trace batches", uniform_bytes, U::UNIFORM | U::COPY_DST);
        let out = buffer(
            "trace output",
            room.bytes,
            U::STORAGE | U::COPY_SRC | U::COPY_DST,
        );
        let readback = buffer("trace read-back", room.bytes, U::COPY_DST | U::MAP_READ);
        let derive_uniform = buffer("derive batches", uniform_bytes, U::UNIFORM | U::COPY_DST);
        let derive_bind = batch_bind_group(
            device,
            "derive batch",
            &self.deriver.batch_layout,
            [&views_buffer, &out],
            &derive_uniform,
            std::mem::size_of::<derive::DeriveRecord>(),
        );
        let bind = batch_bind_group(
            device,
            "trace batch",
            &self.batch_layout,
            [&views_buffer, &out],
            &uniform,
            std::mem::size_of::<BatchRecord>(),
        );
        let set = BufferSet {
            views: views_buffer,
            uniform,
            out,
            readback,
            bind,
            derive_uniform,
            derive_bind,
        };
        (room, set)
    }

    /// Returns a buffer set to the pool ([`SizedPool::put`]).
    fn give_back(&self, room: Room, set: BufferSet) {
        let mut pool = self.pool.lock().unwrap_or_else(|e| e.into_inner());
        pool.put(room, set);
    }

    /// Uploads the scene's hierarchy (built now if it is not yet) and, where they fit, its
    /// attributes and textures for deriving images; fails when the hierarchy exceeds the
    /// device's storage-binding limit.
    pub(super) fn upload(
        &self,
        device: &wgpu::Device,
        scene: &RenderScene,
    ) -> Result<TracedScene, GpuError> {
        let bvh = scene.bvh();
        let limit = device.limits().max_storage_buffer_binding_size;
        let buffer = |label, words: Vec<u32>| {
            let bytes = 4 * words.len() as u64;
            if bytes > limit {
                return Err(GpuError::Render(format!(
                    "the scene's {label} take {bytes} bytes, over the device's storage-buffer \
                     limit of {limit} bytes ({} triangles)",
                    bvh.triangle_count()
                )));
            }
            Ok(
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: bytemuck::cast_slice(&words),
                    usage: wgpu::BufferUsages::STORAGE,
                }),
            )
        };
        let nodes = buffer("BVH nodes", bvh.flat_nodes())?;
        let leaves = buffer("BVH leaves", bvh.flat_leaves())?;
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("trace scene"),
            layout: &self.scene_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: nodes.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: leaves.as_entire_binding(),
                },
            ],
        });
        // At most three entries are pushed per level of the path being visited.
        let fallback = (3 * bvh.depth() > self.stack).then(|| bvh.clone());
        let derive = match self.deriver.upload(device, scene) {
            Ok(d) => Some(d),
            Err(e) => {
                tracing::warn!(
                    "{}: its images are derived on the CPU",
                    crate::escape::error_line(&e)
                );
                None
            }
        };
        Ok(TracedScene {
            bind,
            fallback,
            derive,
        })
    }

    /// Renders views of one resolution `w` × `h` (both non-zero) on uploaded `scenes`, with
    /// the images of `channels` derived on the GPU (where every scene of the batch has its
    /// attributes uploaded), read back with the ids and depth where `ids` (else alone,
    /// [`Frame::derived_only`]): as many views per submission as the output buffer's binding
    /// limit allows.
    pub(super) fn render(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scenes: &[&TracedScene],
        views: &[View],
        (w, h): (u32, u32),
        (channels, ids): (Channels, bool),
    ) -> Result<Vec<Frame>, GpuError> {
        let channels = if views.iter().all(|v| scenes[v.scene.0].derive.is_some()) {
            channels
        } else {
            Channels::NONE
        };
        // Without images to derive, the frames are the ids and depth.
        let ids = ids || channels.is_empty();
        let frame_bytes =
            4 * derive::words_per_pixel(channels) as u64 * u64::from(w) * u64::from(h) + 4;
        let limits = device.limits();
        let per_submission = (limits.max_storage_buffer_binding_size / frame_bytes)
            .min(u64::from(limits.max_compute_workgroups_per_dimension))
            .max(1) as usize;
        let mut frames = Vec::with_capacity(views.len());
        for chunk in views.chunks(per_submission) {
            let size = ((w, h), per_submission);
            let what = (channels, ids);
            frames.extend(self.render_chunk(device, queue, scenes, chunk, size, what)?);
        }
        Ok(frames)
    }

    /// One submission (of at most `max_views` views): a trace dispatch per scene, a
    /// derivation dispatch per scene where `channels` asks for images, one copy back — of the
    /// ids and depth too where `ids` (else only of the derived images and the views' overflow
    /// flags; a view whose rays overflowed then has its ids and depth copied back in a second
    /// submission, to be cast again and derived on the host).
    fn render_chunk(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scenes: &[&TracedScene],
        views: &[View],
        ((w, h), max_views): ((u32, u32), usize),
        (channels, ids): (Channels, bool),
    ) -> Result<Vec<Frame>, GpuError> {
        let n = views.len();
        let pixels = w as usize * h as usize;
        let (at, derived_words) = derive::layout(channels, n, pixels);
        // The overflow flags follow the derived images.
        let (flags_at, out_words) = (derived_words, derived_words + n);
        // Views sorted by scene (stably), so each scene's views are one dispatch.
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by_key(|&i| views[i].scene.0);
        let records: Vec<ViewRecord> = order
            .iter()
            .map(|&i| view_record(&views[i], i as u32))
            .collect();
        let mut groups: Vec<(usize, u32, u32)> = Vec::new(); // (scene, first, count)
        for (k, &i) in order.iter().enumerate() {
            match groups.last_mut() {
                Some((s, _, count)) if *s == views[i].scene.0 => *count += 1,
                _ => groups.push((views[i].scene.0, k as u32, 1)),
            }
        }
        let mut uniforms = vec![0u8; groups.len() * BATCH_STRIDE as usize];
        for (g, &(_, first, _)) in groups.iter().enumerate() {
            let record = BatchRecord {
                first,
                total: n as u32,
                width: w,
                height: h,
                flags: flags_at as u32,
                pad: [0; 3],
            };
            let at = g * BATCH_STRIDE as usize;
            uniforms[at..at + std::mem::size_of::<BatchRecord>()]
                .copy_from_slice(bytemuck::bytes_of(&record));
        }
        let out_bytes = (out_words * 4) as u64;
        let need = Room {
            views: n,
            bytes: out_bytes,
            groups: groups.len(),
        };
        let (room, set) = self.buffers(device, need, max_views);
        queue.write_buffer(&set.views, 0, bytemuck::cast_slice(&records));
        queue.write_buffer(&set.uniform, 0, &uniforms);
        if !channels.is_empty() {
            let mut blocks = vec![0u8; groups.len() * BATCH_STRIDE as usize];
            for (g, &(_, first, _)) in groups.iter().enumerate() {
                let record = derive::record(first, n as u32, (w, h), at);
                let at = g * BATCH_STRIDE as usize;
                blocks[at..at + std::mem::size_of::<derive::DeriveRecord>()]
                    .copy_from_slice(bytemuck::bytes_of(&record));
            }
            queue.write_buffer(&set.derive_uniform, 0, &blocks);
        }
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("trace"),
        });
        let word = |k: usize| (k * 4) as u64;
        encoder.clear_buffer(&set.out, word(flags_at), Some(word(n)));
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("trace"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            for (g, &(scene, _, count)) in groups.iter().enumerate() {
                pass.set_bind_group(0, &scenes[scene].bind, &[]);
                pass.set_bind_group(1, &set.bind, &[(g as u64 * BATCH_STRIDE) as u32]);
                pass.dispatch_workgroups(w.div_ceil(TILE), h.div_ceil(TILE), count);
            }
            if !channels.is_empty() {
                pass.set_pipeline(&self.deriver.pipeline);
                for (g, &(scene, _, count)) in groups.iter().enumerate() {
                    let Some(derived) = &scenes[scene].derive else {
                        continue;
                    };
                    pass.set_bind_group(0, &derived.bind, &[]);
                    pass.set_bind_group(1, &set.derive_bind, &[(g as u64 * BATCH_STRIDE) as u32]);
                    pass.dispatch_workgroups(w.div_ceil(TILE), h.div_ceil(TILE), count);
                }
            }
        }
        // What comes back: everything, or from the derived images on (the ids and depth,
        // the first two words a pixel, left on the GPU).
        let base = if ids { 0 } else { 2 * n * pixels };
        let back = word(out_words - base);
        encoder.copy_buffer_to_buffer(&set.out, word(base), &set.readback, 0, back);
        let submitted = std::time::Instant::now();
        queue.submit([encoder.finish()]);
        let slice = set.readback.slice(..back);
        let data = super::map_read(device, &slice)?;
        let mapped = std::time::Instant::now();
        let words: &[u32] = bytemuck::cast_slice(&data);
        // Views whose rays overflowed: the host casts them again and derives their images
        // itself, so the GPU's (made from overflow markers) are not unpacked.
        let overflowed: Vec<usize> = (0..n)
            .filter(|&i| words[flags_at - base + i] != 0)
            .collect();
        // The derived images' offsets in what came back.
        let at_back = at.map(|a| {
            if a == derive::EMPTY {
                a
            } else {
                a - base as u32
            }
        });
        let mut frames: Vec<Frame> = (0..n)
            .into_par_iter()
            .map(|i| {
                let derived = (!channels.is_empty() && overflowed.binary_search(&i).is_err())
                    .then(|| Box::new(derive::unpack(words, channels, &at_back, i, pixels)));
                if !ids {
                    return Frame::derived_only(w, h, derived);
                }
                let mut frame = Frame::new(w, h);
                frame
                    .tri
                    .copy_from_slice(&words[i * pixels..(i + 1) * pixels]);
                let depths = &words[(n + i) * pixels..(n + i + 1) * pixels];
                for (d, b) in frame.depth.iter_mut().zip(depths) {
                    *d = f32::from_bits(*b);
                }
                frame.derived = derived;
                frame
            })
            .collect();
        drop(data);
        set.readback.unmap();
        let unpacked = mapped.elapsed();
        if !ids && !overflowed.is_empty() {
            // Those views' ids and depth, from the output still on the GPU.
            let (ids_of, depth_of) = self.read_ids(device, queue, &set, n, pixels, &overflowed)?;
            for (k, &i) in overflowed.iter().enumerate() {
                let frame = &mut frames[i];
                frame.tri = ids_of[k * pixels..(k + 1) * pixels].to_vec();
                frame.depth = depth_of[k * pixels..(k + 1) * pixels]
                    .iter()
                    .map(|b| f32::from_bits(*b))
                    .collect();
            }
        }
        self.give_back(room, set);
        let nanos = |d: std::time::Duration| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX);
        let relaxed = std::sync::atomic::Ordering::Relaxed;
        // The overflowed views' second copy counts as waiting for the GPU.
        let waited = submitted.elapsed().saturating_sub(unpacked);
        self.waited_ns.fetch_add(nanos(waited), relaxed);
        self.unpacked_ns.fetch_add(nanos(unpacked), relaxed);
        // In parallel: a view whose rays overflowed is cast again on the host, and the
        // lockstep of a batched rollout waits for the slowest of them.
        frames
            .into_par_iter()
            .zip(views)
            .enumerate()
            .map(|(i, (mut frame, view))| {
                if overflowed.binary_search(&i).is_ok() {
                    // The host casts those rays and derives this view's images itself.
                    let bvh = scenes[view.scene.0].fallback.as_ref().ok_or_else(|| {
                        GpuError::Render(
                            "a ray overflowed the traversal stack of a shallow tree".into(),
                        )
                    })?;
                    recast_overflowed(bvh, &view.camera, &mut frame);
                }
                Ok(frame)
            })
            .collect()
    }

    /// The ids and depth of the views `which` (ascending) of a batch of `n` views still in
    /// `set`'s output, copied back in one more submission: `which.len()` views' ids, then
    /// their depth words.
    fn read_ids(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        set: &BufferSet,
        n: usize,
        pixels: usize,
        which: &[usize],
    ) -> Result<(Vec<u32>, Vec<u32>), GpuError> {
        let word = |k: usize| (k * 4) as u64;
        let bytes = word(2 * which.len() * pixels);
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("trace overflow read-back"),
            size: bytes,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("trace overflow"),
        });
        let m = which.len();
        for (k, &i) in which.iter().enumerate() {
            let (ids, depth) = (i * pixels, (n + i) * pixels);
            encoder.copy_buffer_to_buffer(
                &set.out,
                word(ids),
                &readback,
                word(k * pixels),
                word(pixels),
            );
            let to = word((m + k) * pixels);
            encoder.copy_buffer_to_buffer(&set.out, word(depth), &readback, to, word(pixels));
        }
        queue.submit([encoder.finish()]);
        let slice = readback.slice(..);
        let data = super::map_read(device, &slice)?;
        let words: &[u32] = bytemuck::cast_slice(&data);
        let out = (words[..m * pixels].to_vec(), words[m * pixels..].to_vec());
        drop(data);
        readback.unmap();
        Ok(out)
    }
}

/// The shader's record of `view`, output slot `slot`.
/// The bind group of a batch's dispatches, for the trace pass and the derive pass alike:
/// the view records (binding 0), the output buffer (1) and one `record`-sized block of the
/// per-dispatch uniform buffer (2, bound with a dynamic offset).
fn batch_bind_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    [views, out]: [&wgpu::Buffer; 2],
    uniform: &wgpu::Buffer,
    record: usize,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: views.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: out.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: uniform,
                    offset: 0,
                    size: wgpu::BufferSize::new(record as u64),
                }),
            },
        ],
    })
}

fn view_record(view: &View, slot: u32) -> ViewRecord {
    let c = &view.camera;
    let b = RayBasis::new(c, c.width, c.height);
    let p = c.projection();
    let v4 = |v: glam::Vec3| [v.x, v.y, v.z, 0.0];
    ViewRecord {
        origin: v4(c.position),
        right: v4(b.right),
        up: v4(b.up),
        forward: v4(b.forward),
        lens: [c.near, c.far, b.tan, b.aspect],
        depth: [p.z_axis.z, p.w_axis.z, 0.0, 0.0],
        slot: [slot, 0, 0, 0],
    }
}

/// Casts the pixels marked [`OVERFLOW`] again on the CPU (the single-ray traversal, whose
/// stack has no such limit), as the CPU ray caster would.
fn recast_overflowed(bvh: &Bvh, camera: &crate::render::Camera, frame: &mut Frame) {
    let (w, h) = (frame.width, frame.height);
    let rays = PixelRays::new(camera, w, h);
    let p = camera.projection();
    let (a, b) = (p.z_axis.z, p.w_axis.z);
    for y in 0..h as usize {
        for x in 0..w as usize {
            let i = y * w as usize + x;
            if frame.tri[i] != OVERFLOW {
                continue;
            }
            let ray = Ray::new(camera.position, rays.dir(x, y), camera.near, camera.far);
            match bvh.closest(&ray, None) {
                Some(hit) => {
                    frame.tri[i] = hit.tri;
                    frame.depth[i] = ((b - a * hit.t) / hit.t).clamp(0.0, 1.0);
                }
                None => {
                    frame.tri[i] = NO_HIT;
                    frame.depth[i] = 1.0;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shader_declares_the_stack_size_the_host_assumes() {
        assert!(SHADER.contains(&format!("const STACK: u32 = {STACK}u;")));
        assert!(SHADER.contains(&format!("const OVERFLOW: u32 = 0x{OVERFLOW:x}u;")));
        assert!(SHADER.contains(&format!("@workgroup_size({TILE}, {TILE}, 1)")));
        assert_eq!(std::mem::size_of::<ViewRecord>(), 7 * 16);
    }
}
