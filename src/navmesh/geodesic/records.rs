//! The search state of a geodesic query: one 16-byte record per span (height, distance,
//! anchor, generation mark), the per-query scratch that holds them, the binary-heap queue of
//! `(key bits, span)` words, and the iteration over a span's links from the sight index's
//! packed spans.

use super::*;

/// Per-span search state, 16 bytes: what relaxing a neighbour reads and writes (four
/// records per cache line).
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(16))]
pub(super) struct State {
    /// Floor height (a copy of the span's).
    pub(super) y: f32,
    /// Distance to the nearest goal (valid while `mark` is the search's open or closed mark).
    pub(super) g: f32,
    /// Anchor (valid like `g`).
    pub(super) anchor: u32,
    /// The search's open mark, its closed mark (open + 1), or older: not reached.
    pub(super) mark: u32,
}

impl State {
    /// Readies the record for a relaxation in the search whose open mark is `open`: `false`
    /// when it is closed, else `true`, with a record not yet reached in this search made
    /// open, at an infinite distance and without an anchor.
    #[inline]
    pub(super) fn relaxable(&mut self, open: u32) -> bool {
        if self.mark == open + 1 {
            return false;
        }
        if self.mark != open {
            self.mark = open;
            self.g = f32::INFINITY;
            self.anchor = NONE;
        }
        true
    }
}

/// Where a settled span is and how to find its linked spans (from the [`SightIndex`]'s packed
/// record).
#[derive(Debug, Clone, Copy)]
pub(super) struct Here {
    /// Cell.
    pub(super) xz: (i64, i64),
    /// Column index.
    pub(super) column: u32,
    /// Rank of the span in its column: same-layer links land on the same rank.
    pub(super) rank: u32,
    /// Bit `d`: link `d` leads to the same rank of the neighbouring column.
    pub(super) same: u8,
    /// Bit `d`: link `d` leads to another rank (read from the grid's span).
    pub(super) other: u8,
}

/// Maps cells to world positions: the centre of the cell at floor height, computed exactly
/// as [`NavGrid::span_position`] does.
#[derive(Debug, Clone, Copy)]
pub(super) struct Frame {
    pub(super) x0: f32,
    pub(super) z0: f32,
    pub(super) size: f32,
}

impl Frame {
    /// Position of cell `(ix, iz)` at height `y`.
    #[inline(always)]
    pub(super) fn pos(&self, (ix, iz): (i64, i64), y: f32) -> Vec3 {
        Vec3::new(
            self.x0 + (ix as f32 + 0.5) * self.size,
            y,
            self.z0 + (iz as f32 + 0.5) * self.size,
        )
    }
}

/// Distance between two points (the arithmetic of [`Vec3::distance`]).
#[inline(always)]
pub(super) fn dist(p: Vec3, q: Vec3) -> f32 {
    let (dx, dy, dz) = (p.x - q.x, p.y - q.y, p.z - q.z);
    (dx * dx + dy * dy + dz * dz).sqrt()
}

/// Priority queue of spans: a binary min-heap of 64-bit words `(f32 bits of the key) << 32 |
/// span`. For the non-negative keys of a search the bit pattern orders like the value, so
/// spans pop by key and then by index whatever the order of pushes, and a comparison is one
/// integer compare. (A 4-ary heap and a bucketed queue with the same order measured no
/// faster.)
#[derive(Debug, Default)]
pub(super) struct Queue {
    pub(super) heap: BinaryHeap<Reverse<u64>>,
}

impl Queue {
    pub(super) fn clear(&mut self) {
        self.heap.clear();
    }

    #[inline(always)]
    pub(super) fn push(&mut self, key: f32, span: u32) {
        self.heap
            .push(Reverse((u64::from(key.to_bits()) << 32) | u64::from(span)));
    }

    #[inline(always)]
    pub(super) fn pop(&mut self) -> Option<u32> {
        self.heap.pop().map(|Reverse(k)| k as u32)
    }

    /// The span that pops next.
    #[inline(always)]
    pub(super) fn peek(&self) -> Option<u32> {
        self.heap.peek().map(|Reverse(k)| *k as u32)
    }

    /// Number of queued entries.
    pub(super) fn len(&self) -> usize {
        self.heap.len()
    }
}

/// Reusable state of one search: the per-span records and the queue.
#[derive(Debug)]
pub(super) struct Scratch {
    pub(super) nodes: Vec<State>,
    /// Open mark of the current search (its closed mark is `open + 1`).
    pub(super) open: u32,
    pub(super) queue: Queue,
    /// Queue of the sparse point-to-point search.
    pub(super) entries: BinaryHeap<Entry>,
    /// Per sparse vertex: the open mark of the search in which it was found to see the goal,
    /// or that mark plus one when it was found not to.
    pub(super) sees: Vec<u32>,
    /// Candidate vertices of the goal, by distance.
    pub(super) near: Vec<(u32, u32)>,
    /// Breadth-first queue of the flood from a single goal.
    pub(super) fifo: Vec<u32>,
    /// Per sparse vertex: (open mark of the search, its heuristic).
    pub(super) hcache: Vec<(u32, f32)>,
}

impl Scratch {
    /// Starts a new search: new marks (older marks read as "not reached"), empty queue.
    pub(super) fn begin(&mut self) {
        if self.open >= u32::MAX - 4 {
            self.nodes.iter_mut().for_each(|n| n.mark = 0);
            self.sees.clear();
            self.hcache.clear();
            self.open = 0;
        }
        self.open += 2;
        self.queue.clear();
        self.entries.clear();
    }
}

/// The linked spans of one span: same-layer links from the column offsets, then links to
/// other layers from the grid.
pub(super) struct Links<'a> {
    pub(super) start: &'a [u32],
    pub(super) offsets: &'a [i64; 8],
    pub(super) spans: &'a [Span],
    pub(super) span: u32,
    pub(super) column: i64,
    pub(super) rank: u32,
    pub(super) same: u8,
    pub(super) other: u8,
}

impl Iterator for Links<'_> {
    /// The linked span and the [`DIRS`] index of the step to it.
    type Item = (u32, usize);

    #[inline(always)]
    fn next(&mut self) -> Option<(u32, usize)> {
        if self.same != 0 {
            let d = self.same.trailing_zeros() as usize;
            self.same &= self.same - 1;
            let col = (self.column + self.offsets[d]) as usize;
            return Some((self.start[col] + self.rank, d));
        }
        if self.other != 0 {
            let d = self.other.trailing_zeros() as usize;
            self.other &= self.other - 1;
            return Some((self.spans[self.span as usize].links[d], d));
        }
        None
    }
}
