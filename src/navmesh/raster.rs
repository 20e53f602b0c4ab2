//! Voxelisation of triangles into vertical solid intervals per grid column (the first step of
//! a bake, as in Recast's heightfield rasterisation).
//!
//! Each triangle is clipped against the cell rows and columns it overlaps; the clipped
//! polygon's lowest and highest points give the interval it occupies in that column, and the
//! triangle's slope says whether its top is a floor.

use glam::Vec3;

/// A solid interval `[ymin, ymax]` in one column; `floor` when its top may be walked on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solid {
    /// Column index.
    pub column: u32,
    /// Bottom (m).
    pub ymin: f32,
    /// Top (m).
    pub ymax: f32,
    /// The top surface is within the slope limit.
    pub floor: bool,
}

/// The grid the triangles are rasterised onto.
#[derive(Debug, Clone, Copy)]
pub struct RasterGrid {
    /// World x of the minimum corner.
    pub x0: f32,
    /// World z of the minimum corner.
    pub z0: f32,
    /// Cell edge.
    pub cell: f32,
    /// Columns along x.
    pub nx: u32,
    /// Columns along z.
    pub nz: u32,
}

const MAX_VERTS: usize = 12;

/// A small convex polygon on the stack.
#[derive(Clone, Copy)]
struct Poly {
    v: [Vec3; MAX_VERTS],
    n: usize,
}

impl Poly {
    fn empty() -> Self {
        Poly {
            v: [Vec3::ZERO; MAX_VERTS],
            n: 0,
        }
    }
    fn push(&mut self, p: Vec3) {
        if self.n < MAX_VERTS {
            self.v[self.n] = p;
            self.n += 1;
        }
    }
    fn verts(&self) -> &[Vec3] {
        &self.v[..self.n]
    }
}

/// Splits `poly` by the plane `p[axis] = value` into the part below and the part above.
fn split(poly: &Poly, axis: usize, value: f32) -> (Poly, Poly) {
    let mut below = Poly::empty();
    let mut above = Poly::empty();
    let n = poly.n;
    for i in 0..n {
        let a = poly.v[i];
        let b = poly.v[(i + 1) % n];
        let da = value - a[axis];
        let db = value - b[axis];
        let a_below = da >= 0.0;
        if a_below {
            below.push(a);
        }
        if da <= 0.0 {
            above.push(a);
        }
        // The edge crosses the plane strictly: add the intersection to both sides.
        if (da > 0.0 && db < 0.0) || (da < 0.0 && db > 0.0) {
            let t = da / (da - db);
            let p = a + (b - a) * t;
            below.push(p);
            above.push(p);
        }
    }
    (below, above)
}

impl RasterGrid {
    /// Rasterises one triangle, calling `emit(column, ymin, ymax)` per overlapped column.
    pub fn triangle(&self, tri: [Vec3; 3], mut emit: impl FnMut(u32, f32, f32)) {
        let (min, max) = (
            tri[0].min(tri[1]).min(tri[2]),
            tri[0].max(tri[1]).max(tri[2]),
        );
        let cell = self.cell;
        let ix0 = (((min.x - self.x0) / cell).floor() as i64).max(0);
        let ix1 = (((max.x - self.x0) / cell).floor() as i64).min(self.nx as i64 - 1);
        let iz0 = (((min.z - self.z0) / cell).floor() as i64).max(0);
        let iz1 = (((max.z - self.z0) / cell).floor() as i64).min(self.nz as i64 - 1);
        if ix0 > ix1 || iz0 > iz1 {
            return;
        }
        let mut rest = Poly::empty();
        for p in tri {
            rest.push(p);
        }
        // Drop the part before the first row.
        let (_, r) = split(&rest, 2, self.z0 + iz0 as f32 * cell);
        rest = r;
        for iz in iz0..=iz1 {
            let (row, r) = split(&rest, 2, self.z0 + (iz + 1) as f32 * cell);
            rest = r;
            if row.n < 3 {
                continue;
            }
            let (rmin, rmax) = row
                .verts()
                .iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
                    (lo.min(p.x), hi.max(p.x))
                });
            let cx0 = (((rmin - self.x0) / cell).floor() as i64).max(ix0);
            let cx1 = (((rmax - self.x0) / cell).floor() as i64).min(ix1);
            let (_, mut col_rest) = split(&row, 0, self.x0 + cx0 as f32 * cell);
            for ix in cx0..=cx1 {
                let (piece, r) = split(&col_rest, 0, self.x0 + (ix + 1) as f32 * cell);
                col_rest = r;
                if piece.n < 3 {
                    continue;
                }
                let (ylo, yhi) = piece
                    .verts()
                    .iter()
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
                        (lo.min(p.y), hi.max(p.y))
                    });
                emit((iz as u32) * self.nx + ix as u32, ylo, yhi);
            }
        }
    }
}

/// True when a triangle (counter-clockwise from the front) faces up within `cos_slope`.
pub fn is_floor(tri: [Vec3; 3], cos_slope: f32) -> bool {
    let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
    let len = n.length();
    len > 0.0 && n.y >= cos_slope * len
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> RasterGrid {
        RasterGrid {
            x0: 0.0,
            z0: 0.0,
            cell: 1.0,
            nx: 4,
            nz: 4,
        }
    }

    #[test]
    fn a_flat_triangle_covers_the_cells_under_it() {
        let mut cols = Vec::new();
        let tri = [
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 2.0),
            Vec3::new(2.0, 1.0, 0.0),
        ];
        grid().triangle(tri, |c, lo, hi| {
            assert_eq!((lo, hi), (1.0, 1.0));
            cols.push(c);
        });
        cols.sort();
        // Cells (0,0), (1,0), (0,1); (1,1) only touches the hypotenuse at a corner.
        assert_eq!(cols, vec![0, 1, 4]);
        assert!(is_floor(tri, 0.7));
    }

    #[test]
    fn a_vertical_wall_spans_its_height_in_the_cells_it_crosses() {
        let mut seen = Vec::new();
        let tri = [
            Vec3::new(0.5, 0.0, 0.5),
            Vec3::new(3.5, 0.0, 0.5),
            Vec3::new(3.5, 2.0, 0.5),
        ];
        grid().triangle(tri, |c, lo, hi| seen.push((c, lo, hi)));
        assert_eq!(seen.len(), 4);
        let (_, lo, hi) = seen[3];
        assert!(lo.abs() < 1e-6 && (hi - 2.0).abs() < 1e-6);
        assert!(!is_floor(tri, 0.7));
    }
}
