//! Building a [`Bvh`]: binned surface-area-heuristic splits, four children per node, leaves
//! of up to [`LEAF_MAX`] triangles.
//!
//! The triangles' build records are partitioned in place, so every pass reads them in memory
//! order, and the subtrees of large nodes are built in parallel (rayon). The tree is then laid
//! out depth first (a node, then its children's subtrees in slot order), so the first inner
//! child of a node is the next node in memory. Every decision depends only on the triangles
//! of the subtree being split, and the layout is made in one fixed order afterwards, so the
//! same triangles give the same hierarchy, bit for bit, on any number of threads.

use glam::Vec3;
use rayon::prelude::*;

use super::{Bvh, Leaf, Node, LEAF_MAX, MEDIAN_DEPTH};

/// SAH bins per axis.
const BINS: usize = 16;
/// Subtrees of at least this many triangles build their children in parallel.
const PARALLEL_SUBTREE: usize = 8 * 1024;
/// Passes over at least this many triangles (centroid box, SAH bins) run in parallel chunks
/// of this size.
const PARALLEL_PASS: usize = 64 * 1024;

/// One triangle while building: its box, centroid and scene id.
#[derive(Clone, Copy)]
struct Prim {
    lo: Vec3,
    hi: Vec3,
    centroid: Vec3,
    id: u32,
}

/// A box while building.
#[derive(Clone, Copy, Debug, PartialEq)]
struct BuildBox {
    lo: Vec3,
    hi: Vec3,
}

impl BuildBox {
    const EMPTY: BuildBox = BuildBox {
        lo: Vec3::splat(f32::INFINITY),
        hi: Vec3::splat(f32::NEG_INFINITY),
    };

    fn grow(&mut self, lo: Vec3, hi: Vec3) {
        self.lo = self.lo.min(lo);
        self.hi = self.hi.max(hi);
    }

    /// The union of two boxes (exact: minima and maxima do not round).
    fn union(mut self, other: BuildBox) -> BuildBox {
        self.grow(other.lo, other.hi);
        self
    }

    /// Half the surface area (the SAH only compares areas).
    fn half_area(&self) -> f32 {
        let e = (self.hi - self.lo).max(Vec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// A child slot of a node before the tree is laid out.
enum Built {
    /// Triangles `start..end` of the final order.
    Leaf { start: usize, end: usize },
    /// An inner node: its (up to four) children with their boxes.
    Inner(Vec<(BuildBox, Built)>),
}

impl Bvh {
    /// Builds the hierarchy over triangles given as three corners each (`positions.len()`
    /// a multiple of 3; triangle `i` is `positions[3i..3i + 3]`). Deterministic: the same
    /// triangles give the same tree whatever the thread count; large trees are built on the
    /// current rayon pool.
    pub fn new(positions: &[Vec3]) -> Bvh {
        let tris = positions.len() / 3;
        let mut prims: Vec<Prim> = positions
            .par_chunks_exact(3)
            .enumerate()
            .map(|(t, p)| {
                let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
                Prim {
                    lo,
                    hi,
                    centroid: (lo + hi) * 0.5,
                    id: t as u32,
                }
            })
            .collect();
        let mut nodes = Vec::new();
        let mut leaves = Vec::new();
        if tris == 0 {
            nodes.push(Node::UNUSED);
        } else {
            let whole = bounds(&prims);
            let root = children(&mut prims, 0, 0, whole);
            let ids: Vec<u32> = prims.iter().map(|p| p.id).collect();
            drop(prims);
            nodes.reserve(tris / 3);
            leaves.reserve(tris / 3);
            lay_out(&root, &ids, positions, &mut nodes, &mut leaves);
        }
        Bvh {
            nodes,
            leaves,
            triangles: tris,
        }
    }
}

/// The children of the node over `prims` (which are `offset..` of the final order, inside
/// the box `whole`): up to four parts, each a leaf or, recursively, an inner node. Reorders
/// `prims`.
fn children(
    prims: &mut [Prim],
    offset: usize,
    depth: u32,
    whole: BuildBox,
) -> Vec<(BuildBox, Built)> {
    let parallel = prims.len() >= PARALLEL_SUBTREE;
    let parts = split_four(prims, depth, whole);
    let mut slices = Vec::with_capacity(parts.len());
    let mut rest = prims;
    for &(start, end, b) in &parts {
        let (part, tail) = rest.split_at_mut(end - start);
        slices.push((offset + start, b, part));
        rest = tail;
    }
    let child = |(start, b, part): (usize, BuildBox, &mut [Prim])| {
        let built = if part.len() <= LEAF_MAX {
            Built::Leaf {
                start,
                end: start + part.len(),
            }
        } else {
            Built::Inner(children(part, start, depth + 1, b))
        };
        (b, built)
    };
    if parallel {
        slices.into_par_iter().map(child).collect()
    } else {
        slices.into_iter().map(child).collect()
    }
}

/// Appends the node of `children` and, depth first, its subtrees; returns its index.
fn lay_out(
    children: &[(BuildBox, Built)],
    ids: &[u32],
    positions: &[Vec3],
    nodes: &mut Vec<Node>,
    leaves: &mut Vec<Leaf>,
) -> u32 {
    let index = nodes.len();
    nodes.push(Node::UNUSED);
    for (slot, (b, built)) in children.iter().enumerate() {
        // Pad the box so that rounding in the slab test never misses a triangle on its
        // face (flat boxes of walls and floors included).
        let pad = (b.lo.abs().max(b.hi.abs()).max_element() + 1.0) * 1e-5;
        let (child, count) = match built {
            Built::Leaf { start, end } => {
                leaves.push(Leaf::new(positions, &ids[*start..*end]));
                ((leaves.len() - 1) as u32, (end - start) as u32)
            }
            Built::Inner(grand) => (lay_out(grand, ids, positions, nodes, leaves), 0),
        };
        let node = &mut nodes[index];
        for axis in 0..3 {
            node.bounds[0][axis][slot] = b.lo[axis] - pad;
            node.bounds[1][axis][slot] = b.hi[axis] + pad;
        }
        node.child[slot] = child;
        node.count[slot] = count;
    }
    index as u32
}

/// The box of `prims`.
fn bounds(prims: &[Prim]) -> BuildBox {
    fold_boxes(prims, |b, p| b.grow(p.lo, p.hi))
}

/// The box of `prims`' centroids.
fn centroid_bounds(prims: &[Prim]) -> BuildBox {
    fold_boxes(prims, |b, p| b.grow(p.centroid, p.centroid))
}

/// A box grown by every prim, in parallel chunks for long slices (exact whatever the order).
fn fold_boxes(prims: &[Prim], grow: impl Fn(&mut BuildBox, &Prim) + Sync) -> BuildBox {
    let fold = |chunk: &[Prim]| {
        let mut b = BuildBox::EMPTY;
        for p in chunk {
            grow(&mut b, p);
        }
        b
    };
    if prims.len() >= 2 * PARALLEL_PASS {
        prims
            .par_chunks(PARALLEL_PASS)
            .map(fold)
            .reduce(|| BuildBox::EMPTY, BuildBox::union)
    } else {
        fold(prims)
    }
}

/// Splits `prims` (inside the box `whole`) into up to four consecutive ranges, each with its
/// box: the largest range (by box area) of more than [`LEAF_MAX`] triangles is split in two
/// until there are four (ties: the first).
fn split_four(prims: &mut [Prim], depth: u32, whole: BuildBox) -> Vec<(usize, usize, BuildBox)> {
    let mut parts = vec![(0, prims.len(), whole)];
    while parts.len() < 4 {
        let pick = parts
            .iter()
            .enumerate()
            .filter(|(_, &(s, e, _))| e - s > LEAF_MAX)
            .map(|(i, (_, _, b))| (i, b.half_area()))
            .fold(None::<(usize, f32)>, |best, (i, a)| match best {
                Some((_, b)) if b >= a => best,
                _ => Some((i, a)),
            });
        let Some((i, _)) = pick else {
            break;
        };
        let (s, e, _) = parts.remove(i);
        let mid = s + split(&mut prims[s..e], depth);
        parts.insert(i, (mid, e, bounds(&prims[mid..e])));
        parts.insert(i, (s, mid, bounds(&prims[s..mid])));
    }
    parts
}

/// Splits `prims` in two (binned SAH, or halving past [`MEDIAN_DEPTH`] or when the SAH finds
/// nothing); returns the first index of the second half, strictly inside.
fn split(prims: &mut [Prim], depth: u32) -> usize {
    let cb = centroid_bounds(prims);
    let extent = cb.hi - cb.lo;
    if depth < MEDIAN_DEPTH {
        if let Some((axis, bin)) = sah_split(prims, cb) {
            let scale = BINS as f32 * (1.0 - 1e-6) / extent[axis];
            let bin_of =
                |p: &Prim| (((p.centroid[axis] - cb.lo[axis]) * scale) as usize).min(BINS - 1);
            let (mut lo, mut hi) = (0, prims.len());
            while lo < hi {
                if bin_of(&prims[lo]) < bin {
                    lo += 1;
                } else {
                    hi -= 1;
                    prims.swap(lo, hi);
                }
            }
            if lo > 0 && lo < prims.len() {
                return lo;
            }
        }
    }
    // Halve along the widest centroid axis (ties by triangle id, so the result is unique).
    let axis = extent.max_position();
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |a, b| {
        a.centroid[axis]
            .total_cmp(&b.centroid[axis])
            .then(a.id.cmp(&b.id))
    });
    mid
}

/// The bins of the three axes: each bin's box and triangle count.
#[derive(Clone, Copy)]
struct Bins {
    boxes: [[BuildBox; BINS]; 3],
    counts: [[usize; BINS]; 3],
}

impl Bins {
    const EMPTY: Bins = Bins {
        boxes: [[BuildBox::EMPTY; BINS]; 3],
        counts: [[0; BINS]; 3],
    };

    /// Both chunks' bins together (exact: unions and sums).
    fn merge(mut self, other: Bins) -> Bins {
        for axis in 0..3 {
            for b in 0..BINS {
                self.boxes[axis][b] = self.boxes[axis][b].union(other.boxes[axis][b]);
                self.counts[axis][b] += other.counts[axis][b];
            }
        }
        self
    }
}

/// The best binned-SAH plane: (axis, first bin of the second half), or `None` when all
/// centroids coincide. The prims are binned along the three axes in one pass.
fn sah_split(prims: &[Prim], cb: BuildBox) -> Option<(usize, usize)> {
    let extent = cb.hi - cb.lo;
    let usable: [bool; 3] = std::array::from_fn(|a| extent[a] > 0.0 && extent[a].is_finite());
    let scale: [f32; 3] = std::array::from_fn(|a| BINS as f32 * (1.0 - 1e-6) / extent[a]);
    let bin = |chunk: &[Prim]| {
        let mut bins = Bins::EMPTY;
        for p in chunk {
            for axis in 0..3 {
                if usable[axis] {
                    let b =
                        (((p.centroid[axis] - cb.lo[axis]) * scale[axis]) as usize).min(BINS - 1);
                    bins.boxes[axis][b].grow(p.lo, p.hi);
                    bins.counts[axis][b] += 1;
                }
            }
        }
        bins
    };
    let bins = if prims.len() >= 2 * PARALLEL_PASS {
        prims
            .par_chunks(PARALLEL_PASS)
            .map(bin)
            .reduce(|| Bins::EMPTY, Bins::merge)
    } else {
        bin(prims)
    };
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in (0..3).filter(|&a| usable[a]) {
        let (boxes, counts) = (&bins.boxes[axis], &bins.counts[axis]);
        // Areas and counts of every prefix and suffix of bins.
        let mut right_area = [0f32; BINS];
        let mut right_count = [0usize; BINS];
        let (mut acc, mut n) = (BuildBox::EMPTY, 0);
        for b in (1..BINS).rev() {
            acc.grow(boxes[b].lo, boxes[b].hi);
            n += counts[b];
            right_area[b] = acc.half_area();
            right_count[b] = n;
        }
        let (mut acc, mut n) = (BuildBox::EMPTY, 0);
        for b in 1..BINS {
            acc.grow(boxes[b - 1].lo, boxes[b - 1].hi);
            n += counts[b - 1];
            if n == 0 || right_count[b] == 0 {
                continue;
            }
            let cost = acc.half_area() * n as f32 + right_area[b] * right_count[b] as f32;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, b));
            }
        }
    }
    best.map(|(_, axis, bin)| (axis, bin))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seed::Rng;

    /// Checks the subtree of `node`: every child box holds its triangles' corners (and
    /// inner children's boxes), and returns the triangles found below.
    fn check(bvh: &Bvh, positions: &[Vec3], node: u32, out: &mut Vec<u32>) {
        let n = &bvh.nodes[node as usize];
        let used = n
            .count
            .iter()
            .take_while(|&&c| c != super::super::EMPTY)
            .count();
        assert!(n.count[used..].iter().all(|&c| c == super::super::EMPTY));
        for k in 0..4 {
            let (lo, hi) = (
                Vec3::from_array(std::array::from_fn(|a| n.bounds[0][a][k])),
                Vec3::from_array(std::array::from_fn(|a| n.bounds[1][a][k])),
            );
            let inside = |p: Vec3| p.cmpge(lo).all() && p.cmple(hi).all();
            match n.count[k] {
                super::super::EMPTY => assert!(lo.x.is_infinite(), "unused slot {k} has a box"),
                0 => {
                    let first = out.len();
                    check(bvh, positions, n.child[k], out);
                    for &t in &out[first..] {
                        assert!((0..3).all(|c| inside(positions[3 * t as usize + c])));
                    }
                }
                count => {
                    assert!(count as usize <= LEAF_MAX);
                    let leaf = &bvh.leaves[n.child[k] as usize];
                    for &t in &leaf.ids[..count as usize] {
                        assert!((0..3).all(|c| inside(positions[3 * t as usize + c])));
                        out.push(t);
                    }
                }
            }
        }
    }

    #[test]
    fn every_triangle_is_in_one_leaf_inside_its_ancestors_boxes_on_any_thread_count() {
        let mut rng = Rng::new(3);
        // Large enough for the parallel subtrees and passes; a third of the triangles
        // crowd one point (equal centroids: the halving split and its id ties).
        for n in [0usize, 1, 4, 5, 17, 2_000, 3 * PARALLEL_PASS] {
            let mut r = || rng.range_f64(-1.0, 1.0) as f32;
            let mut positions = Vec::with_capacity(3 * n);
            for i in 0..n {
                let c = if i % 3 == 0 {
                    Vec3::new(1.0, 2.0, 3.0)
                } else {
                    Vec3::new(r() * 50.0, r() * 3.0, r() * 20.0)
                };
                for _ in 0..3 {
                    positions.push(c + Vec3::new(r(), r(), r()) * 0.1);
                }
            }
            let on = |threads: usize| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .expect("pool")
                    .install(|| Bvh::new(&positions))
            };
            let one = on(1);
            assert_eq!(
                one,
                on(3),
                "{n} triangles: the same tree on 1 and 3 threads"
            );
            assert_eq!(one.triangle_count(), n);
            let mut found = Vec::new();
            check(&one, &positions, 0, &mut found);
            found.sort_unstable();
            assert_eq!(found, (0..n as u32).collect::<Vec<_>>(), "{n} triangles");
            // Laid out depth first: a node's first inner child is the next node.
            for (i, node) in one.nodes.iter().enumerate() {
                if let Some(k) = (0..4).find(|&k| node.count[k] == 0) {
                    assert_eq!(node.child[k] as usize, i + 1);
                }
            }
        }
    }
}
