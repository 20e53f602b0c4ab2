//! Four rays from one origin traced through the BVH together: the rays of a 2×2 block of
//! pixels. Each node is fetched and ordered once for the four, its children's boxes are
//! tested against the four rays side by side (a lane per ray), and a leaf is met only by
//! the rays whose own box test reached it. Primary rays of neighbouring pixels visit
//! nearly the same nodes, so the packet pays the memory traffic and the hard-to-predict
//! branches of a traversal once instead of four times.
//!
//! The answer is each ray's own nearest hit, ties to the lowest triangle id, exactly as
//! [`Bvh::closest`] gives it: a ray's box tests compute the same values as the single-ray
//! test (the near side is the smaller of the two slab distances, the same rounded
//! products), every ancestor of a ray's nearest triangle passes that ray's test, and a
//! leaf's triangles are met with the same four-lane test.

use glam::{BVec4A, Vec3, Vec4};

use super::{shear_axes, Bvh, Hit, Ray, EMPTY, STACK};

/// Four rays sharing an origin, with their slab-test constants a lane per ray.
#[derive(Debug, Clone, Copy)]
pub struct Packet {
    rays: [Ray; 4],
    /// Per axis: the rays' reciprocal directions.
    inv: [Vec4; 3],
    /// Per axis: `origin · inv` of each ray.
    origin_inv: [Vec4; 3],
    t_min: Vec4,
}

impl Packet {
    /// The rays `origin + t·dirs[i]` for `t` in `[t_min, t_max]`: each ray exactly as
    /// [`Ray::new`] makes it, the divisions done four lanes at a time.
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
        let rays = match shared_axes(&dirs) {
            Some(axes) => shear_lanes(origin, &d, &inv, &origin_inv, axes, t_min, t_max),
            None => dirs.map(|dir| Ray::new(origin, dir, t_min, t_max)),
        };
        Packet {
            inv,
            origin_inv,
            t_min: Vec4::splat(t_min),
            rays,
        }
    }
}

/// The axes of [`Ray::new`]'s watertight shear ([`shear_axes`]), when all four directions
/// share them.
fn shared_axes(dirs: &[Vec3; 4]) -> Option<[usize; 3]> {
    let first = shear_axes(dirs[0]);
    dirs[1..]
        .iter()
        .all(|&d| shear_axes(d) == first)
        .then_some(first)
}

/// The four rays of directions `d` (lanes per axis) sharing shear axes `[kx, ky, kz]`:
/// [`Ray::new`]'s values computed four lanes at a time with the same operations.
fn shear_lanes(
    origin: Vec3,
    d: &[Vec4; 3],
    inv: &[Vec4; 3],
    origin_inv: &[Vec4; 3],
    [kx, ky, kz]: [usize; 3],
    t_min: f32,
    t_max: f32,
) -> [Ray; 4] {
    let (sx, sy, sz) = (d[kx] / d[kz], d[ky] / d[kz], Vec4::ONE / d[kz]);
    let unit = |k: usize, c: usize| Vec4::splat(f32::from(k == c));
    // Row r, component c, exactly as `unit(k) - unit(kz) * s` (row 2: `unit(kz) * sz`).
    let row = |k: usize, s: Vec4| -> [[f32; 4]; 3] {
        std::array::from_fn(|c| (unit(k, c) - unit(kz, c) * s).to_array())
    };
    let last: [[f32; 4]; 3] = std::array::from_fn(|c| (unit(kz, c) * sz).to_array());
    let (r0, r1) = (row(kx, sx), row(ky, sy));
    let at = |v: &[Vec4; 3], i: usize| Vec3::new(v[0][i], v[1][i], v[2][i]);
    let of = |r: &[[f32; 4]; 3], i: usize| Vec3::new(r[0][i], r[1][i], r[2][i]);
    std::array::from_fn(|i| {
        let inv_i = at(inv, i);
        Ray {
            origin,
            inv: inv_i,
            origin_inv: at(origin_inv, i),
            near_side: [
                usize::from(inv_i.x < 0.0),
                usize::from(inv_i.y < 0.0),
                usize::from(inv_i.z < 0.0),
            ],
            shear: [of(&r0, i), of(&r1, i), of(&last, i)],
            t_min,
            t_max,
        }
    })
}

/// A traversal stack for packets, kept between packets so that a packet allocates nothing.
#[derive(Debug, Clone)]
pub struct PacketStack(Box<[Entry; STACK]>);

impl Default for PacketStack {
    fn default() -> Self {
        PacketStack(Box::new([Entry::default(); STACK]))
    }
}

/// A child waiting on the stack: what it is, which rays reached it and where they enter.
#[derive(Debug, Clone, Copy, Default)]
struct Entry {
    child: u32,
    /// 0 for an inner node, else a leaf's triangle count.
    count: u32,
    /// The smallest entry distance of the rays that reached it (the visiting order).
    first: f32,
    /// Lane `i`: ray `i`'s box test reached the child.
    rays: BVec4A,
    /// Each ray's entry distance.
    near: Vec4,
}

impl Bvh {
    /// The nearest hit of each of the packet's rays, as [`Bvh::closest`] finds it; `hints`
    /// are tried first, per ray (they only prune, never change an answer).
    pub fn closest_packet(
        &self,
        packet: &Packet,
        hints: [Option<u32>; 4],
        stack: &mut PacketStack,
    ) -> [Option<Hit>; 4] {
        let mut best = packet.rays.map(|r| Hit {
            t: r.t_max,
            tri: u32::MAX,
            slot: u32::MAX,
        });
        if self.leaves.is_empty() {
            return [None; 4];
        }
        for ((ray, hint), best) in packet.rays.iter().zip(hints).zip(&mut best) {
            if let Some(leaf) = hint.map(|slot| slot / 4) {
                if let Some(l) = self.leaves.get(leaf as usize) {
                    ray.leaf(l, leaf, best);
                }
            }
        }
        let mut best_t = Vec4::from_array(best.map(|h| h.t));
        let entries = &mut stack.0;
        let mut top = 0;
        let [ix, iy, iz] = packet.inv;
        let [ox, oy, oz] = packet.origin_inv;
        let mut at = Entry {
            child: 0,
            count: 0,
            first: packet.rays[0].t_min,
            rays: BVec4A::splat(true),
            near: packet.t_min,
        };
        'visit: loop {
            if at.count == 0 {
                let node = &self.nodes[at.child as usize];
                let b = &node.bounds;
                let base = top;
                // The nearest reached child (by its rays' smallest entry) is visited next;
                // the others are pushed, farthest deepest.
                let mut next: Option<Entry> = None;
                for (k, (&child, &count)) in node.child.iter().zip(&node.count).enumerate() {
                    if count == EMPTY {
                        // Slots are filled in order: the rest are unused too.
                        break;
                    }
                    let slab = |axis: usize, inv: Vec4, oi: Vec4| {
                        let lo = Vec4::splat(b[0][axis][k]) * inv - oi;
                        let hi = Vec4::splat(b[1][axis][k]) * inv - oi;
                        (lo.min(hi), lo.max(hi))
                    };
                    let (nx, fx) = slab(0, ix, ox);
                    let (ny, fy) = slab(1, iy, oy);
                    let (nz, fz) = slab(2, iz, oz);
                    let near = nx.max(ny).max(nz).max(packet.t_min);
                    let far = fx.min(fy).min(fz).min(best_t);
                    let rays = near.cmple(far) & at.rays;
                    if !rays.any() {
                        continue;
                    }
                    let mut e = Entry {
                        child,
                        count,
                        first: Vec4::select(rays, near, Vec4::INFINITY).min_element(),
                        rays,
                        near,
                    };
                    match &mut next {
                        None => next = Some(e),
                        Some(n) => {
                            if e.first < n.first {
                                std::mem::swap(&mut e, n);
                            }
                            let mut i = top;
                            while i > base && entries[i - 1].first < e.first {
                                entries[i] = entries[i - 1];
                                i -= 1;
                            }
                            entries[i] = e;
                            top += 1;
                        }
                    }
                }
                if let Some(e) = next {
                    at = e;
                    continue 'visit;
                }
            } else {
                let leaf = &self.leaves[at.child as usize];
                let mut rays = at.rays.bitmask();
                while rays != 0 {
                    let i = rays.trailing_zeros() as usize;
                    rays &= rays - 1;
                    packet.rays[i].leaf(leaf, at.child, &mut best[i]);
                }
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
                let rays = e.rays & e.near.cmple(best_t);
                if rays.any() {
                    at = Entry { rays, ..e };
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
        let mut stack = PacketStack::default();
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
            let hints: [Option<u32>; 4] = std::array::from_fn(|i| {
                (case % 2 == 0).then_some(((case * 7 + i * 13) % 2100) as u32)
            });
            let packet = Packet::new(origin, dirs, 0.01, 60.0);
            let got = bvh.closest_packet(&packet, hints, &mut stack);
            for i in 0..4 {
                let want = bvh.closest(&Ray::new(origin, dirs[i], 0.01, 60.0), None);
                assert_eq!(
                    got[i].map(|h| (h.t.to_bits(), h.tri, h.slot)),
                    want.map(|h| (h.t.to_bits(), h.tri, h.slot)),
                    "case {case} ray {i}"
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
            shared += usize::from(shared_axes(&dirs).is_some());
            for (i, dir) in dirs.iter().enumerate() {
                let want = Ray::new(origin, *dir, 0.05, 30.0);
                // Debug prints the sign of zero and NaN, so equal text is equal bits here.
                assert_eq!(
                    format!("{:?}", packet.rays[i]),
                    format!("{want:?}"),
                    "case {case} ray {i}"
                );
                for axis in 0..3 {
                    assert_eq!(packet.inv[axis][i].to_bits(), want.inv[axis].to_bits());
                    assert_eq!(
                        packet.origin_inv[axis][i].to_bits(),
                        want.origin_inv[axis].to_bits()
                    );
                }
            }
        }
        assert!(shared > 1500, "most cases share their axes: {shared}");
    }
}
