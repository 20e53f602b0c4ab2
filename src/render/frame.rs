//! A rendered frame (triangle id and depth per pixel) and the images derived from it: colour,
//! linear depth, normals, semantic class, instance, room. Every renderer produces the same
//! [`Frame`]; everything else is computed here, identically for all of them.

use glam::Vec3;

use super::camera::Camera;
use super::labels::Taxonomy;
use super::scene::RenderScene;

/// Pixel shows no triangle.
pub const NO_HIT: u32 = u32::MAX;

/// Direction towards the light (world, normalised at use).
const LIGHT: [f32; 3] = [0.35, 1.0, 0.55];
/// Ambient share of the shading.
const AMBIENT: f32 = 0.35;

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
        }
    }

    /// Shaded RGB colour (flat material colour, one directional light plus ambient; both
    /// faces lit alike). Black where nothing is hit.
    pub fn color(&self, scene: &RenderScene) -> Vec<[u8; 3]> {
        let light = Vec3::from_array(LIGHT).normalize();
        self.tri
            .iter()
            .map(|&t| {
                if t == NO_HIT {
                    return [0, 0, 0];
                }
                let info = &scene.tris[t as usize];
                let shade =
                    AMBIENT + (1.0 - AMBIENT) * Vec3::from_array(info.normal).dot(light).abs();
                info.color
                    .map(|c| ((c * shade).clamp(0.0, 1.0) * 255.0).round() as u8)
            })
            .collect()
    }

    /// Linear depth in metres along the viewing axis (0 where nothing is hit).
    pub fn linear_depth(&self, camera: &Camera) -> Vec<f32> {
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
        self.tri
            .iter()
            .map(|&t| match (t, taxonomy) {
                (NO_HIT, _) => 0,
                (t, Taxonomy::Nyu40) => scene.tris[t as usize].nyu40,
                (t, Taxonomy::Mpcat40) => scene.tris[t as usize].mpcat40,
            })
            .collect()
    }

    /// Object instance per pixel (object index + 1; 0 for architecture and background).
    pub fn instance(&self, scene: &RenderScene) -> Vec<u32> {
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
