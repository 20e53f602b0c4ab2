//! Axis-aligned boxes and small geometric helpers shared by the scene model.

use glam::{Mat4, Vec3};
use serde::{Deserialize, Serialize};

/// The six faces of an axis-aligned box as quads of its corners ([`box_corner`] numbering),
/// each wound counter-clockwise seen from outside: −x, +x, −y, +y, −z, +z. Split a quad
/// `q` into the triangles `q0 q1 q2` and `q0 q2 q3`.
pub const BOX_FACES: [[usize; 4]; 6] = [
    [0, 4, 6, 2],
    [1, 3, 7, 5],
    [0, 1, 5, 4],
    [2, 6, 7, 3],
    [0, 2, 3, 1],
    [4, 5, 7, 6],
];

/// Corner `i` (0–7) of the box from `min` to `max`: bit 0 of `i` picks the larger x, bit 1
/// the larger y, bit 2 the larger z.
pub fn box_corner<T: Copy>(min: [T; 3], max: [T; 3], i: usize) -> [T; 3] {
    [
        if i & 1 == 0 { min[0] } else { max[0] },
        if i & 2 == 0 { min[1] } else { max[1] },
        if i & 4 == 0 { min[2] } else { max[2] },
    ]
}

/// An axis-aligned bounding box in metres. An empty box has `min > max`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The box that contains nothing; growing it by a point gives that point.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// A box from two corners (in any order).
    pub fn from_corners(a: Vec3, b: Vec3) -> Self {
        Aabb {
            min: a.min(b),
            max: a.max(b),
        }
    }

    /// The smallest box holding all `points`.
    pub fn from_points<I: IntoIterator<Item = Vec3>>(points: I) -> Self {
        let mut b = Aabb::EMPTY;
        for p in points {
            b.grow(p);
        }
        b
    }

    /// True when the box holds no point.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// Extends the box to hold `p`.
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The smallest box holding both.
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// Edge lengths (zero for an empty box).
    pub fn size(&self) -> Vec3 {
        if self.is_empty() {
            Vec3::ZERO
        } else {
            self.max - self.min
        }
    }

    /// Centre point.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// The box of this box's eight corners after `m` (exact for axis-aligned rotations).
    pub fn transformed(&self, m: &Mat4) -> Aabb {
        if self.is_empty() {
            return *self;
        }
        let mut b = Aabb::EMPTY;
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            );
            b.grow(m.transform_point3(c));
        }
        b
    }

    /// True when the boxes overlap by more than `eps` along every axis.
    pub fn overlaps(&self, other: &Aabb, eps: f32) -> bool {
        self.min.x + eps < other.max.x
            && other.min.x + eps < self.max.x
            && self.min.y + eps < other.max.y
            && other.min.y + eps < self.max.y
            && self.min.z + eps < other.max.z
            && other.min.z + eps < self.max.z
    }

    /// True when every coordinate is finite (and the box not empty).
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_faces_wind_outwards_and_cover_the_six_sides() {
        let (min, max) = ([0.0f32, 0.0, 0.0], [1.0f32, 2.0, 3.0]);
        let centre = Vec3::new(0.5, 1.0, 1.5);
        let mut normals = Vec::new();
        let mut uses = [0; 8];
        for q in BOX_FACES {
            let p = q.map(|i| Vec3::from(box_corner(min, max, i)));
            for tri in [[p[0], p[1], p[2]], [p[0], p[2], p[3]]] {
                let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
                let mid = (tri[0] + tri[1] + tri[2]) / 3.0;
                assert!(n.dot(mid - centre) > 0.0, "{q:?} winds inwards");
            }
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
            normals.push(n.to_array().map(|v| v.round() as i32));
            q.iter().for_each(|&i| uses[i] += 1);
        }
        normals.sort();
        let mut axes = vec![
            [-1, 0, 0],
            [1, 0, 0],
            [0, -1, 0],
            [0, 1, 0],
            [0, 0, -1],
            [0, 0, 1],
        ];
        axes.sort();
        assert_eq!(normals, axes);
        assert_eq!(uses, [3; 8], "every corner is on three faces");
        assert_eq!(box_corner(min, max, 5), [1.0, 0.0, 3.0]);
    }

    #[test]
    fn empty_box_grows_to_points_and_unions() {
        let mut b = Aabb::EMPTY;
        assert!(b.is_empty());
        assert_eq!(b.size(), Vec3::ZERO);
        b.grow(Vec3::new(1.0, 2.0, 3.0));
        b.grow(Vec3::new(-1.0, 0.0, 5.0));
        assert_eq!(b.min, Vec3::new(-1.0, 0.0, 3.0));
        assert_eq!(b.max, Vec3::new(1.0, 2.0, 5.0));
        let u = b.union(&Aabb::EMPTY);
        assert_eq!(u, b);
    }

    #[test]
    fn transformed_box_of_quarter_turn_is_exact() {
        let b = Aabb::from_corners(Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, 1.0, 1.0));
        let m = Mat4::from_rotation_y(std::f32::consts::FRAC_PI_2);
        let t = b.transformed(&m);
        // A quarter turn about +Y maps +X to -Z.
        assert!((t.min - Vec3::new(0.0, 0.0, -2.0)).length() < 1e-6);
        assert!((t.max - Vec3::new(1.0, 1.0, 0.0)).length() < 1e-6);
    }
}
