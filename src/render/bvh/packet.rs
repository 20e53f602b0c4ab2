//! Four rays from one origin traced through the BVH together: the rays of a 2×2 block of
//! pixels. Each node is fetched and ordered once for the four: every ray tests the node's
//! four children's boxes side by side (a lane per child) exactly as a single ray does, two
//! rays per instruction where the CPU has AVX ([`super::avx`]), and a leaf is met only by
//! the rays whose own box test reached it. Primary rays of neighbouring pixels visit nearly
//! the same nodes, so the packet pays the memory traffic and the hard-to-predict branches of
//! a traversal once instead of four times.
//!
//! The answer is each ray's own nearest hit, ties to the lowest triangle id, exactly as
//! [`Bvh::closest`] gives it, with or without AVX: a ray's box tests compute the same values
//! as the single-ray test (the same rounded operations in the same order), every ancestor of
//! a ray's nearest triangle passes that ray's test, and a leaf's triangles are met with the
//! same four-lane test.

use glam::{Mat4, Vec3, Vec4};

use super::{slabs, Bvh, Hit, Leaf, Node, Ray, STACK};
use crate::prefetch::prefetch;

/// Rows of [`Packet::lanes`]: the reciprocal direction (x, y, z), then `origin · inv`
/// (x, y, z), then the shear's rows (row × 3 + component).
pub(super) const INV: usize = 0;
/// First row of `origin · inv` in [`Packet::lanes`].
pub(super) const ORIGIN_INV: usize = 3;
/// First row of the shear in [`Packet::lanes`].
pub(super) const SHEAR: usize = 6;

/// Four rays sharing an origin, their constants a lane per ray.
#[derive(Debug, Clone, Copy)]
pub struct Packet {
    pub(super) origin: Vec3,
    pub(super) t_min: f32,
    pub(super) t_max: f32,
    /// Per axis, a bit per ray: set where the ray meets a box's largest coordinate first
    /// (its direction is negative; [`Ray`]'s `near_side`).
    pub(super) sides: [u32; 3],
    /// `lanes[q]`: quantity `q` (see [`INV`], [`ORIGIN_INV`], [`SHEAR`]) of the four rays,
    /// lane `r` for ray `r`.
    pub(super) lanes: [Vec4; 15],
}

impl Packet {
    /// The rays `origin + t·dirs[i]` for `t` in `[t_min, t_max]`: each ray exactly as
    /// [`Ray::new`] makes it, four lanes at a time with the same operations.
    pub fn new(origin: Vec3, dirs: [Vec3; 4], t_min: f32, t_max: f32) -> Packet {
        let lanes = |axis: usize| Vec4::from_array(dirs.map(|d| d[axis]));
        let d = [lanes(0), lanes(1), lanes(2)];
        // Ray::new's `safe` and reciprocal, lane by lane (the same IEEE operations).
        let tiny = Vec4::splat(1e-20);
        let safe = |v: Vec4| Vec4::select(v.abs().cmplt(tiny), tiny.copysign(v), v);
        let inv = d.map(|v| Vec4::ONE / safe(v));
        let origin_inv = [
            Vec4::splat(origin.x) * inv[0],
            Vec4::splat(origin.y) * inv[1],
            Vec4::splat(origin.z) * inv[2],
        ];
        let shear = match shared_axes(&d) {
            Some(axes) => shear_lanes(&d, axes),
            None => {
                let rays = dirs.map(|dir| Ray::new(origin, dir, t_min, t_max));
                std::array::from_fn(|row| {
                    std::array::from_fn(|c| Vec4::from_array(rays.map(|r| r.shear[row][c])))
                })
            }
        };
        let [[s0, s1, s2], [s3, s4, s5], [s6, s7, s8]] = shear;
        let [i0, i1, i2] = inv;
        let [o0, o1, o2] = origin_inv;
        Packet {
            origin,
            t_min,
            t_max,
            sides: inv.map(|v| v.cmplt(Vec4::ZERO).bitmask()),
            lanes: [i0, i1, i2, o0, o1, o2, s0, s1, s2, s3, s4, s5, s6, s7, s8],
        }
    }

    /// Ray `r`, as [`Ray::new`] makes it.
    pub(super) fn ray(&self, r: usize) -> Ray {
        let v = |q: usize| Vec3::new(self.lanes[q][r], self.lanes[q + 1][r], self.lanes[q + 2][r]);
        Ray {
            origin: self.origin,
            inv: v(INV),
            origin_inv: v(ORIGIN_INV),
            near_side: self.near_side(r),
            shear: [v(SHEAR), v(SHEAR + 3), v(SHEAR + 6)],
            t_min: self.t_min,
            t_max: self.t_max,
        }
    }

    /// Ray `r`'s `near_side` ([`Ray`]).
    #[inline]
    pub(super) fn near_side(&self, r: usize) -> [usize; 3] {
        self.sides.map(|s| ((s >> r) & 1) as usize)
    }
}

/// The axes of [`Ray::new`]'s watertight shear ([`super::shear_axes`]) for directions `d` (lanes
/// per axis), when all four share them.
#[inline]
fn shared_axes(d: &[Vec4; 3]) -> Option<[usize; 3]> {
    let a = d.map(Vec4::abs);
    // shear_axes lane by lane: z is x where x is largest, else y where y ≥ z, else z.
    let x = (a[0].cmpge(a[1]) & a[0].cmpge(a[2])).bitmask();
    let y = !x & a[1].cmpge(a[2]).bitmask() & 0xF;
    let kz = match (x, y) {
        (0xF, _) => 0,
        (0, 0xF) => 1,
        (0, 0) => 2,
        _ => return None,
    };
    let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
    match d[kz].cmplt(Vec4::ZERO).bitmask() {
        0 => Some([kx, ky, kz]),
        0xF => Some([ky, kx, kz]),
        _ => None,
    }
}

/// The shear rows of the four rays of directions `d` (lanes per axis) sharing shear axes
/// `[kx, ky, kz]`, `[row][component]` a lane per ray: [`Ray::new`]'s values with the same
/// operations.
#[inline]
fn shear_lanes(d: &[Vec4; 3], [kx, ky, kz]: [usize; 3]) -> [[Vec4; 3]; 3] {
    let (sx, sy, sz) = (d[kx] / d[kz], d[ky] / d[kz], Vec4::ONE / d[kz]);
    let unit = |k: usize, c: usize| Vec4::splat(f32::from(k == c));
    // Row r, component c, exactly as `unit(k) - unit(kz) * s` (row 2: `unit(kz) * sz`).
    let row = |k: usize, s: Vec4| std::array::from_fn(|c| unit(k, c) - unit(kz, c) * s);
    [
        row(kx, sx),
        row(ky, sy),
        std::array::from_fn(|c| unit(kz, c) * sz),
    ]
}

/// A traversal stack for packets, kept between packets so that a packet allocates nothing;
/// it also holds the choice of instructions (AVX where the CPU has it), made once.
#[derive(Debug, Clone)]
pub struct PacketStack {
    entries: Box<[Entry; STACK]>,
    avx: bool,
}

impl Default for PacketStack {
    /// A stack that traces with AVX where this CPU has it.
    fn default() -> Self {
        #[cfg(target_arch = "x86_64")]
        let avx = std::is_x86_feature_detected!("avx");
        #[cfg(not(target_arch = "x86_64"))]
        let avx = false;
        PacketStack {
            entries: Box::new([Entry::default(); STACK]),
            avx,
        }
    }
}

#[cfg(test)]
impl PacketStack {
    /// A stack that traces without AVX on any CPU (the answers are the same bit for bit;
    /// for tests and comparisons).
    pub fn portable() -> Self {
        PacketStack {
            avx: false,
            ..PacketStack::default()
        }
    }

    /// Whether packets traced with this stack use AVX.
    pub fn uses_avx(&self) -> bool {
        self.avx
    }
}

/// A node or leaf to visit: what it is and where each ray enters it.
#[derive(Debug, Clone, Copy, Default)]
struct Entry {
    child: u32,
    /// 0 for an inner node, else a leaf's triangle count.
    count: u32,
    /// The smallest entry distance of its rays (the visiting order).
    first: f32,
    /// Each ray's entry distance; +∞ for a ray whose box test did not reach it.
    near: Vec4,
}

/// What a packet's rays make of one node: `near[r]` holds ray `r`'s entry distance to each
/// child (lane = child), +∞ where its box test misses.
pub(super) type NodeHits = [Vec4; 4];

/// The two tests of a packet traversal, with what they precompute per packet.
pub(super) trait Kernels {
    /// Each ray's test of `node`'s four children, as [`Bvh::closest`] tests them.
    /// `limit[r]` is ray `r`'s best hit so far, or −∞ for a ray not to test.
    fn node(&self, packet: &Packet, node: &Node, limit: Vec4) -> NodeHits;
    /// Folds leaf number `index` into the best hits of the rays in the bit mask `rays`.
    fn leaf(&self, packet: &Packet, leaf: &Leaf, index: u32, rays: u32, best: &mut [Hit; 4]);
}

/// The kernels for any CPU: a ray at a time, four lanes wide.
struct Portable;

impl Kernels for Portable {
    #[inline(always)]
    fn node(&self, packet: &Packet, node: &Node, limit: Vec4) -> NodeHits {
        let q = &packet.lanes;
        let t_min = Vec4::splat(packet.t_min);
        let lane = |v: Vec4, r: usize| Vec4::splat(v[r]);
        std::array::from_fn(|r| {
            let inv = [q[INV], q[INV + 1], q[INV + 2]].map(|v| lane(v, r));
            let origin_inv =
                [q[ORIGIN_INV], q[ORIGIN_INV + 1], q[ORIGIN_INV + 2]].map(|v| lane(v, r));
            let (n, f) = slabs(
                node,
                packet.near_side(r),
                inv,
                origin_inv,
                t_min,
                lane(limit, r),
            );
            Vec4::select(n.cmple(f), n, Vec4::INFINITY)
        })
    }

    #[inline(always)]
    fn leaf(&self, packet: &Packet, leaf: &Leaf, index: u32, rays: u32, best: &mut [Hit; 4]) {
        let mut rays = rays;
        while rays != 0 {
            let i = rays.trailing_zeros() as usize;
            rays &= rays - 1;
            packet.ray(i).leaf(leaf, index, &mut best[i]);
        }
    }
}

impl Bvh {
    /// Asks the CPU to start loading the children of `node` in the bit mask `children`
    /// (the next is visited after the others are ordered, the rest later).
    #[inline(always)]
    fn prefetch(&self, node: &Node, children: u32) {
        let mut children = children;
        while children != 0 {
            let k = children.trailing_zeros() as usize;
            children &= children - 1;
            let child = node.child[k] as usize;
            if node.count[k] == 0 {
                prefetch(&self.nodes, child);
            } else {
                prefetch(&self.leaves, child);
            }
        }
    }

    /// The nearest hit of each of the packet's rays, as [`Bvh::closest`] finds it.
    pub fn closest_packet(&self, packet: &Packet, stack: &mut PacketStack) -> [Option<Hit>; 4] {
        #[cfg(target_arch = "x86_64")]
        if stack.avx {
            // SAFETY: `avx` is set only where the CPU has AVX.
            return unsafe { self.closest_packet_avx(packet, stack) };
        }
        self.trace(&Portable, packet, stack)
    }

    /// [`Bvh::closest_packet`] compiled for AVX, with AVX's kernels.
    ///
    /// # Safety
    /// The CPU must have AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn closest_packet_avx(
        &self,
        packet: &Packet,
        stack: &mut PacketStack,
    ) -> [Option<Hit>; 4] {
        // SAFETY: the caller's CPU has AVX.
        let kernels = unsafe { super::avx::Avx::new(packet) };
        self.trace(&kernels, packet, stack)
    }

    /// The traversal, with the given kernels.
    #[inline(always)]
    fn trace<K: Kernels>(
        &self,
        kernels: &K,
        packet: &Packet,
        stack: &mut PacketStack,
    ) -> [Option<Hit>; 4] {
        let mut best = [Hit {
            t: packet.t_max,
            tri: u32::MAX,
            slot: u32::MAX,
        }; 4];
        if self.leaves.is_empty() {
            return [None; 4];
        }
        let mut best_t = Vec4::from_array(best.map(|h| h.t));
        let entries = &mut stack.entries;
        let mut top = 0;
        let t_min = packet.t_min;
        let mut at = Entry {
            child: 0,
            count: 0,
            first: t_min,
            near: Vec4::splat(t_min),
        };
        'visit: loop {
            // The rays that may still meet something here before their best hit.
            let rays = at.near.cmple(best_t);
            if at.count == 0 {
                let node = &self.nodes[at.child as usize];
                let limit = Vec4::select(rays, best_t, Vec4::NEG_INFINITY);
                let near = kernels.node(packet, node, limit);
                // Lane k of `first`: the smallest entry of a ray into child k (+∞: none).
                let first = near[0].min(near[1]).min(near[2]).min(near[3]);
                let mut children = first.cmplt(Vec4::INFINITY).bitmask();
                if children != 0 {
                    self.prefetch(node, children);
                    // Column k: each ray's entry into child k.
                    let columns = Mat4::from_cols(near[0], near[1], near[2], near[3])
                        .transpose()
                        .to_cols_array_2d();
                    let first = first.to_array();
                    let entry = |k: usize| Entry {
                        child: node.child[k],
                        count: node.count[k],
                        first: first[k],
                        near: Vec4::from_array(columns[k]),
                    };
                    // The nearest reached child is visited next; the others are pushed,
                    // farthest deepest, each above this node's farther ones.
                    let mut next = entry(children.trailing_zeros() as usize);
                    children &= children - 1;
                    let base = top;
                    while children != 0 {
                        let mut e = entry(children.trailing_zeros() as usize);
                        children &= children - 1;
                        if e.first < next.first {
                            std::mem::swap(&mut e, &mut next);
                        }
                        let mut i = top;
                        while i > base && entries[i - 1].first < e.first {
                            entries[i] = entries[i - 1];
                            i -= 1;
                        }
                        entries[i] = e;
                        top += 1;
                    }
                    at = next;
                    continue 'visit;
                }
            } else {
                let leaf = &self.leaves[at.child as usize];
                kernels.leaf(packet, leaf, at.child, rays.bitmask(), &mut best);
                best_t = Vec4::from_array(best.map(|h| h.t));
            }
            // Next: the nearest pushed entry that one of its rays may still reach before
            // that ray's best hit.
            loop {
                if top == 0 {
                    break 'visit;
                }
                top -= 1;
                let e = entries[top];
                if e.near.cmple(best_t).any() {
                    at = e;
                    continue 'visit;
                }
            }
        }
        best.map(|h| (h.tri != u32::MAX).then_some(h))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seed::Rng;

    #[test]
    fn each_ray_of_a_packet_gets_its_single_ray_answer() {
        let mut rng = Rng::new(21);
        let mut r = move || rng.range_f64(-1.0, 1.0) as f32;
        // Random triangles, plus a fan whose shared vertex some rays aim at exactly.
        let mut positions = Vec::new();
        for _ in 0..2000 {
            let c = Vec3::new(r() * 5.0, r() * 5.0, r() * 5.0);
            let size = 0.05 + 0.6 * r().abs();
            for _ in 0..3 {
                positions.push(c + Vec3::new(r(), r(), r()) * size);
            }
        }
        let centre = Vec3::new(0.5, 0.25, -6.0);
        for i in 0..12 {
            let a = |k: usize| k as f32 / 12.0 * std::f32::consts::TAU;
            positions.extend([
                centre,
                centre + Vec3::new(a(i).cos(), a(i).sin(), 0.0),
                centre + Vec3::new(a(i + 1).cos(), a(i + 1).sin(), 0.0),
            ]);
        }
        let bvh = Bvh::new(&positions);
        // This CPU's kernels (AVX where it has it) and the portable ones.
        let mut stack = PacketStack::default();
        let mut portable_stack = PacketStack::portable();
        if !stack.uses_avx() {
            eprintln!("no AVX on this CPU: only the portable kernels are compared");
        }
        let (mut hits, mut packets) = (0, 0);
        for case in 0..1500 {
            let origin = Vec3::new(r() * 6.0, r() * 6.0, r() * 6.0);
            // Coherent (a 2×2 pixel block) or scattered directions, some straight at the
            // fan's centre, some with a zero component.
            let base = Vec3::new(r(), r(), r());
            let dirs: [Vec3; 4] = std::array::from_fn(|i| match (case % 3, i) {
                (0, _) => base + Vec3::new((i % 2) as f32, (i / 2) as f32, 0.0) * 0.004,
                (1, 0) => centre - origin,
                (1, 1) => Vec3::new(base.x, 0.0, base.z),
                _ => Vec3::new(r(), r(), r()),
            });
            if dirs.iter().any(|d| d.length() < 1e-3) {
                continue;
            }
            let packet = Packet::new(origin, dirs, 0.01, 60.0);
            let got = bvh.closest_packet(&packet, &mut stack);
            let portable = bvh.closest_packet(&packet, &mut portable_stack);
            for i in 0..4 {
                let want = bvh.closest(&Ray::new(origin, dirs[i], 0.01, 60.0), None);
                let bits = |h: Option<Hit>| h.map(|h| (h.t.to_bits(), h.tri, h.slot));
                assert_eq!(bits(got[i]), bits(want), "case {case} ray {i}");
                assert_eq!(
                    bits(portable[i]),
                    bits(want),
                    "case {case} ray {i}, portable"
                );
                hits += usize::from(want.is_some());
            }
            packets += 1;
        }
        assert!(
            packets > 1400 && hits > 1500,
            "{packets} packets, {hits} hits"
        );
    }

    #[test]
    fn packet_rays_are_the_single_rays_bit_for_bit() {
        let mut rng = Rng::new(5);
        let mut r = move || rng.range_f64(-1.0, 1.0) as f32;
        let mut shared = 0;
        for case in 0..4000 {
            let base = Vec3::new(r(), r(), r());
            let dirs: [Vec3; 4] = std::array::from_fn(|i| match case % 4 {
                // A 2x2 block of pixels (usually one axis order for all four).
                0 => base + Vec3::new((i % 2) as f32, (i / 2) as f32, 0.0) * 0.01,
                // Components of zero (either sign), tiny and exactly tied magnitudes.
                1 => [
                    Vec3::new(0.0, -0.0, 1.0),
                    Vec3::new(1e-30, base.y, -1e-25),
                    Vec3::new(base.x, base.x, -base.x),
                    Vec3::new(-0.0, base.y, base.y),
                ][i],
                // Directions straddling an axis swap.
                2 => Vec3::new(0.5 + 0.001 * i as f32, 0.5, -0.5 + 0.0004 * i as f32),
                _ => Vec3::new(r(), r(), r()),
            });
            let origin = Vec3::new(r() * 9.0, r(), r() * 9.0);
            let packet = Packet::new(origin, dirs, 0.05, 30.0);
            let d = [0, 1, 2].map(|axis| Vec4::from_array(dirs.map(|d| d[axis])));
            shared += usize::from(shared_axes(&d).is_some());
            for (i, dir) in dirs.iter().enumerate() {
                let want = Ray::new(origin, *dir, 0.05, 30.0);
                // Debug prints the sign of zero and NaN, so equal text is equal bits here.
                assert_eq!(
                    format!("{:?}", packet.ray(i)),
                    format!("{want:?}"),
                    "case {case} ray {i}"
                );
            }
        }
        assert!(shared > 1500, "most cases share their axes: {shared}");
    }
}
