//! A bounding-volume hierarchy over a render scene's triangles, for casting the rays of small
//! images (see [`super::raycast`]): a four-wide BVH built with the binned surface-area
//! heuristic, traversed nearest child first with a watertight ray–triangle test.
//!
//! Hand-written rather than taken from a crate because it is specialised for one query —
//! the nearest hit of a primary ray between the near and far planes, ties broken by the
//! lowest triangle id so the answer is unique whatever order nodes are visited in — and the
//! crates that exist fit it less well: `bvh` builds a binary tree over nalgebra types, its
//! explicitly vectorised traversal needs a nightly compiler, and its ray query hands back
//! candidate shapes for the caller to test rather than pruning by the nearest hit found so
//! far; `obvhs` is closer (glam, CWBVH) but adds a dependency for ~400 lines. Here a node
//! holds the boxes of its four children side by side and a leaf its (up to four) triangles
//! side by side (struct of arrays, glam's `Vec4`), so the four slab tests of a node and the
//! four triangle tests of a leaf are straight-line vector code on stable Rust. `packet`
//! traces the four rays of a 2×2 pixel block together; `avx` does its node and leaf tests
//! two rays per 8-lane instruction where the CPU has AVX (detected at run time, the only
//! `unsafe` here: calling those functions and their loads), with the same answers bit for
//! bit; `build` builds the tree, large subtrees in parallel, the same tree on any number of
//! threads.
//!
//! Memory: a node is 128 bytes and there is about one node per seven triangles; a leaf is
//! 160 bytes (four triangles' corners and ids; a partly filled leaf repeats its first
//! triangle), about 70 MB per million triangles (71.6 MB measured by
//! [`Bvh::memory_bytes`] on the 1M-triangle dense bench house).

use glam::{Vec3, Vec4};

#[cfg(target_arch = "x86_64")]
mod avx;
mod build;
mod flat;
mod packet;
pub use packet::{Packet, PacketStack};

/// Largest number of triangles in a leaf.
const LEAF_MAX: usize = 4;
/// Below this depth splits follow the SAH; deeper, they halve the triangles, which bounds
/// the depth (and so the traversal stack) whatever the geometry.
const MEDIAN_DEPTH: u32 = 40;
/// Traversal stack entries: at most 3 per level plus one, and levels are bounded by
/// [`MEDIAN_DEPTH`] plus the halving levels of 2³² triangles.
const STACK: usize = 3 * (MEDIAN_DEPTH as usize + 34) + 1;
/// `count` of an unused child slot.
const EMPTY: u32 = u32::MAX;

/// Four children's boxes side by side, and what each child is.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
struct Node {
    /// `bounds[0]`: smallest x, y, z of each child's box; `bounds[1]`: largest (four
    /// children per lane group, so one slab test covers all four).
    bounds: [[Vec4; 3]; 2],
    /// Inner child: its node index; leaf child: its first triangle (leaf order).
    child: [u32; 4],
    /// 0 for an inner child, the triangle count for a leaf, [`EMPTY`] for an unused slot
    /// (unused slots come after the used ones).
    count: [u32; 4],
}

impl Node {
    /// A node with four unused slots; their boxes (all corners at +∞) no ray meets.
    const UNUSED: Node = Node {
        bounds: [[Vec4::INFINITY; 3]; 2],
        child: [0; 4],
        count: [EMPTY; 4],
    };
}

/// The (up to four) triangles of one leaf side by side, so that one ray meets all four in
/// one pass of four-lane arithmetic.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(16))]
struct Leaf {
    /// `corners[c][axis]`: lane `i` holds that coordinate of corner `c` of triangle `i`.
    corners: [[Vec4; 3]; 3],
    /// Scene triangle id per lane. Unused lanes repeat lane 0 (the same triangle again,
    /// which cannot change a nearest hit).
    ids: [u32; 4],
}

impl Leaf {
    /// The leaf of triangles `tris` (1 to [`LEAF_MAX`] scene ids) of `positions`.
    fn new(positions: &[Vec3], tris: &[u32]) -> Leaf {
        let lane = |i: usize| tris[if i < tris.len() { i } else { 0 }];
        let corner = |i: usize, c: usize| positions[3 * lane(i) as usize + c];
        Leaf {
            corners: std::array::from_fn(|c| {
                std::array::from_fn(|axis| {
                    Vec4::from_array(std::array::from_fn(|i| corner(i, c)[axis]))
                })
            }),
            ids: std::array::from_fn(lane),
        }
    }

    /// The three corners of the triangle in `lane`.
    fn triangle(&self, lane: usize) -> [Vec3; 3] {
        self.corners
            .map(|c| Vec3::new(c[0][lane], c[1][lane], c[2][lane]))
    }
}

/// The BVH of one scene's triangles.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// The leaves' triangles, four lanes per leaf.
    leaves: Vec<Leaf>,
    /// Number of triangles.
    triangles: usize,
}

/// The nearest hit of a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (`origin + t·dir`).
    pub t: f32,
    /// Scene triangle id.
    pub tri: u32,
    /// Where the triangle is stored (leaf × 4 + lane): a hint for [`Bvh::closest`] of a
    /// neighbouring ray.
    pub slot: u32,
}

/// A ray with everything its tests need precomputed.
#[derive(Debug, Clone, Copy)]
pub struct Ray {
    origin: Vec3,
    /// Reciprocal direction (components near zero replaced by a tiny number of their sign).
    inv: Vec3,
    /// `origin · inv`, so a slab distance is one multiply-subtract.
    origin_inv: Vec3,
    /// Per axis: which of a box's bounds the ray meets first (1, the largest coordinate,
    /// where the direction is negative).
    near_side: [usize; 3],
    /// Watertight test: the rows of the shear that maps the direction to +z (rows 0 and 1
    /// give the 2D coordinates, row 2 the scaled depth).
    shear: [Vec3; 3],
    t_min: f32,
    t_max: f32,
}

impl Ray {
    /// The ray `origin + t·dir` for `t` in `[t_min, t_max]` (`dir` need not be unit).
    pub fn new(origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Ray {
        let safe = |d: f32| {
            if d.abs() < 1e-20 {
                1e-20f32.copysign(d)
            } else {
                d
            }
        };
        let inv = Vec3::new(1.0 / safe(dir.x), 1.0 / safe(dir.y), 1.0 / safe(dir.z));
        let [kx, ky, kz] = shear_axes(dir);
        let d = dir.to_array();
        let (sx, sy, sz) = (d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
        let unit = |k: usize| Vec3::from_array(std::array::from_fn(|i| f32::from(i == k)));
        // Rows with one 1 and one −s (or one s): applied to a point they compute exactly
        // `p[kx] − sx·p[kz]` etc., as the paper's permuted form does, so triangles sharing
        // an edge see the same edge values and no ray slips between them.
        let shear = [
            unit(kx) - unit(kz) * sx,
            unit(ky) - unit(kz) * sy,
            unit(kz) * sz,
        ];
        Ray {
            origin,
            inv,
            origin_inv: origin * inv,
            near_side: [
                usize::from(inv.x < 0.0),
                usize::from(inv.y < 0.0),
                usize::from(inv.z < 0.0),
            ],
            shear,
            t_min,
            t_max,
        }
    }

    /// The ray parameter where the ray meets the triangle, if within `[t_min, t_max]`;
    /// both faces count. Watertight: a ray through a shared edge or vertex meets at least
    /// one of the triangles.
    #[inline]
    fn triangle(&self, p: &[Vec3; 3], t_max: f32) -> Option<f32> {
        let [r0, r1, r2] = self.shear;
        let (a, b, c) = (p[0] - self.origin, p[1] - self.origin, p[2] - self.origin);
        let (ax, ay) = (r0.dot(a), r1.dot(a));
        let (bx, by) = (r0.dot(b), r1.dot(b));
        let (cx, cy) = (r0.dot(c), r1.dot(c));
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // On an edge in single precision: decide in double precision (the same rows,
            // widened).
            let [q0, q1] = [r0.as_dvec3(), r1.as_dvec3()];
            let o = self.origin.as_dvec3();
            let (a, b, c) = (
                p[0].as_dvec3() - o,
                p[1].as_dvec3() - o,
                p[2].as_dvec3() - o,
            );
            let (ax, ay, bx, by, cx, cy) = (
                q0.dot(a),
                q1.dot(a),
                q0.dot(b),
                q1.dot(b),
                q0.dot(c),
                q1.dot(c),
            );
            u = (cx * by - cy * bx) as f32;
            v = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let t = (u * r2.dot(a) + v * r2.dot(b) + w * r2.dot(c)) / det;
        (t >= self.t_min && t <= t_max).then_some(t)
    }
}

/// The axes `[kx, ky, kz]` of the watertight ray–triangle test (Woop, Benthin and Wald
/// 2013) for direction `dir`: the axis where the direction is largest becomes z, the other
/// two keep a right-handed order (swapped when the z component is negative).
fn shear_axes(dir: Vec3) -> [usize; 3] {
    let a = dir.abs().to_array();
    let kz = if a[0] >= a[1] && a[0] >= a[2] {
        0
    } else if a[1] >= a[2] {
        1
    } else {
        2
    };
    let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
    if dir[kz] < 0.0 {
        [ky, kx, kz]
    } else {
        [kx, ky, kz]
    }
}

impl Ray {
    /// Folds the hits of `leaf`'s four lanes (leaf number `index`) into `best`: the nearest
    /// hit, ties to the lowest triangle id. The lanes are computed exactly as
    /// [`Ray::triangle`] computes one triangle (same operations in the same order), and a
    /// lane with an edge value of exactly 0 is handed to it for the double-precision
    /// decision, so both give the same answer bit for bit.
    #[inline(always)]
    fn leaf(&self, leaf: &Leaf, index: u32, best: &mut Hit) {
        let [r0, r1, r2] = self.shear;
        let o = self.origin;
        let rel = |c: usize| {
            let p = &leaf.corners[c];
            [
                p[0] - Vec4::splat(o.x),
                p[1] - Vec4::splat(o.y),
                p[2] - Vec4::splat(o.z),
            ]
        };
        let dot = |r: Vec3, p: &[Vec4; 3]| {
            Vec4::splat(r.x) * p[0] + Vec4::splat(r.y) * p[1] + Vec4::splat(r.z) * p[2]
        };
        let (a, b, c) = (rel(0), rel(1), rel(2));
        let (ax, ay) = (dot(r0, &a), dot(r1, &a));
        let (bx, by) = (dot(r0, &b), dot(r1, &b));
        let (cx, cy) = (dot(r0, &c), dot(r1, &c));
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let zero = Vec4::ZERO;
        let on_edge = (u.cmpeq(zero) | v.cmpeq(zero) | w.cmpeq(zero)).bitmask();
        let outside = (u.cmplt(zero) | v.cmplt(zero) | w.cmplt(zero))
            & (u.cmpgt(zero) | v.cmpgt(zero) | w.cmpgt(zero));
        let det = u + v + w;
        let t = (u * dot(r2, &a) + v * dot(r2, &b) + w * dot(r2, &c)) / det;
        let met = !outside
            & det.cmpne(zero)
            & det.abs().cmplt(Vec4::INFINITY)
            & t.cmpge(Vec4::splat(self.t_min))
            & t.cmple(Vec4::splat(best.t));
        fold(
            leaf,
            index,
            t.to_array(),
            met.bitmask() | on_edge,
            on_edge,
            best,
            |lane, t_max| self.edge_lane(leaf, lane, t_max),
        );
    }

    /// [`Ray::triangle`] on the triangle in `leaf`'s `lane`: the rare lanes with an edge
    /// value of exactly 0, kept out of line so the common path stays small.
    #[cold]
    #[inline(never)]
    fn edge_lane(&self, leaf: &Leaf, lane: usize, t_max: f32) -> Option<f32> {
        self.triangle(&leaf.triangle(lane), t_max)
    }
}

/// A ray's entry and exit distances for each of `node`'s four children (lane = child),
/// clipped to `[t_min, limit]` (the box is met where entry ≤ exit): `near_side` and the
/// reciprocal direction and `origin · inv` (splatted per axis) are the ray's. The one box
/// test of every traversal, so single rays and packets compute the same values; the AVX
/// kernels (`avx.rs`) repeat its operations in the same order.
#[inline(always)]
fn slabs(
    node: &Node,
    [sx, sy, sz]: [usize; 3],
    [ix, iy, iz]: [Vec4; 3],
    [ox, oy, oz]: [Vec4; 3],
    t_min: Vec4,
    limit: Vec4,
) -> (Vec4, Vec4) {
    let b = &node.bounds;
    let near = (b[sx][0] * ix - ox)
        .max(b[sy][1] * iy - oy)
        .max(b[sz][2] * iz - oz)
        .max(t_min);
    let far = (b[sx ^ 1][0] * ix - ox)
        .min(b[sy ^ 1][1] * iy - oy)
        .min(b[sz ^ 1][2] * iz - oz)
        .min(limit);
    (near, far)
}

/// Folds a leaf's lanes into `best` (leaf number `index`): `t` holds each lane's
/// single-precision distance, `lanes` the lanes met or `on_edge`, and `on_edge` those to
/// decide again with `edge(lane, t_max)` (the ray's [`Ray::triangle`] in double precision).
/// Nearest hit, ties to the lowest triangle id.
#[inline(always)]
fn fold(
    leaf: &Leaf,
    index: u32,
    t: [f32; 4],
    lanes: u32,
    on_edge: u32,
    best: &mut Hit,
    edge: impl Fn(usize, f32) -> Option<f32>,
) {
    let mut lanes = lanes;
    while lanes != 0 {
        let lane = lanes.trailing_zeros() as usize;
        lanes &= lanes - 1;
        let t = if on_edge & (1 << lane) != 0 {
            match edge(lane, best.t) {
                Some(t) => t,
                None => continue,
            }
        } else {
            t[lane]
        };
        let tri = leaf.ids[lane];
        // Earlier lanes may have moved `best` nearer: only as near or nearer counts, and
        // equal distances go to the lowest id.
        if t < best.t || (t == best.t && tri < best.tri) {
            *best = Hit {
                t,
                tri,
                slot: index * 4 + lane as u32,
            };
        }
    }
}

impl Bvh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles
    }

    /// Bytes the hierarchy holds (nodes and leaves; for the render bench).
    #[cfg(feature = "internals")]
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>()
            + self.leaves.len() * std::mem::size_of::<Leaf>()
    }

    /// The nearest hit of `ray` (ties: the lowest triangle id), trying the triangle at leaf
    /// position `hint` first (a neighbouring pixel's hit) so that farther nodes are skipped
    /// from the start. The answer does not depend on the hint.
    pub fn closest(&self, ray: &Ray, hint: Option<u32>) -> Option<Hit> {
        self.closest_with(ray, hint, &mut Stack::default())
    }

    /// [`Bvh::closest`] with a traversal stack kept between rays.
    pub fn closest_with(&self, ray: &Ray, hint: Option<u32>, stack: &mut Stack) -> Option<Hit> {
        let mut best = Hit {
            t: ray.t_max,
            tri: u32::MAX,
            slot: u32::MAX,
        };
        if self.leaves.is_empty() {
            return None;
        }
        if let Some(leaf) = hint.map(|slot| slot / 4) {
            if let Some(l) = self.leaves.get(leaf as usize) {
                ray.leaf(l, leaf, &mut best);
            }
        }
        // Entries: (child, count, entry distance); count 0 is an inner node. A fixed-size
        // array with its own top, so pushing is a store.
        let entries = &mut stack.0;
        let mut top = 0;
        let inv = ray.inv.to_array().map(Vec4::splat);
        let origin_inv = ray.origin_inv.to_array().map(Vec4::splat);
        let t_min = Vec4::splat(ray.t_min);
        // The node or leaf being visited: (child, count) as in the entries.
        let (mut child, mut count) = (0u32, 0u32);
        'visit: loop {
            if count == 0 {
                // An inner node: the four slab tests side by side, a bit per child hit.
                let node = &self.nodes[child as usize];
                let limit = Vec4::splat(best.t);
                let (near, far) = slabs(node, ray.near_side, inv, origin_inv, t_min, limit);
                // Unused slots are never hit (their boxes are empty at +∞), and were one
                // reached it would only test leaf 0's real triangles once more.
                let mut mask = near.cmple(far).bitmask();
                if mask != 0 {
                    let k = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if mask == 0 {
                        // One child hit (the common case deep in the tree): no ordering.
                        (child, count) = (node.child[k], node.count[k]);
                        continue 'visit;
                    }
                    // The nearest hit child is visited next; the others are pushed,
                    // farthest deepest, each above the (this node's) farther ones.
                    let near = near.to_array();
                    let base = top;
                    let mut next = (node.child[k], node.count[k], near[k]);
                    while mask != 0 {
                        let k = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        let mut e = (node.child[k], node.count[k], near[k]);
                        if e.2 < next.2 {
                            std::mem::swap(&mut e, &mut next);
                        }
                        let mut i = top;
                        while i > base && entries[i - 1].2 < e.2 {
                            entries[i] = entries[i - 1];
                            i -= 1;
                        }
                        entries[i] = e;
                        top += 1;
                    }
                    (child, count) = (next.0, next.1);
                    continue 'visit;
                }
            } else {
                ray.leaf(&self.leaves[child as usize], child, &mut best);
            }
            // Next: the nearest pushed entry the ray may still reach before its best hit.
            loop {
                if top == 0 {
                    break 'visit;
                }
                top -= 1;
                let (c, n, entry) = entries[top];
                if entry <= best.t {
                    (child, count) = (c, n);
                    continue 'visit;
                }
            }
        }
        (best.tri != u32::MAX).then_some(best)
    }
}

/// A traversal stack, kept between rays so that a ray allocates nothing.
#[derive(Debug, Clone)]
pub struct Stack(Box<[(u32, u32, f32); STACK]>);

impl Default for Stack {
    fn default() -> Self {
        Stack(Box::new([(0, 0, 0.0); STACK]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seed::Rng;

    fn random_triangles(rng: &mut Rng, n: usize) -> Vec<Vec3> {
        let mut r = || rng.range_f64(-1.0, 1.0) as f32;
        let mut out = Vec::new();
        for _ in 0..n {
            let c = Vec3::new(r() * 5.0, r() * 5.0, r() * 5.0);
            let size = 0.05 + 0.5 * r().abs();
            for _ in 0..3 {
                out.push(c + Vec3::new(r(), r(), r()) * size);
            }
        }
        out
    }

    /// Möller–Trumbore in double precision over every triangle: an independent answer.
    fn brute_force(positions: &[Vec3], o: Vec3, d: Vec3, t_min: f64, t_max: f64) -> Option<f64> {
        let (o, d) = (o.as_dvec3(), d.as_dvec3());
        let mut best: Option<f64> = None;
        for p in positions.chunks_exact(3) {
            let (a, b, c) = (p[0].as_dvec3(), p[1].as_dvec3(), p[2].as_dvec3());
            let (e1, e2) = (b - a, c - a);
            let h = d.cross(e2);
            let det = e1.dot(h);
            if det.abs() < 1e-15 {
                continue;
            }
            let s = o - a;
            let u = s.dot(h) / det;
            let q = s.cross(e1);
            let v = d.dot(q) / det;
            if u < 0.0 || v < 0.0 || u + v > 1.0 {
                continue;
            }
            let t = e2.dot(q) / det;
            if t >= t_min && t <= t_max && best.is_none_or(|b| t < b) {
                best = Some(t);
            }
        }
        best
    }

    #[test]
    fn nearest_hits_match_brute_force_on_random_rays() {
        let mut rng = Rng::new(7);
        let positions = random_triangles(&mut rng, 3000);
        let bvh = Bvh::new(&positions);
        assert_eq!(bvh.triangle_count(), 3000);
        let (mut hits, mut near_edges) = (0, 0);
        for _ in 0..4000 {
            let mut r = || rng.range_f64(-1.0, 1.0) as f32;
            let o = Vec3::new(r() * 7.0, r() * 7.0, r() * 7.0);
            let d = Vec3::new(r(), r(), r());
            if d.length() < 1e-3 {
                continue;
            }
            let got = bvh.closest(&Ray::new(o, d, 0.01, 100.0), None);
            let want = brute_force(&positions, o, d, 0.01, 100.0);
            match (got, want) {
                (Some(g), Some(w)) => {
                    hits += 1;
                    let tol = 1e-4 * (1.0 + w);
                    if (f64::from(g.t) - w).abs() > tol {
                        // Different triangles may be hit only where the ray grazes an edge;
                        // the hit triangle must still be met at the reported distance.
                        near_edges += 1;
                    }
                    let p = &positions[3 * g.tri as usize..3 * g.tri as usize + 3];
                    let again = brute_force(p, o, d, 0.0, 1e9).expect("hit triangle is hit");
                    assert!((again - f64::from(g.t)).abs() < 1e-3 * (1.0 + again));
                }
                (None, None) => {}
                (g, w) => panic!("ray {o} {d}: bvh {g:?}, brute force {w:?}"),
            }
        }
        assert!(hits > 500, "rays should often hit: {hits}");
        assert!(near_edges <= 2, "{near_edges} rays disagree");
    }

    #[test]
    fn four_lanes_give_the_one_triangle_tests_answers_bit_for_bit() {
        let mut rng = Rng::new(11);
        let mut checked = 0;
        for case in 0..3000 {
            // Random triangles, and every fourth case a fan sharing one vertex that the
            // ray aims at exactly (edge values of 0: the double-precision lanes).
            let n = 1 + case % 4;
            let positions = if case % 4 == 3 {
                let c = Vec3::new(0.0, 0.0, -3.0);
                (0..n)
                    .flat_map(|i| {
                        let a = i as f32;
                        [
                            c,
                            c + Vec3::new(a.cos(), a.sin(), 0.0),
                            c + Vec3::new((a + 1.0).cos(), (a + 1.0).sin(), 0.0),
                        ]
                    })
                    .collect()
            } else {
                random_triangles(&mut rng, n)
            };
            let ids: Vec<u32> = (0..n as u32).map(|i| (i * 7 + case as u32) % 5).collect();
            let mut scene = vec![Vec3::ZERO; 3 * 5];
            for (k, &id) in ids.iter().enumerate() {
                scene[3 * id as usize..3 * id as usize + 3]
                    .copy_from_slice(&positions[3 * k..3 * k + 3]);
            }
            let mut ids = ids;
            ids.sort_unstable();
            ids.dedup();
            let leaf = Leaf::new(&scene, &ids);
            let mut r = || rng.range_f64(-1.0, 1.0) as f32;
            let (o, d) = if case % 4 == 3 {
                (Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0))
            } else {
                (
                    Vec3::new(r() * 6.0, r() * 6.0, r() * 6.0),
                    Vec3::new(r(), r(), r()),
                )
            };
            let ray = Ray::new(o, d, 0.01, 50.0);
            let mut lanes = Hit {
                t: ray.t_max,
                tri: u32::MAX,
                slot: u32::MAX,
            };
            ray.leaf(&leaf, 3, &mut lanes);
            let mut one = Hit {
                t: ray.t_max,
                tri: u32::MAX,
                slot: u32::MAX,
            };
            for (lane, &id) in ids.iter().enumerate() {
                let corners = [
                    scene[3 * id as usize],
                    scene[3 * id as usize + 1],
                    scene[3 * id as usize + 2],
                ];
                if let Some(t) = ray.triangle(&corners, one.t) {
                    if t < one.t || id < one.tri {
                        one = Hit {
                            t,
                            tri: id,
                            slot: 12 + lane as u32,
                        };
                    }
                }
            }
            assert_eq!(lanes.t.to_bits(), one.t.to_bits(), "case {case}");
            assert_eq!((lanes.tri, lanes.slot), (one.tri, one.slot), "case {case}");
            checked += usize::from(one.tri != u32::MAX);
        }
        assert!(checked > 600, "rays should often hit: {checked}");
    }

    #[test]
    fn a_hint_never_changes_the_answer_and_ties_go_to_the_lowest_id() {
        // Two copies of the same quad: every hit ties, and the lower ids must win.
        let quad = [
            Vec3::new(-1.0, -1.0, -2.0),
            Vec3::new(1.0, -1.0, -2.0),
            Vec3::new(1.0, 1.0, -2.0),
            Vec3::new(-1.0, -1.0, -2.0),
            Vec3::new(1.0, 1.0, -2.0),
            Vec3::new(-1.0, 1.0, -2.0),
        ];
        let positions: Vec<Vec3> = quad.iter().chain(quad.iter()).copied().collect();
        let bvh = Bvh::new(&positions);
        for (x, y) in [(0.5, -0.5), (-0.5, 0.5), (0.3, 0.1)] {
            let ray = Ray::new(Vec3::ZERO, Vec3::new(x, y, -1.0), 0.1, 10.0);
            let plain = bvh.closest(&ray, None).expect("hit");
            assert!(plain.tri < 2, "lowest id wins a tie: {plain:?}");
            assert!((plain.t - 2.0).abs() < 1e-5);
            for hint in 0..4 {
                assert_eq!(
                    bvh.closest(&ray, Some(hint)).map(|h| h.tri),
                    Some(plain.tri)
                );
            }
        }
    }

    #[test]
    fn rays_through_shared_edges_and_vertices_never_slip_through() {
        // A fan of thin triangles around the origin, all sharing the centre vertex; rays
        // straight at the centre and along each spoke must hit.
        let n = 64;
        let mut positions = Vec::new();
        for i in 0..n {
            let angle = |k: usize| k as f32 / n as f32 * std::f32::consts::TAU;
            positions.push(Vec3::new(0.0, 0.0, -3.0));
            positions.push(Vec3::new(angle(i).cos(), angle(i).sin(), -3.0));
            positions.push(Vec3::new(angle(i + 1).cos(), angle(i + 1).sin(), -3.0));
        }
        let bvh = Bvh::new(&positions);
        let eye = Vec3::new(0.013, -0.021, 0.0);
        let centre = Vec3::new(0.0, 0.0, -3.0) - eye;
        assert!(bvh
            .closest(&Ray::new(eye, centre, 0.0, 10.0), None)
            .is_some());
        for i in 0..n {
            let p = positions[3 * i + 1] * 0.5 + Vec3::new(0.0, 0.0, -1.5);
            assert!(
                bvh.closest(&Ray::new(eye, p - eye, 0.0, 10.0), None)
                    .is_some(),
                "spoke {i}"
            );
        }
    }

    #[test]
    fn empty_degenerate_and_coincident_triangles_do_not_panic() {
        let empty = Bvh::new(&[]);
        let ray = Ray::new(Vec3::ZERO, Vec3::NEG_Z, 0.0, 10.0);
        assert_eq!(empty.closest(&ray, Some(3)), None);
        // Zero-area triangles (a point, a line) are never hit; many coincident ones build.
        let p = Vec3::new(0.0, 0.0, -1.0);
        let mut positions = vec![p, p, p, p, p + Vec3::X, p + Vec3::X * 2.0];
        for _ in 0..100 {
            positions.extend([
                Vec3::new(-1.0, -1.0, -5.0),
                Vec3::new(1.0, -1.0, -5.0),
                Vec3::new(0.0, 1.0, -5.0),
            ]);
        }
        let bvh = Bvh::new(&positions);
        let hit = bvh.closest(&ray, None).expect("the coincident triangles");
        assert_eq!(hit.tri, 2, "lowest id of the coincident ones");
        assert!((hit.t - 5.0).abs() < 1e-5);
        // Outside [t_min, t_max] nothing counts.
        assert_eq!(
            bvh.closest(&Ray::new(Vec3::ZERO, Vec3::NEG_Z, 0.0, 4.0), None),
            None
        );
        assert_eq!(
            bvh.closest(&Ray::new(Vec3::ZERO, Vec3::NEG_Z, 6.0, 9.0), None),
            None
        );
    }
}
