//! The hierarchy as flat 32-bit words, for the GPU ray tracer (`render/gpu/trace.wgsl`),
//! which reads the same nodes and leaves the CPU traverses.
//!
//! A node is 32 words: its children's box minima (x, y, z, four lanes each), maxima
//! (likewise), child indices, then counts (0: inner node, 1–4: a leaf's triangles,
//! [`FLAT_EMPTY`]: an unused slot). An unused slot's box is written as the empty box at the
//! origin (minima and maxima 0) instead of the CPU's corners at +∞, so the shader does no
//! arithmetic on infinities (WGSL does not promise them); the shader skips such slots by
//! their count. A leaf is 40 words: corner `c`'s axis `a` for the four lanes at words
//! `4·(3c + a)`, then the four triangle ids.

use super::{Bvh, EMPTY};

/// Words per flattened node.
pub const NODE_WORDS: usize = 32;
/// Words per flattened leaf.
pub const LEAF_WORDS: usize = 40;
/// `count` of an unused child slot in the flattened nodes.
#[cfg(test)]
pub(crate) const FLAT_EMPTY: u32 = EMPTY;

impl Bvh {
    /// The nodes as [`NODE_WORDS`] words each (floats as their bits); at least one node, so
    /// that a buffer of them is never empty.
    pub fn flat_nodes(&self) -> Vec<u32> {
        let mut out = Vec::with_capacity(self.nodes.len().max(1) * NODE_WORDS);
        for node in &self.nodes {
            for side in &node.bounds {
                for axis in side {
                    for (lane, v) in axis.to_array().into_iter().enumerate() {
                        let used = node.count[lane] != EMPTY;
                        out.push(if used { v.to_bits() } else { 0 });
                    }
                }
            }
            out.extend_from_slice(&node.child);
            out.extend_from_slice(&node.count);
        }
        if out.is_empty() {
            // No triangles: one node of unused slots.
            out.resize(NODE_WORDS, 0);
            out[NODE_WORDS - 4..].fill(EMPTY);
        }
        out
    }

    /// Levels of inner nodes on the longest path from the root to a leaf (0 without
    /// triangles). A traversal holds at most three pushed entries per level.
    pub fn depth(&self) -> usize {
        if self.leaves.is_empty() {
            return 0;
        }
        let mut deepest = 0;
        let mut todo = vec![(0u32, 1usize)];
        while let Some((n, level)) = todo.pop() {
            deepest = deepest.max(level);
            let node = &self.nodes[n as usize];
            for k in 0..4 {
                if node.count[k] == 0 {
                    todo.push((node.child[k], level + 1));
                }
            }
        }
        deepest
    }

    /// The leaves as [`LEAF_WORDS`] words each; at least one leaf.
    pub fn flat_leaves(&self) -> Vec<u32> {
        let mut out = Vec::with_capacity(self.leaves.len().max(1) * LEAF_WORDS);
        for leaf in &self.leaves {
            for corner in &leaf.corners {
                for axis in corner {
                    out.extend(axis.to_array().map(f32::to_bits));
                }
            }
            out.extend_from_slice(&leaf.ids);
        }
        if out.is_empty() {
            out.resize(LEAF_WORDS, 0);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    #[test]
    fn flat_words_hold_every_node_box_and_leaf_triangle() {
        // Forty separate triangles: several levels of nodes over leaves.
        let mut positions = Vec::new();
        for k in 0..40 {
            let c = Vec3::new(k as f32 * 2.0, (k % 3) as f32, (k % 5) as f32);
            positions.extend([c, c + Vec3::X, c + Vec3::Y]);
        }
        let bvh = Bvh::new(&positions);
        let (nodes, leaves) = (bvh.flat_nodes(), bvh.flat_leaves());
        assert_eq!(nodes.len(), bvh.nodes.len() * NODE_WORDS);
        assert_eq!(leaves.len(), bvh.leaves.len() * LEAF_WORDS);
        let f = |w: u32| f32::from_bits(w);
        // Every triangle appears in some leaf with its corners where the layout says.
        for t in 0..40u32 {
            let (leaf, lane) = (0..bvh.leaves.len())
                .flat_map(|l| (0..4).map(move |i| (l, i)))
                .find(|&(l, i)| leaves[l * LEAF_WORDS + 36 + i] == t)
                .expect("triangle in a leaf");
            let w = &leaves[leaf * LEAF_WORDS..];
            for c in 0..3 {
                let got = Vec3::new(
                    f(w[4 * (3 * c) + lane]),
                    f(w[4 * (3 * c + 1) + lane]),
                    f(w[4 * (3 * c + 2) + lane]),
                );
                assert_eq!(got, positions[3 * t as usize + c]);
            }
        }
        // Each used child slot's box holds its subtree's triangles; unused slots are the
        // empty box at the origin with the unused count.
        for n in 0..bvh.nodes.len() {
            let w = &nodes[n * NODE_WORDS..(n + 1) * NODE_WORDS];
            for lane in 0..4 {
                let lo = Vec3::new(f(w[lane]), f(w[4 + lane]), f(w[8 + lane]));
                let hi = Vec3::new(f(w[12 + lane]), f(w[16 + lane]), f(w[20 + lane]));
                let (child, count) = (w[24 + lane], w[28 + lane]);
                if count == FLAT_EMPTY {
                    assert_eq!((lo, hi), (Vec3::ZERO, Vec3::ZERO));
                    continue;
                }
                assert!(lo.cmple(hi).all());
                if count > 0 {
                    for i in 0..count as usize {
                        let l = &leaves[child as usize * LEAF_WORDS..];
                        for c in 0..3 {
                            let p = Vec3::new(
                                f(l[4 * (3 * c) + i]),
                                f(l[4 * (3 * c + 1) + i]),
                                f(l[4 * (3 * c + 2) + i]),
                            );
                            assert!(p.cmpge(lo).all() && p.cmple(hi).all(), "{p} in {lo}..{hi}");
                        }
                    }
                }
            }
        }
        // Depth: the levels of inner nodes down to the deepest leaf, counted independently
        // from the flat words.
        fn levels(nodes: &[u32], n: usize) -> usize {
            let w = &nodes[n * NODE_WORDS..(n + 1) * NODE_WORDS];
            1 + (0..4)
                .filter(|&k| w[28 + k] == 0)
                .map(|k| levels(nodes, w[24 + k] as usize))
                .max()
                .unwrap_or(0)
        }
        assert_eq!(bvh.depth(), levels(&nodes, 0));
        assert!(bvh.depth() >= 2, "forty triangles need more than one level");
        let empty = Bvh::new(&[]);
        assert_eq!(empty.depth(), 0);
        assert_eq!(empty.flat_nodes().len(), NODE_WORDS);
        assert!(empty.flat_nodes()[28..].iter().all(|&c| c == FLAT_EMPTY));
        assert_eq!(empty.flat_leaves().len(), LEAF_WORDS);
    }
}
