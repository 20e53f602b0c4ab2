//! The wgpu renderer: offscreen, headless (no surface or window), on any adapter wgpu finds —
//! a GPU, or lavapipe on a CPU. It writes, per pixel, the triangle id and the depth-buffer
//! value; the images are then derived exactly as for the CPU renderer ([`Frame`]'s methods).
//! Two methods ([`GpuMethod`]): ray tracing in a compute shader over the BVH the CPU ray caster
//! builds (`trace.rs`, the default: its cost follows the pixels), or rasterising every triangle
//! of the scene per view (`raster.rs`: its cost follows the triangles). Several scenes can be
//! uploaded side by side, and a batch of views — each a camera on one of them, all of one
//! resolution — renders with one command encoder, one submission and one read-back; batches
//! larger than the device's buffer or texture limits are split into as few submissions as fit.
//! The ray tracer can also derive a batch's images (colour, linear depth, normals, labels) in a
//! second compute pass (`derive.rs`), so they are read back finished ([`Channels`]).

mod derive;
mod pool;
mod raster;
mod trace;

use super::camera::Camera;
use super::derived::Channels;
use super::frame::Frame;
use super::scene::RenderScene;

/// Why the GPU renderer is unavailable or failed.
#[derive(Debug, Clone, thiserror::Error)]
pub enum GpuError {
    /// No adapter (install `mesa-vulkan-drivers` for lavapipe, or use the CPU renderer).
    #[error("no GPU adapter found (the CPU renderer works without one)")]
    NoAdapter(#[source] wgpu::RequestAdapterError),
    /// The device could not be created.
    #[error("GPU device")]
    Device(#[source] wgpu::RequestDeviceError),
    /// Rendering failed: what the renderer found wrong.
    #[error("GPU render: {0}")]
    Render(String),
    /// Reading rendered images back failed (waiting for the GPU, or mapping the buffer).
    #[error("GPU read-back")]
    ReadBack(#[source] std::sync::Arc<dyn std::error::Error + Send + Sync>),
}

/// A read-back failure with its cause kept as the error's source.
fn read_back(e: impl std::error::Error + Send + Sync + 'static) -> GpuError {
    GpuError::ReadBack(std::sync::Arc::new(e))
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

/// How the GPU renders a view.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GpuMethod {
    /// A compute shader casts one ray per pixel through the scene's BVH.
    #[default]
    RayTrace,
    /// The rasteriser draws every triangle of the scene into each view.
    Rasterise,
}

impl GpuMethod {
    /// `ray-trace` or `rasterise`.
    pub fn name(self) -> &'static str {
        match self {
            GpuMethod::RayTrace => "ray-trace",
            GpuMethod::Rasterise => "rasterise",
        }
    }
}

/// The method's pipeline.
enum Pipeline {
    Trace(trace::Tracer),
    Raster(raster::Raster),
}

/// An uploaded scene, as its method needs it.
enum Uploaded {
    Trace(trace::TracedScene),
    Raster(raster::RasterScene),
}

/// A wgpu device with the chosen method's pipeline and the uploaded scenes.
pub struct GpuRenderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipeline: Pipeline,
    adapter: wgpu::AdapterInfo,
    /// The uploaded scenes, by [`SceneSlot`].
    scenes: Vec<Uploaded>,
    /// Whether simulators observing through this renderer have their images derived on the
    /// GPU ([`GpuRenderer::derives_images`]).
    derive_images: bool,
}

/// The environment variable that, set to `0`, makes simulators derive images from a GPU
/// renderer's ids and depth on the host instead of on the GPU (to measure the difference).
pub const DERIVE_ENV: &str = "MINOS_GPU_DERIVE";

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
    /// honoured) and builds the ray-tracing pipeline.
    pub fn new() -> Result<Self, GpuError> {
        Self::with_method(GpuMethod::default())
    }

    /// [`GpuRenderer::new`] with the given method.
    pub fn with_method(method: GpuMethod) -> Result<Self, GpuError> {
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
        .map_err(GpuError::NoAdapter)?;
        let info = adapter.get_info();
        let supported = adapter.limits();
        // Scenes of millions of triangles and batches of thousands of views need the
        // adapter's whole buffer range, not the portable 128 MiB.
        let required_limits = wgpu::Limits {
            max_storage_buffer_binding_size: supported.max_storage_buffer_binding_size,
            max_buffer_size: supported.max_buffer_size,
            ..wgpu::Limits::downlevel_defaults().using_resolution(supported)
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("minos"),
            required_features: wgpu::Features::empty(),
            required_limits,
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(GpuError::Device)?;
        let pipeline = match method {
            GpuMethod::RayTrace => Pipeline::Trace(trace::Tracer::new(&device)),
            GpuMethod::Rasterise => Pipeline::Raster(raster::Raster::new(&device)),
        };
        Ok(GpuRenderer {
            device,
            queue,
            pipeline,
            adapter: info,
            scenes: Vec::new(),
            derive_images: std::env::var_os(DERIVE_ENV).is_none_or(|v| v != "0"),
        })
    }

    /// The method this renderer uses.
    pub fn method(&self) -> GpuMethod {
        match self.pipeline {
            Pipeline::Trace(_) => GpuMethod::RayTrace,
            Pipeline::Raster(_) => GpuMethod::Rasterise,
        }
    }

    /// Whether simulators observing through this renderer ask it for finished images (the
    /// default with the ray-tracing method; off with `MINOS_GPU_DERIVE=0` or
    /// [`GpuRenderer::set_derives_images`]). The rasterising method never derives.
    pub fn derives_images(&self) -> bool {
        self.derive_images && self.method() == GpuMethod::RayTrace
    }

    /// Turns deriving images on the GPU for simulators on or off.
    pub fn set_derives_images(&mut self, on: bool) {
        self.derive_images = on;
    }

    /// Whether the adapter is a software one (lavapipe, WARP, SwiftShader: the CPU).
    pub fn is_software(&self) -> bool {
        self.adapter.device_type == wgpu::DeviceType::Cpu
    }

    /// Wall-clock time the ray tracer's batches spent from submission until their read-back
    /// was mapped (the GPU's work and the copy to host memory), and unpacking their frames,
    /// summed since the renderer was made (zero for the rasteriser).
    pub fn read_back_times(&self) -> (std::time::Duration, std::time::Duration) {
        match &self.pipeline {
            Pipeline::Trace(t) => t.times(),
            Pipeline::Raster(_) => Default::default(),
        }
    }

    /// "name (backend, device type)" of the adapter in use.
    pub fn adapter_name(&self) -> String {
        format!(
            "{} ({:?}, {:?})",
            self.adapter.name, self.adapter.backend, self.adapter.device_type
        )
    }

    /// Uploads the scene, replacing every scene uploaded before; it becomes `SceneSlot(0)`,
    /// the scene [`GpuRenderer::render_batch`] renders.
    pub fn upload(&mut self, scene: &RenderScene) -> Result<(), GpuError> {
        self.scenes.clear();
        self.add_scene(scene).map(|_| ())
    }

    /// Uploads one more scene beside those already uploaded and returns its slot (ray
    /// tracing builds the scene's BVH first, if it is not built yet). Fails when the scene
    /// does not fit the device's buffer limits.
    pub fn add_scene(&mut self, scene: &RenderScene) -> Result<SceneSlot, GpuError> {
        let uploaded = match &self.pipeline {
            Pipeline::Trace(t) => Uploaded::Trace(t.upload(&self.device, scene)?),
            Pipeline::Raster(_) => Uploaded::Raster(raster::Raster::upload(&self.device, scene)),
        };
        self.scenes.push(uploaded);
        Ok(SceneSlot(self.scenes.len() - 1))
    }

    /// Number of uploaded scenes.
    pub fn scene_count(&self) -> usize {
        self.scenes.len()
    }

    /// Renders cameras of one resolution on the scene of [`GpuRenderer::upload`] (slot 0)
    /// in one submission. Frames come back in camera order.
    pub fn render_batch(&self, cameras: &[Camera]) -> Result<Vec<Frame>, GpuError> {
        self.render_batch_with(cameras, Channels::NONE)
    }

    /// [`GpuRenderer::render_batch`] with the images of `channels` derived on the GPU
    /// ([`GpuRenderer::render_views_with`]).
    pub fn render_batch_with(
        &self,
        cameras: &[Camera],
        channels: Channels,
    ) -> Result<Vec<Frame>, GpuError> {
        self.render_views_with(&first_scene_views(cameras), channels)
    }

    /// [`GpuRenderer::render_batch_with`] reading back only the derived images
    /// ([`GpuRenderer::render_views_derived`]).
    pub fn render_batch_derived(
        &self,
        cameras: &[Camera],
        channels: Channels,
    ) -> Result<Vec<Frame>, GpuError> {
        self.render_views_derived(&first_scene_views(cameras), channels)
    }

    /// Renders views (cameras on any uploaded scenes, one resolution) with one command
    /// encoder, one submission and one read-back (more only where a batch exceeds the
    /// device's limits); frames come back in view order, each frame's triangle ids those of
    /// its own scene.
    pub fn render_views(&self, views: &[View]) -> Result<Vec<Frame>, GpuError> {
        self.render_views_with(views, Channels::NONE)
    }

    /// [`GpuRenderer::render_views`], each frame also carrying the images of `channels`
    /// derived on the GPU in the same submission and read back with the ids and depth
    /// ([`Frame::derived`]; the ray-tracing method only — the rasteriser's frames carry none,
    /// and neither does a view whose rays the host cast again: [`Frame`]'s methods then
    /// derive on the CPU).
    pub fn render_views_with(
        &self,
        views: &[View],
        channels: Channels,
    ) -> Result<Vec<Frame>, GpuError> {
        self.render_views_as(views, channels, true)
    }

    /// [`GpuRenderer::render_views_with`] reading back only the images of `channels` where
    /// the GPU derives them (less to copy back and unpack): each frame is then
    /// [`Frame::derived_only`] — no ids or depth, so only its derived images may be asked
    /// for —, except a view whose rays the host cast again, which comes back whole with no
    /// derived images. Without images to derive (the rasteriser, `channels` empty, derivation
    /// off) the frames are whole, as [`GpuRenderer::render_views_with`]'s.
    pub fn render_views_derived(
        &self,
        views: &[View],
        channels: Channels,
    ) -> Result<Vec<Frame>, GpuError> {
        self.render_views_as(views, channels, false)
    }

    fn render_views_as(
        &self,
        views: &[View],
        channels: Channels,
        ids: bool,
    ) -> Result<Vec<Frame>, GpuError> {
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
        if w == 0 || h == 0 {
            return Ok(views.iter().map(|_| Frame::new(w, h)).collect());
        }
        let (device, queue) = (&self.device, &self.queue);
        match &self.pipeline {
            Pipeline::Trace(t) => {
                let scenes: Vec<&trace::TracedScene> = self
                    .scenes
                    .iter()
                    .filter_map(|s| match s {
                        Uploaded::Trace(s) => Some(s),
                        Uploaded::Raster(_) => None,
                    })
                    .collect();
                t.render(device, queue, &scenes, views, (w, h), (channels, ids))
            }
            Pipeline::Raster(r) => {
                let scenes: Vec<&raster::RasterScene> = self
                    .scenes
                    .iter()
                    .filter_map(|s| match s {
                        Uploaded::Raster(s) => Some(s),
                        Uploaded::Trace(_) => None,
                    })
                    .collect();
                r.render(device, queue, &scenes, views, (w, h))
            }
        }
    }
}

/// Views of `cameras` on the scene of [`GpuRenderer::upload`] (slot 0).
fn first_scene_views(cameras: &[Camera]) -> Vec<View> {
    cameras
        .iter()
        .map(|&camera| View {
            scene: SceneSlot(0),
            camera,
        })
        .collect()
}

/// Maps a read-back buffer's `slice` for reading, waiting for the GPU work before it.
fn map_read(
    device: &wgpu::Device,
    slice: &wgpu::BufferSlice<'_>,
) -> Result<wgpu::BufferView, GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(read_back)?;
    rx.recv().map_err(read_back)?.map_err(read_back)?;
    slice.get_mapped_range().map_err(read_back)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::raycast;
    use glam::Vec3;

    /// Rays whose traversal stack overflows are cast again on the CPU, so the frame is still
    /// the nearest hit: a tracer with a four-entry stack on a scene of thousands of
    /// triangles overflows on most pixels and still agrees with the CPU ray caster.
    #[test]
    fn overflowed_rays_are_cast_again_on_the_cpu() {
        let mut gpu = match GpuRenderer::new() {
            Ok(g) => g,
            Err(e) => {
                eprintln!("skipped: {e}");
                return;
            }
        };
        gpu.pipeline = Pipeline::Trace(trace::Tracer::with_stack(&gpu.device, 4));
        let mut rng = crate::seed::Rng::new(5);
        let mut r = || rng.range_f64(-1.0, 1.0) as f32;
        let mut scene = RenderScene::default();
        for _ in 0..4000 {
            let c = Vec3::new(r() * 4.0, r() * 2.0, -6.0 + r() * 4.0);
            for _ in 0..3 {
                scene.positions.push(c + Vec3::new(r(), r(), r()) * 0.4);
            }
        }
        assert!(3 * scene.bvh().depth() > 4, "deep enough to overflow");
        gpu.upload(&scene).unwrap();
        let cameras: Vec<Camera> = (0..3)
            .map(|k| Camera {
                position: Vec3::new(0.0, 0.0, 1.0),
                yaw: k as f32 * 0.2 - 0.2,
                tilt: 0.0,
                vfov_deg: 70.0,
                width: 48,
                height: 40,
                near: 0.05,
                far: 30.0,
            })
            .collect();
        let frames = gpu.render_batch(&cameras).unwrap();
        let (mut equal, mut total, mut hits) = (0, 0, 0);
        for (cam, f) in cameras.iter().zip(&frames) {
            let want = raycast::render(&scene, cam);
            assert!(!f.tri.contains(&0xffff_fffe), "no overflow marker is left");
            equal += f.tri.iter().zip(&want.tri).filter(|(a, b)| a == b).count();
            hits += want
                .tri
                .iter()
                .filter(|&&t| t != crate::render::NO_HIT)
                .count();
            total += f.tri.len();
        }
        assert!(hits > total / 2, "the cameras see the triangles");
        assert!(equal as f64 >= 0.995 * total as f64, "{equal} of {total}");
        // Asked for images, such views come back without the GPU's (which saw the overflow
        // marker), so the frame's methods derive them from the recast ids.
        let derived = gpu.render_batch_with(&cameras, Channels::all()).unwrap();
        for (f, d) in frames.iter().zip(&derived) {
            assert_eq!((&f.tri, &f.depth), (&d.tri, &d.depth));
            assert!(d.derived.is_none());
        }
        // Reading back only the derived images: the views that overflowed still come back
        // whole (their ids and depth fetched in a second copy, then cast again), while a
        // view facing away from the triangles — no overflow — comes back as its derived
        // images alone, equal to those of a whole read-back.
        let mut mixed = cameras.clone();
        mixed.insert(
            1,
            Camera {
                yaw: std::f32::consts::PI,
                ..cameras[0]
            },
        );
        let whole = gpu.render_batch_with(&mixed, Channels::all()).unwrap();
        let only = gpu.render_batch_derived(&mixed, Channels::all()).unwrap();
        assert!(whole[1].derived.is_some() && !only[1].has_ids());
        assert_eq!(only[1].derived, whole[1].derived);
        for (k, f) in [0, 2, 3].into_iter().zip(&frames) {
            assert!(only[k].has_ids() && only[k].derived.is_none(), "view {k}");
            assert_eq!(
                (&only[k].tri, &only[k].depth),
                (&f.tri, &f.depth),
                "view {k}"
            );
        }
    }

    /// Without overflows, frames read back as their derived images alone carry the same
    /// images as whole frames, and no ids or depth; without channels they are whole.
    #[test]
    fn derived_only_read_back_gives_the_same_images() {
        let mut gpu = match GpuRenderer::new() {
            Ok(g) => g,
            Err(e) => {
                eprintln!("skipped: {e}");
                return;
            }
        };
        let mut scene = RenderScene::default();
        for (i, c) in [Vec3::new(-1.0, 0.0, -4.0), Vec3::new(1.0, 0.5, -5.0)]
            .iter()
            .enumerate()
        {
            scene.positions.extend([*c, *c + Vec3::X, *c + Vec3::Y]);
            scene.tris.push(crate::render::scene::TriInfo {
                normal: [0.0, 0.0, 1.0],
                color: [0.8, 0.2 * i as f32, 0.1],
                texture: crate::render::scene::NO_TEXTURE,
                object: i as u32 + 1,
                room: 1,
                room_class: 2,
                nyu40: 5,
                mpcat40: 3,
                coarse: 4,
            });
        }
        gpu.upload(&scene).unwrap();
        let views: Vec<View> = (0..5)
            .map(|k| View {
                scene: SceneSlot(0),
                camera: Camera {
                    position: Vec3::new(0.1 * k as f32, 0.3, 0.0),
                    yaw: 0.05 * k as f32,
                    tilt: 0.0,
                    vfov_deg: 90.0,
                    width: 24,
                    height: 16,
                    near: 0.05,
                    far: 30.0,
                },
            })
            .collect();
        let channels = Channels::all();
        let whole = gpu.render_views_with(&views, channels).unwrap();
        let only = gpu.render_views_derived(&views, channels).unwrap();
        for (w, o) in whole.iter().zip(&only) {
            assert!(w.has_ids() && !o.has_ids());
            assert!(w.derived.is_some());
            assert_eq!(o.derived, w.derived);
            assert_eq!((o.width, o.height), (w.width, w.height));
        }
        assert!(whole
            .iter()
            .any(|f| f.tri.iter().any(|&t| t != crate::render::NO_HIT)));
        let plain = gpu.render_views_derived(&views, Channels::NONE).unwrap();
        for (w, p) in whole.iter().zip(&plain) {
            assert!(p.has_ids() && p.derived.is_none());
            assert_eq!((&p.tri, &p.depth), (&w.tri, &w.depth));
        }
    }

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
