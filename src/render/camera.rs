//! The camera model shared by every renderer: pose from the agent (position, yaw, tilt),
//! vertical field of view, resolution and clip planes; right-handed view, depth in [0, 1].

use glam::{Mat4, Vec3, Vec4};
use serde::{Deserialize, Serialize};

/// A pinhole camera.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Eye position (world).
    pub position: Vec3,
    /// Yaw (rad, counter-clockwise about +Y; 0 looks along −Z).
    pub yaw: f32,
    /// Tilt (rad, about the camera's +X; positive looks up).
    pub tilt: f32,
    /// Vertical field of view (degrees).
    pub vfov_deg: f32,
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// Near clip plane (m).
    pub near: f32,
    /// Far clip plane (m).
    pub far: f32,
}

impl Camera {
    /// Unit viewing direction.
    pub fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (st, ct) = self.tilt.sin_cos();
        Vec3::new(-sy * ct, st, -cy * ct)
    }

    /// World → camera.
    pub fn view(&self) -> Mat4 {
        let up = if self.forward().y.abs() > 0.999 {
            // Looking straight up or down: "up" is the yaw direction.
            let (sy, cy) = self.yaw.sin_cos();
            Vec3::new(-sy, 0.0, -cy) * -self.tilt.signum()
        } else {
            Vec3::Y
        };
        Mat4::look_to_rh(self.position, self.forward(), up)
    }

    /// Camera → clip (right-handed, depth 0 at near, 1 at far).
    pub fn projection(&self) -> Mat4 {
        Mat4::perspective_rh(
            self.vfov_deg.to_radians(),
            self.width as f32 / self.height.max(1) as f32,
            self.near,
            self.far,
        )
    }

    /// World → clip.
    pub fn view_projection(&self) -> Mat4 {
        self.projection() * self.view()
    }

    /// Linear depth (m along the viewing axis) of a depth-buffer value in [0, 1].
    pub fn linear_depth(&self, z: f32) -> f32 {
        self.near * self.far / (self.far - z * (self.far - self.near))
    }

    /// The six frustum planes (a, b, c, d) with inside where a·x + b·y + c·z + d ≥ 0.
    pub fn frustum_planes(&self) -> [Vec4; 6] {
        let m = self.view_projection();
        let (r0, r1, r2, r3) = (m.row(0), m.row(1), m.row(2), m.row(3));
        [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2, r3 - r2]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_zero_looks_down_minus_z_and_tilt_looks_up() {
        let mut c = Camera {
            position: Vec3::ZERO,
            yaw: 0.0,
            tilt: 0.0,
            vfov_deg: 90.0,
            width: 64,
            height: 64,
            near: 0.1,
            far: 10.0,
        };
        assert!((c.forward() - Vec3::NEG_Z).length() < 1e-6);
        c.yaw = std::f32::consts::FRAC_PI_2;
        assert!(
            (c.forward() - Vec3::NEG_X).length() < 1e-6,
            "CCW yaw turns left"
        );
        c.tilt = 0.3;
        assert!(c.forward().y > 0.29);
        // A point straight ahead projects to the image centre.
        let p = c.position + c.forward() * 3.0;
        let clip = c.view_projection() * p.extend(1.0);
        assert!((clip.x / clip.w).abs() < 1e-5 && (clip.y / clip.w).abs() < 1e-5);
        assert!((c.linear_depth(clip.z / clip.w) - 3.0).abs() < 1e-4);
    }
}
