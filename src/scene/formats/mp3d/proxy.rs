//! Proxy geometry for Matterport3D houses that come as a `.house` file only: enough solid
//! structure, built from the annotations, to bake navigation on the real layouts.
//!
//! - floors: each region's floor polygon, ear-clipped (polygons may be non-convex), facing up;
//! - passages: where a region's outline runs within [`SHARE_TOLERANCE`] of another region's
//!   (annotated regions leave small gaps at open passages), a strip of floor
//!   [`BRIDGE_WIDTH`] wide bridges the gap and no wall is built; where a door or a portal
//!   crosses the outline, a wider strip ([`OPENING_BRIDGE_WIDTH`]) spans a wall's thickness;
//! - walls: every other stretch of outline gets a box [`WALL_THICKNESS`] thick, outside the
//!   polygon, up to the region's height;
//! - obstacles: objects as oriented boxes (a shared unit box mesh and a transform, [`Obb`]).
//!
//! All of it works in y-up world coordinates; floor polygons are `(x, z)` pairs. Which objects
//! are obstacles and how meshes are assigned to rooms is decided in [`super`].

use glam::{Mat4, Vec3};

use crate::invalid::Invalid;
use crate::scene::Aabb;
use crate::scene::{Material, Mesh};

/// Distance (m) within which two regions' outlines count as one shared boundary (no wall).
pub const SHARE_TOLERANCE: f32 = 0.15;
/// Width (m) of the floor strip bridging the gap along a shared boundary.
pub const BRIDGE_WIDTH: f32 = 0.15;
/// Width (m) of the floor strip through a door or portal (each side builds one).
pub const OPENING_BRIDGE_WIDTH: f32 = 0.25;
/// Thickness (m) of proxy walls (built outside the floor polygon).
pub const WALL_THICKNESS: f32 = 0.1;
/// Wall height (m) when a region's own height is missing or implausible.
pub const DEFAULT_WALL_HEIGHT: f32 = 2.5;
/// Spacing (m) of the samples that classify a region's outline.
const SAMPLE_STEP: f32 = 0.05;
/// Most samples along one outline edge (a 5 km edge at [`SAMPLE_STEP`]).
const MAX_SAMPLES: f32 = 100_000.0;
/// Shared stretches shorter than this (m) are walled: no agent passes through them.
const MIN_PASSAGE: f32 = 0.3;
/// How far (m) from a door's box an outline sample still counts as crossing it.
const OPENING_MARGIN: f32 = 0.1;

/// Signed area of a polygon in the `(x, z)` plane: positive when the vertices run
/// counter-clockwise with x to the right and z up (which is clockwise seen from +Y).
pub fn signed_area(poly: &[[f32; 2]]) -> f32 {
    let n = poly.len();
    let mut s = 0.0f64;
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        s += f64::from(a[0]) * f64::from(b[1]) - f64::from(b[0]) * f64::from(a[1]);
    }
    (s * 0.5) as f32
}

fn cross(o: [f32; 2], a: [f32; 2], b: [f32; 2]) -> f32 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// The polygon without repeated vertices (consecutive, or the last equal to the first) and
/// without vertices on a straight line between their neighbours.
pub fn clean_polygon(poly: &[[f32; 2]]) -> Vec<[f32; 2]> {
    let mut out: Vec<[f32; 2]> = Vec::with_capacity(poly.len());
    for &p in poly {
        if out
            .last()
            .is_none_or(|q| (q[0] - p[0]).abs() > 1e-5 || (q[1] - p[1]).abs() > 1e-5)
        {
            out.push(p);
        }
    }
    while out.len() > 1 {
        let (f, l) = (out[0], out[out.len() - 1]);
        if (f[0] - l[0]).abs() <= 1e-5 && (f[1] - l[1]).abs() <= 1e-5 {
            out.pop();
        } else {
            break;
        }
    }
    let mut changed = true;
    while changed && out.len() > 3 {
        changed = false;
        for i in 0..out.len() {
            let n = out.len();
            let (a, b, c) = (out[(i + n - 1) % n], out[i], out[(i + 1) % n]);
            let len = ((c[0] - a[0]).powi(2) + (c[1] - a[1]).powi(2))
                .sqrt()
                .max(1e-6);
            if (cross(a, b, c) / len).abs() < 1e-5 {
                out.remove(i);
                changed = true;
                break;
            }
        }
    }
    out
}

fn in_triangle(p: [f32; 2], a: [f32; 2], b: [f32; 2], c: [f32; 2], sign: f32) -> bool {
    let same = |q: [f32; 2]| (q[0] - p[0]).abs() < 1e-7 && (q[1] - p[1]).abs() < 1e-7;
    if same(a) || same(b) || same(c) {
        return false;
    }
    cross(a, b, p) * sign >= 0.0 && cross(b, c, p) * sign >= 0.0 && cross(c, a, p) * sign >= 0.0
}

/// Ear-clipping triangulation of a simple polygon (convex or not, either orientation).
/// Triangles keep the polygon's orientation. Self-intersecting or degenerate input still
/// gives triangles (never a panic): when no proper ear exists, the most convex corner is cut.
pub fn triangulate(poly: &[[f32; 2]]) -> Vec<[usize; 3]> {
    let n = poly.len();
    if n < 3 {
        return Vec::new();
    }
    let sign = if signed_area(poly) >= 0.0 { 1.0 } else { -1.0 };
    let mut idx: Vec<usize> = (0..n).collect();
    let mut out = Vec::with_capacity(n - 2);
    while idx.len() > 3 {
        let m = idx.len();
        let corner = |i: usize| (idx[(i + m - 1) % m], idx[i], idx[(i + 1) % m]);
        let ear = (0..m).find(|&i| {
            let (a, b, c) = corner(i);
            cross(poly[a], poly[b], poly[c]) * sign > 1e-9
                && !idx.iter().any(|&k| {
                    k != a
                        && k != b
                        && k != c
                        && in_triangle(poly[k], poly[a], poly[b], poly[c], sign)
                })
        });
        let i = match ear {
            Some(i) => i,
            None => (0..m)
                .max_by(|&i, &j| {
                    let (a, b, c) = corner(i);
                    let (d, e, f) = corner(j);
                    (cross(poly[a], poly[b], poly[c]) * sign)
                        .total_cmp(&(cross(poly[d], poly[e], poly[f]) * sign))
                })
                .unwrap_or(0),
        };
        let (a, b, c) = corner(i);
        if cross(poly[a], poly[b], poly[c]) * sign > 0.0 {
            out.push([a, b, c]);
        }
        idx.remove(i);
    }
    if cross(poly[idx[0]], poly[idx[1]], poly[idx[2]]) * sign > 0.0 {
        out.push([idx[0], idx[1], idx[2]]);
    }
    out
}

/// True when `p` lies inside the polygon (even-odd rule).
pub fn contains(poly: &[[f32; 2]], p: [f32; 2]) -> bool {
    let n = poly.len();
    let mut inside = false;
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + n - 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// Distance from `p` to the polygon's area (0 inside).
pub fn distance_to(poly: &[[f32; 2]], p: [f32; 2]) -> f32 {
    if contains(poly, p) {
        return 0.0;
    }
    let n = poly.len();
    (0..n)
        .map(|i| segment_distance(p, poly[i], poly[(i + 1) % n]))
        .fold(f32::INFINITY, f32::min)
}

fn segment_distance(p: [f32; 2], a: [f32; 2], b: [f32; 2]) -> f32 {
    let (dx, dz) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dz * dz;
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dz) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (x, z) = (a[0] + t * dx - p[0], a[1] + t * dz - p[1]);
    (x * x + z * z).sqrt()
}

/// Builds one [`Mesh`] triangle by triangle, with material slots.
#[derive(Debug, Default)]
pub struct MeshBuilder {
    mesh: Mesh,
}

impl MeshBuilder {
    /// An empty mesh called `name`.
    pub fn new(name: impl Into<String>) -> Self {
        MeshBuilder {
            mesh: Mesh {
                name: name.into(),
                ..Default::default()
            },
        }
    }

    /// The slot of material `name`, added with colour `rgb` when new.
    pub fn material(&mut self, name: &str, rgb: [f32; 3]) -> u16 {
        if let Some(i) = self.mesh.materials.iter().position(|m| m.name == name) {
            return i as u16;
        }
        self.mesh.materials.push(Material::solid(name, rgb));
        (self.mesh.materials.len() - 1) as u16
    }

    /// Adds a vertex and returns its index.
    pub fn vertex(&mut self, p: Vec3) -> u32 {
        self.mesh.positions.push(p.to_array());
        (self.mesh.positions.len() - 1) as u32
    }

    /// Adds a triangle of existing vertices.
    pub fn triangle_indices(&mut self, t: [u32; 3], slot: u16) {
        self.mesh.indices.extend_from_slice(&t);
        self.mesh.face_materials.push(slot);
    }

    /// Adds a triangle with its own vertices, wound as given.
    pub fn triangle(&mut self, t: [Vec3; 3], slot: u16) {
        let i = [self.vertex(t[0]), self.vertex(t[1]), self.vertex(t[2])];
        self.triangle_indices(i, slot);
    }

    /// Adds a horizontal triangle facing up (+Y), whatever the order of its corners.
    pub fn up_triangle(&mut self, a: Vec3, b: Vec3, c: Vec3, slot: u16) {
        if (b - a).cross(c - a).y >= 0.0 {
            self.triangle([a, b, c], slot);
        } else {
            self.triangle([a, c, b], slot);
        }
    }

    /// Adds a closed box with flat faces ([`Mesh::push_box`]; normals are recomputed by
    /// [`MeshBuilder::finish`]).
    pub fn push_box(&mut self, c: [Vec3; 8], slot: u16) {
        self.mesh.push_box(c, slot);
    }

    /// True when no triangle was added.
    pub fn is_empty(&self) -> bool {
        self.mesh.indices.is_empty()
    }

    /// The mesh, with normals computed from the faces.
    pub fn finish(mut self) -> Mesh {
        if self.mesh.materials.is_empty() {
            self.mesh
                .materials
                .push(Material::solid("default", [0.7; 3]));
        }
        self.mesh.compute_normals();
        self.mesh
    }
}

/// The unit box `[-0.5, 0.5]³` that every proxy obstacle places with its [`Obb::transform`].
pub fn unit_box() -> Mesh {
    let mut b = MeshBuilder::new("mp3d proxy unit box");
    let slot = b.material("object", [0.6, 0.55, 0.5]);
    let [b0, b1, b2, b3] = [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]]
        .map(|[x, z]| Vec3::new(x, -0.5, z));
    b.push_box([b0, b1, b2, b3, b0 + Vec3::Y, b1 + Vec3::Y, b2 + Vec3::Y, b3 + Vec3::Y], slot);
    b.finish()
}

/// An oriented box: centre, three orthonormal axes (right-handed) and half sizes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Obb {
    /// Centre.
    pub center: Vec3,
    /// Unit axes; `axes[2] = axes[0] × axes[1]`.
    pub axes: [Vec3; 3],
    /// Half sizes along the axes (at least 1 mm each).
    pub radii: Vec3,
}

impl Obb {
    /// A box from Matterport's description (already in y-up coordinates): the second axis is
    /// made orthogonal to the first, the third is their cross product, radii below 1 mm are
    /// raised to 1 mm (flat objects such as pictures). Fails on zero or parallel axes.
    pub fn new(center: Vec3, axis0: Vec3, axis1: Vec3, radii: Vec3) -> Result<Obb, Invalid> {
        let a0 = axis0
            .try_normalize()
            .ok_or_else(|| format!("box axis 0 {axis0} has no direction"))?;
        let a1 = (axis1 - a0 * axis1.dot(a0))
            .try_normalize()
            .ok_or_else(|| format!("box axes {axis0} and {axis1} are parallel"))?;
        let a2 = a0.cross(a1);
        if !(center.is_finite() && radii.is_finite()) {
            return Err("box centre or radii not finite".into());
        }
        Ok(Obb {
            center,
            axes: [a0, a1, a2],
            radii: radii.max(Vec3::splat(1e-3)),
        })
    }

    /// An axis-aligned box as an [`Obb`].
    pub fn from_aabb(b: &Aabb) -> Obb {
        Obb {
            center: b.center(),
            axes: [Vec3::X, Vec3::Y, Vec3::Z],
            radii: (b.size() * 0.5).max(Vec3::splat(1e-3)),
        }
    }

    /// The transform that places [`unit_box`] on this box.
    pub fn transform(&self) -> Mat4 {
        Mat4::from_cols(
            (self.axes[0] * 2.0 * self.radii.x).extend(0.0),
            (self.axes[1] * 2.0 * self.radii.y).extend(0.0),
            (self.axes[2] * 2.0 * self.radii.z).extend(0.0),
            self.center.extend(1.0),
        )
    }

    /// The eight corners.
    pub fn corners(&self) -> [Vec3; 8] {
        let mut out = [Vec3::ZERO; 8];
        for (i, c) in out.iter_mut().enumerate() {
            let s = |bit: usize| if i & bit == 0 { -1.0 } else { 1.0 };
            *c = self.center
                + self.axes[0] * self.radii.x * s(1)
                + self.axes[1] * self.radii.y * s(2)
                + self.axes[2] * self.radii.z * s(4);
        }
        out
    }

    /// The world axis-aligned box around it.
    pub fn aabb(&self) -> Aabb {
        Aabb::from_points(self.corners())
    }

    /// True when `p` lies inside the box grown by `margin` on every side.
    pub fn contains(&self, p: Vec3, margin: f32) -> bool {
        let d = p - self.center;
        (0..3).all(|k| d.dot(self.axes[k]).abs() <= self.radii[k] + margin)
    }
}

/// A region as proxy geometry sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct ProxyRegion {
    /// Floor outline in `(x, z)`, any orientation.
    pub polygon: Vec<[f32; 2]>,
    /// Floor height.
    pub floor_y: f32,
    /// Wall height above the floor.
    pub wall_height: f32,
    /// Level index (only regions of one level share boundaries).
    pub level: usize,
}

/// The proxy surfaces of one region.
#[derive(Debug, Default)]
pub struct ProxySurfaces {
    /// Floor polygon plus bridging strips, facing up.
    pub floor: Option<Mesh>,
    /// Wall boxes, when walls were asked for and some stretch of outline needs one.
    pub walls: Option<Mesh>,
}

/// What one stretch of outline gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stretch {
    Wall,
    Shared,
    Opening,
}

/// Builds floors (with bridges) and, when `walls`, walls for every region; `openings` are the
/// boxes of doors and portals, through which walls leave a gap.
pub fn build_surfaces(
    regions: &[ProxyRegion],
    openings: &[Obb],
    walls: bool,
) -> Vec<ProxySurfaces> {
    let polys: Vec<Vec<[f32; 2]>> = regions
        .iter()
        .map(|r| {
            let mut p = clean_polygon(&r.polygon);
            if signed_area(&p) < 0.0 {
                p.reverse();
            }
            p
        })
        .collect();
    let boxes: Vec<Aabb> = polys
        .iter()
        .map(|p| Aabb::from_points(p.iter().map(|q| Vec3::new(q[0], 0.0, q[1]))))
        .collect();
    let mut out = Vec::with_capacity(regions.len());
    for (r, region) in regions.iter().enumerate() {
        let poly = &polys[r];
        if poly.len() < 3 || signed_area(poly).abs() < 1e-6 {
            out.push(ProxySurfaces::default());
            continue;
        }
        let y = region.floor_y;
        let at = |q: [f32; 2]| Vec3::new(q[0], y, q[1]);
        let mut floor = MeshBuilder::new(format!("mp3d proxy floor {r}"));
        let slot = floor.material("floor", [0.62, 0.5, 0.38]);
        let base: Vec<u32> = poly.iter().map(|&q| floor.vertex(at(q))).collect();
        for t in triangulate(poly) {
            // Counter-clockwise in (x, z) is clockwise seen from +Y: swap to face up.
            floor.triangle_indices([base[t[0]], base[t[2]], base[t[1]]], slot);
        }
        let mut wall = MeshBuilder::new(format!("mp3d proxy walls {r}"));
        let wall_slot = wall.material("wall", [0.85, 0.83, 0.78]);
        let neighbours: Vec<usize> = (0..regions.len())
            .filter(|&o| {
                o != r
                    && regions[o].level == region.level
                    && (regions[o].floor_y - y).abs() < 1.0
                    && polys[o].len() >= 3
                    && boxes[o].min.x <= boxes[r].max.x + SHARE_TOLERANCE
                    && boxes[r].min.x <= boxes[o].max.x + SHARE_TOLERANCE
                    && boxes[o].min.z <= boxes[r].max.z + SHARE_TOLERANCE
                    && boxes[r].min.z <= boxes[o].max.z + SHARE_TOLERANCE
            })
            .collect();
        let doors: Vec<&Obb> = openings
            .iter()
            .filter(|o| {
                let b = o.aabb();
                b.max.y >= y + 0.3 && b.min.y <= y + 1.5
            })
            .collect();
        let h = region.wall_height;
        for i in 0..poly.len() {
            let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
            let d = [q[0] - p[0], q[1] - p[1]];
            let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
            if len < 1e-4 {
                continue;
            }
            // Outward normal of a counter-clockwise (x, z) outline.
            let n = [d[1] / len, -d[0] / len];
            let samples = (len / SAMPLE_STEP).ceil().clamp(1.0, MAX_SAMPLES) as usize;
            let kind_at = |k: usize| {
                let t = (k as f32 + 0.5) / samples as f32;
                let s = [p[0] + d[0] * t, p[1] + d[1] * t];
                if doors
                    .iter()
                    .any(|o| o.contains(Vec3::new(s[0], o.center.y, s[1]), OPENING_MARGIN))
                {
                    Stretch::Opening
                } else if neighbours
                    .iter()
                    .any(|&o| distance_to(&polys[o], s) <= SHARE_TOLERANCE)
                {
                    Stretch::Shared
                } else {
                    Stretch::Wall
                }
            };
            let mut runs: Vec<(Stretch, usize, usize)> = Vec::new();
            for k in 0..samples {
                let kind = kind_at(k);
                match runs.last_mut() {
                    Some((last, _, end)) if *last == kind => *end = k + 1,
                    _ => runs.push((kind, k, k + 1)),
                }
            }
            // Shared stretches too short to pass through are wall, merged with their
            // neighbours into one box.
            let min_samples = (MIN_PASSAGE / len * samples as f32).ceil() as usize;
            let mut merged: Vec<(Stretch, usize, usize)> = Vec::with_capacity(runs.len());
            for (kind, k0, k1) in runs {
                let kind = if kind == Stretch::Shared && k1 - k0 < min_samples {
                    Stretch::Wall
                } else {
                    kind
                };
                match merged.last_mut() {
                    Some((last, _, end)) if *last == kind => *end = k1,
                    _ => merged.push((kind, k0, k1)),
                }
            }
            for (kind, k0, k1) in merged {
                let t0 = k0 as f32 / samples as f32;
                let t1 = k1 as f32 / samples as f32;
                let a = [p[0] + d[0] * t0, p[1] + d[1] * t0];
                let b = [p[0] + d[0] * t1, p[1] + d[1] * t1];
                let width = match kind {
                    Stretch::Shared => BRIDGE_WIDTH,
                    Stretch::Opening => OPENING_BRIDGE_WIDTH,
                    Stretch::Wall => {
                        if walls {
                            let out = |c: [f32; 2], w: f32| [c[0] + n[0] * w, c[1] + n[1] * w];
                            let quad = [a, b, out(b, WALL_THICKNESS), out(a, WALL_THICKNESS)];
                            let bottom = quad.map(|c| Vec3::new(c[0], y, c[1]));
                            let top = quad.map(|c| Vec3::new(c[0], y + h, c[1]));
                            wall.push_box(
                                [
                                    bottom[0], bottom[1], bottom[2], bottom[3], top[0], top[1],
                                    top[2], top[3],
                                ],
                                wall_slot,
                            );
                        }
                        continue;
                    }
                };
                let a2 = [a[0] + n[0] * width, a[1] + n[1] * width];
                let b2 = [b[0] + n[0] * width, b[1] + n[1] * width];
                floor.up_triangle(at(a), at(b), at(b2), slot);
                floor.up_triangle(at(a), at(b2), at(a2), slot);
            }
        }
        out.push(ProxySurfaces {
            floor: Some(floor.finish()),
            walls: (!wall.is_empty()).then(|| wall.finish()),
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area_of(poly: &[[f32; 2]], tris: &[[usize; 3]]) -> f32 {
        tris.iter()
            .map(|t| signed_area(&[poly[t[0]], poly[t[1]], poly[t[2]]]))
            .sum()
    }

    #[test]
    fn ear_clipping_covers_a_non_convex_polygon_exactly() {
        // An L shape (area 3) in both orientations, with a repeated and a collinear vertex.
        let l = [
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [0.5, 2.0],
            [0.0, 2.0],
            [0.0, 2.0],
        ];
        let cleaned = clean_polygon(&l);
        assert_eq!(cleaned.len(), 6);
        let tris = triangulate(&cleaned);
        assert_eq!(tris.len(), 4);
        assert!((area_of(&cleaned, &tris) - 3.0).abs() < 1e-5);
        // Every triangle keeps the polygon's orientation: no triangle covers the notch.
        assert!(tris
            .iter()
            .all(|t| signed_area(&[cleaned[t[0]], cleaned[t[1]], cleaned[t[2]]]) > 0.0));
        let mut rev = cleaned.clone();
        rev.reverse();
        let tris = triangulate(&rev);
        assert!((area_of(&rev, &tris) + 3.0).abs() < 1e-5);
    }

    #[test]
    fn degenerate_polygons_do_not_panic() {
        assert!(triangulate(&[[0.0, 0.0], [1.0, 0.0]]).is_empty());
        assert!(triangulate(&[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]).is_empty());
        // A bow tie (self-intersecting): some triangles, no panic.
        let bow = [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]];
        let _ = triangulate(&bow);
    }

    #[test]
    fn containment_and_distance() {
        let sq = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        assert!(contains(&sq, [1.0, 1.0]));
        assert!(!contains(&sq, [3.0, 1.0]));
        assert_eq!(distance_to(&sq, [1.0, 1.0]), 0.0);
        assert!((distance_to(&sq, [3.0, 1.0]) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn obb_transform_places_the_unit_box() {
        let obb = Obb::new(
            Vec3::new(1.0, 0.5, -2.0),
            Vec3::new(0.0, 0.0, 2.0),
            Vec3::new(1.0, 0.0, 0.1),
            Vec3::new(0.4, 0.3, 0.5),
        )
        .unwrap();
        let m = obb.transform();
        assert!(m.determinant() > 0.0);
        let b = unit_box().world_bounds(&m);
        let expect = obb.aabb();
        assert!((b.min - expect.min).length() < 1e-5 && (b.max - expect.max).length() < 1e-5);
        // axis0 = +Z with radius 0.4; axis1 ~ +X with radius 0.3; axis2 = Z × X = +Y, 0.5.
        assert!(
            (expect.size() - Vec3::new(0.6, 1.0, 0.8)).length() < 1e-5,
            "{}",
            expect.size()
        );
        assert!(obb.contains(Vec3::new(1.25, 0.5, -2.0), 0.0));
        assert!(!obb.contains(Vec3::new(1.35, 0.5, -2.0), 0.0));
        assert!(Obb::new(Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::ONE).is_err());
        assert!(Obb::new(Vec3::ZERO, Vec3::ZERO, Vec3::X, Vec3::ONE).is_err());
        // Flat boxes get a minimum thickness so the transform stays invertible.
        let flat = Obb::new(Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)).unwrap();
        assert!(flat.transform().determinant().abs() > 0.0);
    }

    #[test]
    fn unit_box_faces_outwards() {
        let m = unit_box();
        assert_eq!(m.triangle_count(), 12);
        for t in m.indices.chunks_exact(3) {
            let p = |i: u32| Vec3::from_array(m.positions[i as usize]);
            let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
            let n = (b - a).cross(c - a);
            assert!(n.dot((a + b + c) / 3.0) > 0.0);
        }
        assert!(m.validate().is_ok());
    }

    fn rect(x0: f32, z0: f32, x1: f32, z1: f32) -> Vec<[f32; 2]> {
        vec![[x0, z0], [x1, z0], [x1, z1], [x0, z1]]
    }

    #[test]
    fn shared_boundaries_get_bridges_and_others_walls() {
        // Two rooms with a 4 cm gap between them (an open passage) and a third far away.
        let regions = vec![
            ProxyRegion {
                polygon: rect(0.0, 0.0, 3.0, 3.0),
                floor_y: 0.0,
                wall_height: 2.5,
                level: 0,
            },
            ProxyRegion {
                polygon: rect(3.04, 0.0, 6.0, 3.0),
                floor_y: 0.01,
                wall_height: 2.5,
                level: 0,
            },
        ];
        let s = build_surfaces(&regions, &[], true);
        let floor = s[0].floor.as_ref().unwrap();
        // Polygon (2 triangles) + one bridge strip (2 triangles) along x = 3.
        assert_eq!(floor.triangle_count(), 4);
        assert!((floor.bounds().max.x - (3.0 + BRIDGE_WIDTH)).abs() < 1e-5);
        assert!(floor.normals.iter().all(|n| n[1] > 0.99));
        let walls = s[0].walls.as_ref().unwrap();
        // Three walled sides (the shared one is open): 3 boxes of 12 triangles.
        assert_eq!(walls.triangle_count(), 36);
        assert!(walls.bounds().max.x <= 3.0 + 1e-5);
        assert!((walls.bounds().min.x + WALL_THICKNESS).abs() < 1e-5);
        assert!((walls.bounds().max.y - 2.5).abs() < 1e-5);
        // Without walls, a door across the outer wall still adds its bridge.
        let door = Obb::from_aabb(&Aabb::from_corners(
            Vec3::new(-0.1, 0.0, 1.0),
            Vec3::new(0.1, 2.0, 1.8),
        ));
        let s = build_surfaces(&regions, &[door], false);
        assert!(s[0].walls.is_none());
        let f = s[0].floor.as_ref().unwrap();
        assert!((f.bounds().min.x + OPENING_BRIDGE_WIDTH).abs() < 1e-5);
        // The door's stretch of wall is left out.
        let s = build_surfaces(&regions, &[door], true);
        assert_eq!(s[0].walls.as_ref().unwrap().triangle_count(), 48);
    }
}
