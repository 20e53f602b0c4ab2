//! The packet traversal's two kernels — a node's box tests and a leaf's triangle tests —
//! two rays per 8-lane AVX instruction (ray `2p` in the low four lanes, ray `2p + 1` in the
//! high four), for CPUs that have AVX ([`super::PacketStack`] checks once).
//!
//! Each lane computes what the portable kernels compute, with the same IEEE operations on
//! the same operands in the same order (AVX adds no fused multiply-add and no
//! reassociation), so a frame is identical bit for bit whichever kernels drew it; the
//! packet tests compare both with the single-ray answers.

use std::arch::x86_64::*;

use glam::Vec4;

use super::packet::{Kernels, NodeHits, Packet, INV, ORIGIN_INV, SHEAR};
use super::{fold, Hit, Leaf, Node};

/// The AVX kernels, with each of the packet's constants splatted for the two pairs of
/// rays: `pairs[p][q]` holds quantity `q` (a row of [`Packet::lanes`]) of ray `2p` in
/// lanes 0–3 and of ray `2p + 1` in lanes 4–7.
pub(super) struct Avx {
    pairs: [[__m256; 15]; 2],
    /// Per axis, the side of a box all four rays meet first (see [`super::Ray`]'s
    /// `near_side`), when they agree — nearly always for neighbouring pixels.
    sides: Option<[usize; 3]>,
}

impl Avx {
    /// The kernels for `packet`.
    ///
    /// # Safety
    /// The CPU must have AVX (every method relies on it).
    #[inline]
    #[target_feature(enable = "avx")]
    pub(super) unsafe fn new(packet: &Packet) -> Avx {
        // Plain loops: built through `array::map` closures, which the compiler may decide
        // not to inline, this set-up once cost more than the traversal gained.
        let mut pairs = [[_mm256_setzero_ps(); 15]; 2];
        for (p, row) in pairs.iter_mut().enumerate() {
            for (pair, v) in row.iter_mut().zip(&packet.lanes) {
                *pair = halves(Vec4::splat(v[2 * p]), Vec4::splat(v[2 * p + 1]));
            }
        }
        let shared = packet.sides.iter().all(|&s| s == 0 || s == 0xF);
        Avx {
            pairs,
            sides: shared.then(|| packet.near_side(0)),
        }
    }
}

impl Kernels for Avx {
    #[inline(always)]
    fn node(&self, packet: &Packet, node: &Node, limit: Vec4) -> NodeHits {
        // SAFETY: an `Avx` exists only where the CPU has AVX (`Avx::new`).
        unsafe { node_hits(self, packet, node, limit) }
    }

    #[inline(always)]
    fn leaf(&self, packet: &Packet, leaf: &Leaf, index: u32, rays: u32, best: &mut [Hit; 4]) {
        // SAFETY: as for `node`.
        unsafe { leaf_hits(self, packet, leaf, index, rays, best) }
    }
}

/// `low` in lanes 0–3 and `high` in lanes 4–7.
#[inline]
#[target_feature(enable = "avx")]
fn halves(low: Vec4, high: Vec4) -> __m256 {
    _mm256_set_m128(high.into(), low.into())
}

/// The packet's node test ([`Kernels::node`]), rays two at a time.
#[inline]
#[target_feature(enable = "avx")]
fn node_hits(avx: &Avx, packet: &Packet, node: &Node, limit: Vec4) -> NodeHits {
    let b = &node.bounds;
    let mut near = [Vec4::INFINITY; 4];
    for p in 0..2 {
        let lim = halves(Vec4::splat(limit[2 * p]), Vec4::splat(limit[2 * p + 1]));
        let n = match avx.sides {
            // One box side per axis for all rays: each bound is one broadcast load.
            Some(sides) => box_pass(&avx.pairs[p], packet, lim, |axis, flip| {
                let v = b[(sides[axis] ^ flip) & 1][axis];
                halves(v, v)
            }),
            None => {
                let (s0, s1) = (packet.near_side(2 * p), packet.near_side(2 * p + 1));
                box_pass(&avx.pairs[p], packet, lim, |axis, flip| {
                    halves(b[s0[axis] ^ flip][axis], b[s1[axis] ^ flip][axis])
                })
            }
        };
        near[2 * p] = _mm256_castps256_ps128(n).into();
        near[2 * p + 1] = _mm256_extractf128_ps::<1>(n).into();
    }
    near
}

/// Two rays' entry distances to a node's four children (+∞ where the box test misses), as
/// [`super::Bvh::closest`] computes them: `q` holds the rays' constants, `limit` their best
/// hits, and `bound(axis, flip)` the children's bounds on each ray's near (`flip` 0) or far
/// (1) side along `axis`.
#[inline]
#[target_feature(enable = "avx")]
fn box_pass(
    q: &[__m256; 15],
    packet: &Packet,
    limit: __m256,
    bound: impl Fn(usize, usize) -> __m256,
) -> __m256 {
    let slab = |axis: usize, flip: usize| {
        _mm256_sub_ps(
            _mm256_mul_ps(bound(axis, flip), q[INV + axis]),
            q[ORIGIN_INV + axis],
        )
    };
    let n = _mm256_max_ps(
        _mm256_max_ps(_mm256_max_ps(slab(0, 0), slab(1, 0)), slab(2, 0)),
        _mm256_set1_ps(packet.t_min),
    );
    let f = _mm256_min_ps(
        _mm256_min_ps(_mm256_min_ps(slab(0, 1), slab(1, 1)), slab(2, 1)),
        limit,
    );
    _mm256_blendv_ps(
        _mm256_set1_ps(f32::INFINITY),
        n,
        _mm256_cmp_ps::<_CMP_LE_OQ>(n, f),
    )
}

/// The lanes where `u`, `v` or `w` compares to zero as `PREDICATE` says.
#[inline]
#[target_feature(enable = "avx")]
fn any_of<const PREDICATE: i32>(u: __m256, v: __m256, w: __m256) -> __m256 {
    let zero = _mm256_setzero_ps();
    _mm256_or_ps(
        _mm256_or_ps(
            _mm256_cmp_ps::<PREDICATE>(u, zero),
            _mm256_cmp_ps::<PREDICATE>(v, zero),
        ),
        _mm256_cmp_ps::<PREDICATE>(w, zero),
    )
}

/// The packet's leaf test ([`Kernels::leaf`], each ray's [`super::Ray::leaf`]), rays two
/// at a time.
#[inline]
#[target_feature(enable = "avx")]
fn leaf_hits(avx: &Avx, packet: &Packet, leaf: &Leaf, index: u32, rays: u32, best: &mut [Hit; 4]) {
    let o = packet.origin;
    // The corners relative to the rays' shared origin, the same for both halves.
    let rel = |c: usize| -> [__m256; 3] {
        std::array::from_fn(|axis| {
            let p = leaf.corners[c][axis] - Vec4::splat(o[axis]);
            halves(p, p)
        })
    };
    let (a, b, c) = (rel(0), rel(1), rel(2));
    let zero = _mm256_setzero_ps();
    let t_min = _mm256_set1_ps(packet.t_min);
    for p in 0..2 {
        let lanes = (((rays >> (2 * p)) & 1) * 0x0F) | (((rays >> (2 * p + 1)) & 1) * 0xF0);
        if lanes == 0 {
            continue;
        }
        let dot = |row: usize, v: &[__m256; 3]| {
            let r = |axis: usize| avx.pairs[p][SHEAR + 3 * row + axis];
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(r(0), v[0]), _mm256_mul_ps(r(1), v[1])),
                _mm256_mul_ps(r(2), v[2]),
            )
        };
        let (ax, ay) = (dot(0, &a), dot(1, &a));
        let (bx, by) = (dot(0, &b), dot(1, &b));
        let (cx, cy) = (dot(0, &c), dot(1, &c));
        let u = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
        let v = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
        let w = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
        let on_edge = _mm256_movemask_ps(any_of::<_CMP_EQ_OQ>(u, v, w)) as u32;
        let outside = _mm256_and_ps(any_of::<_CMP_LT_OQ>(u, v, w), any_of::<_CMP_GT_OQ>(u, v, w));
        let det = _mm256_add_ps(_mm256_add_ps(u, v), w);
        let t = _mm256_div_ps(
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(u, dot(2, &a)), _mm256_mul_ps(v, dot(2, &b))),
                _mm256_mul_ps(w, dot(2, &c)),
            ),
            det,
        );
        let abs_det = _mm256_andnot_ps(_mm256_set1_ps(-0.0), det);
        let best_t = halves(Vec4::splat(best[2 * p].t), Vec4::splat(best[2 * p + 1].t));
        let met = _mm256_andnot_ps(
            outside,
            _mm256_and_ps(
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_NEQ_UQ>(det, zero),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(abs_det, _mm256_set1_ps(f32::INFINITY)),
                ),
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GE_OQ>(t, t_min),
                    _mm256_cmp_ps::<_CMP_LE_OQ>(t, best_t),
                ),
            ),
        );
        let found = (_mm256_movemask_ps(met) as u32 | on_edge) & lanes;
        if found == 0 {
            continue;
        }
        let mut ts = [0f32; 8];
        // SAFETY: `ts` is eight f32s.
        unsafe { _mm256_storeu_ps(ts.as_mut_ptr(), t) };
        for half in 0..2 {
            let shift = 4 * half;
            let r = 2 * p + half;
            let t4 = [ts[shift], ts[shift + 1], ts[shift + 2], ts[shift + 3]];
            fold(
                leaf,
                index,
                t4,
                (found >> shift) & 0xF,
                (on_edge >> shift) & 0xF,
                &mut best[r],
                |lane, t_max| packet.ray(r).edge_lane(leaf, lane, t_max),
            );
        }
    }
}
