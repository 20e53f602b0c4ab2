//! A rendered frame (triangle id and depth per pixel) and the images derived from it: colour,
//! linear depth, normals, semantic class, instance, room. Every renderer produces the same
//! [`Frame`]; everything else is computed here, identically for all of them.

use glam::Vec3;

use super::camera::Camera;
use super::derived::{taxonomy_slot, Derived};
use super::scene::RenderScene;
use crate::prefetch::prefetch;
use crate::scene::Taxonomy;

/// Pixel shows no triangle.
pub const NO_HIT: u32 = u32::MAX;

/// Direction towards the light (world, normalised at use).
pub(crate) const LIGHT: [f32; 3] = [0.35, 1.0, 0.55];
/// Ambient share of the shading.
pub(crate) const AMBIENT: f32 = 0.35;

/// How many pixels ahead [`Frame::color`] asks for a triangle's record: a frame's pixels
/// show triangles scattered over the scene's arrays, and each would otherwise wait on memory
/// in turn.
const PREFETCH_AHEAD: usize = 16;

/// World directions of the rays through pixel centres, split into a per-column and a
/// per-row part (the same camera model the rasterisers sample).
pub(super) struct PixelRays {
    columns: Vec<Vec3>,
    rows: Vec<Vec3>,
}

/// A camera's ray basis at an image size: the world right, up and viewing directions and the
/// lens's extent, from which [`PixelRays`] (and the GPU ray tracer, with the same formula) make
/// each pixel centre's ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct RayBasis {
    /// World direction of the image's +x.
    pub right: Vec3,
    /// World direction of the image's up.
    pub up: Vec3,
    /// World viewing direction (unit).
    pub forward: Vec3,
    /// `tan(vfov / 2)`.
    pub tan: f32,
    /// Width over height.
    pub aspect: f32,
}

impl RayBasis {
    /// The basis of `camera` at `width` × `height`.
    pub(crate) fn new(camera: &Camera, width: u32, height: u32) -> Self {
        let to_world = camera.view().inverse();
        RayBasis {
            right: to_world.transform_vector3(Vec3::X),
            up: to_world.transform_vector3(Vec3::Y),
            forward: to_world.transform_vector3(Vec3::NEG_Z),
            tan: (camera.vfov_deg.to_radians() * 0.5).tan(),
            aspect: width as f32 / height.max(1) as f32,
        }
    }
}

impl PixelRays {
    /// The rays of `camera`'s pixels at `width` × `height`; each direction's component
    /// along the viewing axis is 1, so a ray parameter is a camera-space depth.
    pub(super) fn new(camera: &Camera, width: u32, height: u32) -> Self {
        let RayBasis {
            right,
            up,
            forward,
            tan,
            aspect,
        } = RayBasis::new(camera, width, height);
        let columns = (0..width)
            .map(|x| right * (((x as f32 + 0.5) / width as f32 * 2.0 - 1.0) * tan * aspect))
            .collect();
        let rows = (0..height)
            .map(|y| forward + up * ((1.0 - (y as f32 + 0.5) / height as f32 * 2.0) * tan))
            .collect();
        PixelRays { columns, rows }
    }

    /// The (not normalised) direction through pixel (x, y).
    #[inline]
    pub(super) fn dir(&self, x: usize, y: usize) -> Vec3 {
        self.columns[x] + self.rows[y]
    }
}

/// Triangle ids and depth-buffer values of one camera image, row-major from the top left.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Triangle index per pixel ([`NO_HIT`] when none).
    pub tri: Vec<u32>,
    /// Depth-buffer value per pixel in [0, 1] (1 when no hit).
    pub depth: Vec<f32>,
    /// Images the renderer derived itself (the GPU ray tracer, when asked); the methods
    /// below return them where present and derive on the CPU otherwise.
    pub derived: Option<Box<Derived>>,
}

impl Frame {
    /// An empty frame.
    pub fn new(width: u32, height: u32) -> Self {
        let n = (width * height) as usize;
        Frame {
            width,
            height,
            tri: vec![NO_HIT; n],
            depth: vec![1.0; n],
            derived: None,
        }
    }

    /// A frame of only the images a renderer derived (`derived`), without triangle ids or
    /// depth (`tri` and `depth` empty): what a batch that asked for exactly the images its
    /// callers use reads back. Its methods answer for the derived images only; the others
    /// come back empty.
    pub fn derived_only(width: u32, height: u32, derived: Option<Box<Derived>>) -> Self {
        Frame {
            width,
            height,
            tri: Vec::new(),
            depth: Vec::new(),
            derived,
        }
    }

    /// Whether the frame carries triangle ids and depth (not [`Frame::derived_only`]).
    pub fn has_ids(&self) -> bool {
        self.tri.len() == (self.width * self.height) as usize
    }

    /// The renderer's image `pick` chooses, where it derived one.
    fn derived_image<'a, T>(
        &'a self,
        pick: impl Fn(&'a Derived) -> &'a Option<T>,
    ) -> Option<&'a T> {
        self.derived.as_deref().and_then(|d| pick(d).as_ref())
    }

    /// Shaded RGB colour: the material colour, times the texture where the triangle has one
    /// (bilinear, coordinates exact at the pixel centre's ray), with one directional light
    /// plus ambient (both faces lit alike). Black where nothing is hit.
    pub fn color(&self, scene: &RenderScene, camera: &Camera) -> Vec<[u8; 3]> {
        if let Some(c) = self.derived_image(|d| &d.color) {
            return c.clone();
        }
        let light = Vec3::from_array(LIGHT).normalize();
        let rays =
            (!scene.textures.is_empty()).then(|| PixelRays::new(camera, self.width, self.height));
        let width = self.width.max(1) as usize;
        let mut out = Vec::with_capacity(self.tri.len());
        for (y, row) in self.tri.chunks(width).enumerate() {
            for (x, &t) in row.iter().enumerate() {
                if let Some(&ahead) = self.tri.get(y * width + x + PREFETCH_AHEAD) {
                    prefetch(&scene.tris, ahead as usize);
                }
                if t == NO_HIT {
                    out.push([0, 0, 0]);
                    continue;
                }
                let info = &scene.tris[t as usize];
                let normal = Vec3::from_array(info.normal);
                let shade = AMBIENT + (1.0 - AMBIENT) * normal.dot(light).abs();
                let mut rgb = info.color;
                if let (Some(tex), Some(rays)) = (scene.textures.get(info.texture as usize), &rays)
                {
                    let dir = rays.dir(x, y);
                    let [u, v] = scene.uv_maps[t as usize].at(camera.position, dir, normal);
                    let s = tex.sample(u, v);
                    rgb = [rgb[0] * s[0], rgb[1] * s[1], rgb[2] * s[2]];
                }
                // + 0.5 and truncate: rounding without a library call (values are ≥ 0).
                out.push(rgb.map(|c| ((c * shade).clamp(0.0, 1.0) * 255.0 + 0.5) as u8));
            }
        }
        out
    }

    /// Linear depth in metres along the viewing axis (0 where nothing is hit).
    pub fn linear_depth(&self, camera: &Camera) -> Vec<f32> {
        if let Some(d) = self.derived_image(|d| &d.linear_depth) {
            return d.clone();
        }
        self.tri
            .iter()
            .zip(&self.depth)
            .map(|(&t, &z)| {
                if t == NO_HIT {
                    0.0
                } else {
                    camera.linear_depth(z)
                }
            })
            .collect()
    }

    /// World-space unit normals (zero where nothing is hit).
    pub fn normals(&self, scene: &RenderScene) -> Vec<[f32; 3]> {
        if let Some(n) = self.derived_image(|d| &d.normals) {
            return n.clone();
        }
        self.tri
            .iter()
            .map(|&t| {
                if t == NO_HIT {
                    [0.0; 3]
                } else {
                    scene.tris[t as usize].normal
                }
            })
            .collect()
    }

    /// Semantic class per pixel in `taxonomy` (0 = void).
    pub fn semantic(&self, scene: &RenderScene, taxonomy: Taxonomy) -> Vec<u16> {
        if let Some(s) = self.derived_image(|d| &d.semantic[taxonomy_slot(taxonomy)]) {
            return s.clone();
        }
        self.tri
            .iter()
            .map(|&t| match (t, taxonomy) {
                (NO_HIT, _) => 0,
                (t, Taxonomy::Nyu40) => scene.tris[t as usize].nyu40,
                (t, Taxonomy::Mpcat40) => scene.tris[t as usize].mpcat40,
                (t, Taxonomy::Coarse) => scene.tris[t as usize].coarse,
            })
            .collect()
    }

    /// Object instance per pixel (object index + 1; 0 for architecture and background).
    pub fn instance(&self, scene: &RenderScene) -> Vec<u32> {
        if let Some(i) = self.derived_image(|d| &d.instance) {
            return i.clone();
        }
        self.tri
            .iter()
            .map(|&t| {
                if t == NO_HIT {
                    0
                } else {
                    scene.tris[t as usize].object
                }
            })
            .collect()
    }

    /// Room per pixel (room index + 1; 0 outside rooms).
    pub fn room(&self, scene: &RenderScene) -> Vec<u32> {
        if let Some(r) = self.derived_image(|d| &d.room) {
            return r.clone();
        }
        self.tri
            .iter()
            .map(|&t| {
                if t == NO_HIT {
                    0
                } else {
                    scene.tris[t as usize].room
                }
            })
            .collect()
    }

    /// MINOS room class per pixel (0 also for none).
    pub fn room_class(&self, scene: &RenderScene) -> Vec<u8> {
        if let Some(r) = self.derived_image(|d| &d.room_class) {
            return r.clone();
        }
        self.tri
            .iter()
            .map(|&t| {
                if t == NO_HIT {
                    0
                } else {
                    scene.tris[t as usize].room_class
                }
            })
            .collect()
    }
}
