//! Scan-like houses (`minos generate --scan`): a planned house written as a Matterport3D
//! reconstruction would be — every surface tessellated into a dense grid of small triangles
//! (the cell size chosen so the house has about the requested number of triangles), vertices
//! pushed along their surface's normal by a few millimetres of noise, small holes in walls,
//! ceilings and furniture, clutter on furniture tops and along walls, and the faces of floors,
//! walls and ceilings split into segments of about a square metre (`E` records), as
//! Matterport's over-segmentation does. Floors and stairs are never holed, so the house stays
//! navigable.
//!
//! All randomness comes from one generator seeded from `(seed, house id, "scan")`, used in a
//! fixed order, so a house's files are byte-identical whatever the thread count.

use crate::invalid::Invalid;
use crate::seed::Rng;

use super::layout::keep_outs;
use super::mp3d_mesh::{
    cross3, grow, len3, segment_object, sub3, zup, MeshData, Quad, QuadKind, SegmentRec, EMPTY_BOX,
};
use super::plan::{HousePlan, Rect, Side, WALL_T};

/// Default number of triangles of a scan house.
pub const DEFAULT_TRIANGLES: u64 = 2_000_000;
/// Default standard deviation of the vertex noise along surface normals (m).
pub const DEFAULT_NOISE: f64 = 0.003;
/// Fewest triangles a scan house may be asked for.
pub const MIN_TRIANGLES: u64 = 1_000;
/// Most triangles a scan house may be asked for.
pub const MAX_TRIANGLES: u64 = 50_000_000;
/// Smallest cell edge the tessellation uses (m).
const MIN_CELL: f64 = 0.004;
/// Side of the segments floors, walls and ceilings are split into (m).
const PATCH: f64 = 1.0;
/// Probability that a cell of a wall, ceiling or object is missing.
const CELL_DROPOUT: f64 = 0.002;
/// Holes per square metre of wall, ceiling or object surface.
const HOLES_PER_M2: f64 = 1.0;
/// Radii of those holes (m).
const HOLE_RADIUS: (f64, f64) = (0.02, 0.10);
/// Fine categories of the clutter (appended to the house's `C` records).
pub const CLUTTER_CATEGORIES: [&str; 5] = ["box", "books", "clothes", "bottle", "basket"];
/// Furniture whose top gets clutter.
const TOPS: [&str; 6] = [
    "desk",
    "coffee_table",
    "dining_table",
    "tv_stand",
    "dresser",
    "stand",
];

/// How a scan house is written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanParams {
    /// Triangles to aim for (the house gets at most this many, within a few per cent).
    pub triangles: u64,
    /// Standard deviation of the vertex noise along surface normals (m).
    pub noise: f64,
    /// The user seed (the house id is mixed in).
    pub seed: u64,
}

impl ScanParams {
    /// Checks the triangle count and the noise.
    pub fn validate(&self) -> Result<(), Invalid> {
        if !(MIN_TRIANGLES..=MAX_TRIANGLES).contains(&self.triangles) {
            return Err(format!(
                "scan triangles {}: need {MIN_TRIANGLES} <= N <= {MAX_TRIANGLES}",
                self.triangles
            )
            .into());
        }
        if !(0.0..=0.05).contains(&self.noise) {
            return Err(format!("scan noise {} m: need 0 <= NOISE <= 0.05", self.noise).into());
        }
        Ok(())
    }
}

/// A clutter box: level, room (index in its level), y-up corners, fine category.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Clutter {
    pub(super) level: usize,
    pub(super) room: usize,
    pub(super) min: [f64; 3],
    pub(super) max: [f64; 3],
    pub(super) fine: &'static str,
}

/// Clutter for a plan: one to three small boxes on each table, desk, dresser or stand, and up
/// to three per room on the floor against a wall — never in front of an opening, on a stair
/// landing, over a floor hole or on other furniture, and not in stair halls.
pub(super) fn clutter(plan: &HousePlan, rng: &mut Rng) -> Vec<Clutter> {
    let mut out = Vec::new();
    for (li, level) in plan.levels.iter().enumerate() {
        for o in &level.objects {
            let Some(&room) = o.rooms.first() else {
                continue;
            };
            if !TOPS.contains(&o.spec().fine) {
                continue;
            }
            let (lo, hi) = o.world_box();
            for _ in 0..rng.range_usize(1, 3) {
                let (sx, sz) = (rng.range_f64(0.05, 0.25), rng.range_f64(0.05, 0.25));
                let sy = rng.range_f64(0.03, 0.25);
                let (fx, fz) = (rng.unit_f64(), rng.unit_f64());
                let fine = *rng.pick(&CLUTTER_CATEGORIES).unwrap_or(&"box");
                let (w, d) = (hi[0] - lo[0] - 0.1 - sx, hi[2] - lo[2] - 0.1 - sz);
                if w <= 0.0 || d <= 0.0 {
                    continue;
                }
                let x = lo[0] + 0.05 + fx * w;
                let z = lo[2] + 0.05 + fz * d;
                out.push(Clutter {
                    level: li,
                    room,
                    min: [x, hi[1], z],
                    max: [x + sx, hi[1] + sy, z + sz],
                    fine,
                });
            }
        }
        let footprints: Vec<Rect> = level.objects.iter().map(|o| o.footprint()).collect();
        for (ri, room) in level.rooms.iter().enumerate() {
            let n = rng.range_usize(0, 3);
            if !room.floor_holes.is_empty() || !room.ceiling_holes.is_empty() {
                continue;
            }
            let blocked = keep_outs(level, ri);
            for _ in 0..n {
                let side = *rng.pick(&Side::ALL).unwrap_or(&Side::MinX);
                let (along, across) = (rng.range_f64(0.15, 0.4), rng.range_f64(0.15, 0.35));
                let height = rng.range_f64(0.1, 0.5);
                let gap = rng.range_f64(0.02, 0.1);
                let f = rng.unit_f64();
                let fine = *rng.pick(&CLUTTER_CATEGORIES).unwrap_or(&"box");
                let inner = room.rect.inflate(-WALL_T);
                let span = if side.along_x() { inner.w() } else { inner.d() } - along;
                if span <= 0.0 {
                    continue;
                }
                let u = f * span;
                let r = match side {
                    Side::MinX => Rect::new(
                        inner.x0 + gap,
                        inner.z0 + u,
                        inner.x0 + gap + across,
                        inner.z0 + u + along,
                    ),
                    Side::MaxX => Rect::new(
                        inner.x1 - gap - across,
                        inner.z0 + u,
                        inner.x1 - gap,
                        inner.z0 + u + along,
                    ),
                    Side::MinZ => Rect::new(
                        inner.x0 + u,
                        inner.z0 + gap,
                        inner.x0 + u + along,
                        inner.z0 + gap + across,
                    ),
                    Side::MaxZ => Rect::new(
                        inner.x0 + u,
                        inner.z1 - gap - across,
                        inner.x0 + u + along,
                        inner.z1 - gap,
                    ),
                };
                let grown = r.inflate(0.1);
                if blocked
                    .iter()
                    .chain(&footprints)
                    .any(|b| b.overlaps(&grown, 0.0))
                {
                    continue;
                }
                out.push(Clutter {
                    level: li,
                    room: ri,
                    min: [r.x0, level.base_y, r.z0],
                    max: [r.x1, level.base_y + height, r.z1],
                    fine,
                });
            }
        }
    }
    out
}

/// Cells of a quad along its two edges for cell edge `cell`.
fn cells(q: &Quad, cell: f64) -> (usize, usize) {
    let u = len3(sub3(q.c[1], q.c[0]));
    let v = len3(sub3(q.c[3], q.c[0]));
    (
        ((u / cell).ceil() as usize).max(1),
        ((v / cell).ceil() as usize).max(1),
    )
}

/// Triangles the quads make at cell edge `cell` (before holes).
fn count(quads: &[Quad], cell: f64) -> u64 {
    quads
        .iter()
        .map(|q| {
            let (nu, nv) = cells(q, cell);
            2 * (nu * nv) as u64
        })
        .sum()
}

/// The smallest cell edge (at least [`MIN_CELL`]) whose tessellation has at most `target`
/// triangles, by bisection in log space.
pub(super) fn cell_for(quads: &[Quad], target: u64) -> f64 {
    let (mut lo, mut hi) = (MIN_CELL.ln(), 20f64.ln());
    if count(quads, MIN_CELL) <= target {
        return MIN_CELL;
    }
    for _ in 0..48 {
        let mid = 0.5 * (lo + hi);
        if count(quads, mid.exp()) <= target {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi.exp()
}

/// A standard-normal-like draw in [−3, 3] (sum of three uniforms).
fn gauss(rng: &mut Rng) -> f64 {
    (rng.unit_f64() + rng.unit_f64() + rng.unit_f64() - 1.5) * 2.0
}

/// Tessellates the quads into the scan mesh: cells of the edge [`cell_for`] picks, each split
/// into two triangles; vertices moved along the quad's normal by clamped Gaussian noise; holes
/// cut into walls, ceilings and objects; floors, walls and ceilings split into segments of
/// about [`PATCH`] metres (objects keep one segment each).
pub(super) fn tessellate(quads: &[Quad], params: &ScanParams, rng: &mut Rng) -> MeshData {
    let cell = cell_for(quads, params.triangles);
    let mut out = MeshData::default();
    let budget = params.triangles as usize;
    out.positions.reserve(budget / 2 + 4 * quads.len());
    out.triangles.reserve(budget);
    out.labels.reserve(budget);
    // Segments: objects keep theirs; structure gets one per patch of each quad.
    let mut segments: std::collections::BTreeMap<i32, SegmentRec> = Default::default();
    let mut next_patch_id = 1i32;
    let mut keep: Vec<bool> = Vec::new();
    for q in quads {
        let (nu, nv) = cells(q, cell);
        let u = sub3(q.c[1], q.c[0]);
        let v = sub3(q.c[3], q.c[0]);
        let n = cross3(u, v);
        let nl = len3(n);
        let normal = if nl > 0.0 {
            [n[0] / nl, n[1] / nl, n[2] / nl]
        } else {
            [0.0, 0.0, 0.0]
        };
        // Cells kept: holes only off the floor.
        keep.clear();
        keep.resize(nu * nv, true);
        if q.kind != QuadKind::Floor {
            for k in keep.iter_mut() {
                if rng.chance(CELL_DROPOUT) {
                    *k = false;
                }
            }
            let area = nl;
            let holes = (area * HOLES_PER_M2 + rng.unit_f64()).floor() as usize;
            for _ in 0..holes {
                let (ci, cj) = (rng.unit_f64() * nu as f64, rng.unit_f64() * nv as f64);
                let r = rng.range_f64(HOLE_RADIUS.0, HOLE_RADIUS.1) / cell;
                let (i0, i1) = (
                    (ci - r).max(0.0) as usize,
                    ((ci + r).ceil() as usize).min(nu),
                );
                let (j0, j1) = (
                    (cj - r).max(0.0) as usize,
                    ((cj + r).ceil() as usize).min(nv),
                );
                for j in j0..j1 {
                    for i in i0..i1 {
                        let (di, dj) = (i as f64 + 0.5 - ci, j as f64 + 0.5 - cj);
                        if di * di + dj * dj <= r * r {
                            keep[j * nu + i] = false;
                        }
                    }
                }
            }
        }
        let base = out.positions.len() as u32;
        for j in 0..=nv {
            let fv = j as f64 / nv as f64;
            for i in 0..=nu {
                let fu = i as f64 / nu as f64;
                let d = (gauss(rng) * params.noise).clamp(-3.0 * params.noise, 3.0 * params.noise);
                let p = [
                    q.c[0][0] + u[0] * fu + v[0] * fv + normal[0] * d,
                    q.c[0][1] + u[1] * fu + v[1] * fv + normal[1] * d,
                    q.c[0][2] + u[2] * fu + v[2] * fv + normal[2] * d,
                ];
                let z = zup(p);
                out.positions.push([z[0] as f32, z[1] as f32, z[2] as f32]);
            }
        }
        let structure = q.kind != QuadKind::Object;
        // Patches of about PATCH metres: cell (i, j) is in patch (pi(i), pj(j)).
        let (lu, lv) = (len3(u), len3(v));
        let (pu, pv) = if structure {
            (
                ((lu / PATCH - 1e-9).ceil() as usize).max(1),
                ((lv / PATCH - 1e-9).ceil() as usize).max(1),
            )
        } else {
            (1, 1)
        };
        let patch = |k: usize, n: usize, len: f64, parts: usize| {
            (((k as f64 + 0.5) / n as f64 * len / PATCH) as usize).min(parts - 1)
        };
        let first_patch = next_patch_id;
        if structure {
            next_patch_id += (pu * pv) as i32;
        }
        let cell_area = nl / (nu * nv) as f64;
        let row = (nu + 1) as u32;
        for j in 0..nv {
            for i in 0..nu {
                if !keep[j * nu + i] {
                    continue;
                }
                let seg = if structure {
                    first_patch + (patch(j, nv, lv, pv) * pu + patch(i, nu, lu, pu)) as i32
                } else {
                    q.segment
                };
                let a = base + j as u32 * row + i as u32;
                let (b, c, d) = (a + 1, a + row + 1, a + row);
                out.triangles.push([a, b, c]);
                out.triangles.push([a, c, d]);
                out.labels.push([0, seg, q.category]);
                out.labels.push([0, seg, q.category]);
                let e = segments.entry(seg).or_insert(SegmentRec {
                    id: seg,
                    object: if structure {
                        -1
                    } else {
                        segment_object(q.segment)
                    },
                    area: 0.0,
                    bbox: EMPTY_BOX,
                });
                e.area += cell_area;
                let (f0, f1) = (i as f64 / nu as f64, (i + 1) as f64 / nu as f64);
                let (g0, g1) = (j as f64 / nv as f64, (j + 1) as f64 / nv as f64);
                for (fu, fv) in [(f0, g0), (f1, g1)] {
                    grow(
                        &mut e.bbox,
                        [
                            q.c[0][0] + u[0] * fu + v[0] * fv,
                            q.c[0][1] + u[1] * fu + v[1] * fv,
                            q.c[0][2] + u[2] * fu + v[2] * fv,
                        ],
                    );
                }
            }
        }
    }
    // Object segments (ids from 100000) sort after the patches (ids from 1).
    out.segments = segments.into_values().collect();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(side: f64, kind: QuadKind) -> Quad {
        Quad {
            c: [
                [0.0, 0.0, 0.0],
                [side, 0.0, 0.0],
                [side, side, 0.0],
                [0.0, side, 0.0],
            ],
            category: 1,
            segment: 3,
            kind,
        }
    }

    #[test]
    fn cell_size_meets_the_triangle_budget_from_below() {
        let quads = vec![square(2.0, QuadKind::Floor), square(1.0, QuadKind::Wall)];
        // 5 m² at cell c: 2·(ceil(2/c)² + ceil(1/c)²) triangles.
        let cell = cell_for(&quads, 10_000);
        let n = count(&quads, cell);
        assert!(n <= 10_000 && n > 9_000, "{n} triangles at {cell}");
        let expected =
            |c: f64| 2 * ((2.0f64 / c).ceil().powi(2) + (1.0f64 / c).ceil().powi(2)) as u64;
        assert_eq!(n, expected(cell));
    }

    #[test]
    fn floors_are_whole_and_flat_within_the_noise_and_split_into_patches() {
        let params = ScanParams {
            triangles: 20_000,
            noise: 0.003,
            seed: 1,
        };
        let quads = vec![square(3.0, QuadKind::Floor)];
        let mesh = tessellate(&quads, &params, &mut Rng::new(7));
        let cell = cell_for(&quads, params.triangles);
        let (nu, nv) = cells(&quads[0], cell);
        assert_eq!(mesh.triangles.len(), 2 * nu * nv, "floors are never holed");
        // y-up z = 0 plane is z-up y = 0: noise moves vertices along the normal only.
        for p in &mesh.positions {
            assert!(f64::from(p[1]).abs() <= 0.009 + 1e-6);
        }
        // A 3 m square in 1 m patches: 9 segments, areas adding up to 9 m².
        assert_eq!(mesh.segments.len(), 9);
        let area: f64 = mesh.segments.iter().map(|s| s.area).sum();
        assert!((area - 9.0).abs() < 1e-6);
    }

    #[test]
    fn walls_get_holes_and_keep_their_object_segment() {
        let params = ScanParams {
            triangles: 50_000,
            noise: 0.0,
            seed: 1,
        };
        let mut q = square(4.0, QuadKind::Object);
        q.segment = 100_004;
        let mesh = tessellate(&[q], &params, &mut Rng::new(3));
        let full = count(&[q], cell_for(&[q], params.triangles)) as usize;
        assert!(mesh.triangles.len() < full, "holes cut");
        assert!(mesh.triangles.len() > full * 8 / 10, "small holes only");
        assert_eq!(mesh.segments.len(), 1);
        assert_eq!(mesh.segments[0].object, 4);
        assert!(mesh.labels.iter().all(|l| l[1] == 100_004));
    }
}
