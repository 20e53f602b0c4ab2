//! The sight index: the spans packed with their links as bit masks (SSE2 on x86-64, the
//! branch-free loop elsewhere and as the tested reference), the clear squares ahead of each
//! span per quadrant (stored in `.nav` since format 3, swept by rows otherwise), and the
//! straight walks that use them.

use super::*;

/// What a walk reads of one span, packed.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct SightSpan {
    /// Floor height.
    pub(super) y: f32,
    /// Column index.
    pub(super) column: u32,
    /// Per quadrant (see [`quadrant`]): side of the clear square ahead, in cells.
    pub(super) ahead: [u8; 4],
    /// Bit `d`: link `d` exists and leads to the span of the same rank in its column.
    pub(super) same_rank: u8,
    /// Bit `d`: link `d` exists.
    pub(super) linked: u8,
}

/// Link masks of a span of rank `rank` in its column (`links`: its links; `lo`, `count`:
/// first span and span count of the neighbouring column in each direction; `n`: the span
/// count): `(same_rank, linked)`, bit `d` of `linked` set when link `d` exists (is below
/// `n`; `NONE` never is), of `same_rank` when it also lands at `lo[d] + rank` with `rank <
/// count[d]`. The eight links are compared four at a time (SSE2, part of every x86-64).
#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
#[inline]
pub(super) fn link_bits(
    links: &[u32; 8],
    n: u32,
    lo: &[u32; 8],
    count: &[u32; 8],
    rank: u32,
) -> (u8, u8) {
    use std::arch::x86_64::{
        __m128i, _mm_add_epi32, _mm_and_si128, _mm_castsi128_ps, _mm_cmpeq_epi32, _mm_cmplt_epi32,
        _mm_movemask_ps, _mm_set1_epi32, _mm_set_epi32, _mm_xor_si128,
    };
    // SAFETY: SSE2 is enabled (cfg above); the intrinsics only compute on values.
    unsafe {
        let four = |a: &[u32; 8], h: usize| -> __m128i {
            _mm_set_epi32(
                a[4 * h + 3] as i32,
                a[4 * h + 2] as i32,
                a[4 * h + 1] as i32,
                a[4 * h] as i32,
            )
        };
        // Unsigned comparisons as signed ones of the values with their top bit flipped.
        let bias = _mm_set1_epi32(i32::MIN);
        let (nb, r) = (
            _mm_set1_epi32((n ^ 1 << 31) as i32),
            _mm_set1_epi32(rank as i32),
        );
        let rb = _mm_xor_si128(r, bias);
        let (mut same, mut linked) = (0u8, 0u8);
        for h in 0..2 {
            let l = four(links, h);
            let ok = _mm_cmplt_epi32(_mm_xor_si128(l, bias), nb);
            let on = _mm_cmpeq_epi32(l, _mm_add_epi32(four(lo, h), r));
            let live = _mm_cmplt_epi32(rb, _mm_xor_si128(four(count, h), bias));
            let both = _mm_and_si128(_mm_and_si128(ok, on), live);
            linked |= (_mm_movemask_ps(_mm_castsi128_ps(ok)) as u8) << (4 * h);
            same |= (_mm_movemask_ps(_mm_castsi128_ps(both)) as u8) << (4 * h);
        }
        (same, linked)
    }
}

/// Link masks of a span (see the x86-64 version), one link at a time.
#[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
#[inline]
pub(super) fn link_bits(
    links: &[u32; 8],
    n: u32,
    lo: &[u32; 8],
    count: &[u32; 8],
    rank: u32,
) -> (u8, u8) {
    link_bits_plain(links, n, lo, count, rank)
}

/// [`link_bits`] one link at a time (branch-free; the reference the SSE2 version is tested
/// against).
#[cfg_attr(all(target_arch = "x86_64", target_feature = "sse2"), allow(dead_code))]
#[inline]
pub(super) fn link_bits_plain(
    links: &[u32; 8],
    n: u32,
    lo: &[u32; 8],
    count: &[u32; 8],
    rank: u32,
) -> (u8, u8) {
    let (mut same, mut linked) = (0u8, 0u8);
    for d in 0..8 {
        let l = links[d];
        let ok = l < n;
        linked |= u8::from(ok) << d;
        let on_rank = (l.wrapping_sub(lo[d]) == rank) & (rank < count[d]);
        same |= u8::from(ok & on_rank) << d;
    }
    (same, linked)
}

/// Precomputed data for fast repeated line-of-sight queries on one grid.
///
/// Per span: its height, column, which links stay on the same layer (rank in the column),
/// and, per quadrant of directions, the side `L` of the square of columns ahead of it (the
/// span at one corner, up to 255 cells) in which every span is walkable, has the same rank,
/// and has its three forward links (the two axis steps and the diagonal of the quadrant) to
/// spans at most a quarter of `max_climb` higher or lower. A walk heading into that quadrant
/// cannot fail inside the square, so it is jumped in one go.
#[derive(Debug, Clone)]
pub struct SightIndex<'g> {
    pub(super) grid: &'g NavGrid,
    pub(super) spans: Vec<SightSpan>,
    /// Column index offset of one step in each direction.
    pub(super) offsets: [i64; 8],
    /// [`profile_tolerance`] of the grid.
    pub(super) tolerance: f32,
}

impl<'g> SightIndex<'g> {
    /// The index of a grid: the clear squares stored with it ([`NavGrid::baked`], read from
    /// its `.nav` file) when it carries one per span, otherwise built as by
    /// [`SightIndex::build`]. Either way one pass over the columns packs the spans and their
    /// link masks (what a walk reads to find the next span, checked against the grid's own
    /// links): stored squares can only make a walk jump where it would have stepped.
    pub fn new(grid: &'g NavGrid) -> Self {
        let squares = &grid.baked.sight_squares;
        if squares.is_empty() || squares.len() != grid.spans.len() {
            return Self::build(grid);
        }
        Self::packed(grid, squares)
    }

    /// Builds the index from the grid alone: one pass over the columns (packed spans, link
    /// masks), then the clear squares of every quadrant by row sweeps (`squares_ahead`).
    pub fn build(grid: &'g NavGrid) -> Self {
        let mut index = Self::packed(grid, &[]);
        squares_ahead(grid, &mut index.spans);
        index
    }

    /// Per span, the side of the clear square ahead in each quadrant (what a `.nav` file
    /// stores, see [`NavGrid::baked`]).
    pub fn squares(&self) -> Vec<[u8; 4]> {
        self.spans.iter().map(|s| s.ahead).collect()
    }

    /// The packed spans and link masks, with the clear squares of `squares` (one per span, as
    /// [`SightIndex::squares`] gives them; every `ahead` is 0 where it is shorter), set in
    /// the same pass.
    pub(super) fn packed(grid: &'g NavGrid, squares: &[[u8; 4]]) -> Self {
        let n = grid.spans.len();
        let start = &grid.column_start;
        let (nx, nz) = (grid.nx as usize, grid.nz as usize);
        let columns = start.len().saturating_sub(1).min(nx * nz);
        let mut spans = Vec::with_capacity(n);
        let near = DIRS.map(|(dx, dz)| dx as isize + dz as isize * nx as isize);
        let mut c = 0;
        'rows: for iz in 0..nz {
            for ix in 0..nx {
                if c >= columns {
                    break 'rows;
                }
                let (s0, s1) = (start[c] as usize, (start[c + 1] as usize).min(n));
                if s0 < s1 {
                    // First span and span count of the neighbouring column in each direction
                    // (none outside the grid): a link to the same rank lands at `lo + rank`.
                    let (mut lo, mut count) = ([0u32; 8], [0u32; 8]);
                    if ix > 0 && iz > 0 && ix + 1 < nx && iz + 1 < nz && c + nx + 2 < start.len() {
                        // Inside the grid: all eight neighbours exist.
                        for d in 0..8 {
                            let cc = c.wrapping_add_signed(near[d]);
                            (lo[d], count[d]) =
                                (start[cc], start[cc + 1].saturating_sub(start[cc]));
                        }
                    } else {
                        for (d, &(dx, dz)) in DIRS.iter().enumerate() {
                            let (jx, jz) = (ix as i64 + i64::from(dx), iz as i64 + i64::from(dz));
                            if jx >= 0 && jz >= 0 && (jx as usize) < nx && (jz as usize) < nz {
                                let cc = jz as usize * nx + jx as usize;
                                if let (Some(&a), Some(&b)) = (start.get(cc), start.get(cc + 1)) {
                                    (lo[d], count[d]) = (a, b.saturating_sub(a));
                                }
                            }
                        }
                    }
                    let n32 = n as u32;
                    for s in s0..s1 {
                        if spans.len() != s {
                            // Malformed column ranges: no fast paths for the rest.
                            break 'rows;
                        }
                        let span = &grid.spans[s];
                        let rank = (s - s0) as u32;
                        let (same, linked) = link_bits(&span.links, n32, &lo, &count, rank);
                        spans.push(SightSpan {
                            y: span.y,
                            column: c as u32,
                            ahead: squares.get(s).copied().unwrap_or([0; 4]),
                            same_rank: same,
                            linked,
                        });
                    }
                }
                c += 1;
            }
        }
        // Spans outside every column range (malformed grids) get no links.
        let done = spans.len();
        spans.extend(
            grid.spans[done..]
                .iter()
                .enumerate()
                .map(|(i, s)| SightSpan {
                    y: s.y,
                    ahead: squares.get(done + i).copied().unwrap_or([0; 4]),
                    ..SightSpan::default()
                }),
        );
        let nx = i64::from(grid.nx);
        let offsets = DIRS.map(|(dx, dz)| i64::from(dx) + i64::from(dz) * nx);
        SightIndex {
            grid,
            spans,
            offsets,
            tolerance: profile_tolerance(grid),
        }
    }

    /// The grid this index was built for.
    pub fn grid(&self) -> &'g NavGrid {
        self.grid
    }

    /// Asks the CPU to start loading a span's packed record (a hint; no effect on results).
    #[inline]
    pub(crate) fn prefetch(&self, span: u32) {
        crate::prefetch::prefetch(&self.spans, span as usize);
    }

    /// Column and floor height of a span (a valid index).
    #[inline]
    pub(crate) fn column_height(&self, span: u32) -> (u32, f32) {
        let s = &self.spans[span as usize];
        (s.column, s.y)
    }

    /// Link masks of a span (a valid index): bit `d` of the first is set when link `d`
    /// leads to the span of the same rank in the neighbouring column, bit `d` of the second
    /// when link `d` exists.
    #[inline]
    pub(crate) fn link_masks(&self, span: u32) -> (u8, u8) {
        let s = &self.spans[span as usize];
        (s.same_rank, s.linked)
    }

    /// Side `L` of the clear square ahead of a span (a valid index) in quadrant `q` (bit 0:
    /// heading to -x, bit 1: heading to -z; a walk along an axis uses the quadrant on the
    /// positive side of the other axis): `L >= k` exactly when every span of the
    /// `(k - 1) × (k - 1)` columns from this one into the quadrant has its three forward links
    /// to flat spans of the same rank. Capped at 255.
    #[inline]
    pub(crate) fn square_ahead(&self, span: u32, q: usize) -> u8 {
        self.spans[span as usize].ahead[q & 3]
    }

    /// How many cells a walk from this span can jump at most, over all directions (0: it
    /// steps cell by cell whatever the direction).
    #[cfg(test)]
    pub(crate) fn jump_reach(&self, span: u32) -> u16 {
        self.spans.get(span as usize).map_or(0, |s| {
            u16::from(s.ahead.iter().max().copied().unwrap_or(0).saturating_sub(1))
        })
    }

    /// Same answer as `los::line_of_sight` (the plain walk), jumping across open floor.
    #[cfg(test)]
    pub(crate) fn line_of_sight(&self, from: u32, to: u32) -> bool {
        self.query(from, to, false)
    }

    /// Same answer as [`straight_line`] except that heights are not checked inside jumped
    /// flat blocks (only where the walk enters and leaves them), jumping across open floor.
    pub fn straight_line(&self, from: u32, to: u32) -> bool {
        self.query(from, to, true)
    }

    #[inline]
    pub(super) fn query(&self, from: u32, to: u32, profile: bool) -> bool {
        walkable_pair(self.grid, from, to) && self.trace(from, to, profile)
    }

    /// [`SightIndex::straight_line`] for two spans the caller knows to be walkable, given
    /// their cells `a`, `b` and floor heights `ya`, `yb` (reads only the packed copy of the
    /// spans the walk lands on, starting with `from`'s).
    #[inline]
    pub(crate) fn straight_line_between(
        &self,
        (from, a, ya): (u32, (i64, i64), f32),
        (to, b, yb): (u32, (i64, i64), f32),
    ) -> bool {
        from == to || self.trace_cells(from, to, (a, b), (ya, yb), true)
    }

    /// The walk over the packed spans, with jumps.
    pub(super) fn trace(&self, from: u32, to: u32, profile: bool) -> bool {
        if from == to {
            return true;
        }
        let (fi, ti) = (self.spans[from as usize], self.spans[to as usize]);
        let w = self.grid.nx.max(1);
        let a = (i64::from(fi.column % w), i64::from(fi.column / w));
        let b = (i64::from(ti.column % w), i64::from(ti.column / w));
        self.trace_cells(from, to, (a, b), (fi.y, ti.y), profile)
    }

    /// [`SightIndex::trace`] with the cells and heights of both ends known (`from != to`).
    pub(super) fn trace_cells(
        &self,
        from: u32,
        to: u32,
        (a, b): ((i64, i64), (i64, i64)),
        (ya, yb): (f32, f32),
        profile: bool,
    ) -> bool {
        let start = &self.grid.column_start;
        let walk = Walk::with_heights(from, to, (a, b), (ya, yb), profile, self.tolerance);
        let (dx, dz) = (b.0 - a.0, b.1 - a.1);
        if dx == 0 && dz == 0 {
            return false;
        }
        let (sx, sz) = (dx.signum(), dz.signum());
        let nx = i64::from(self.grid.nx.max(1));
        let mut dda = Dda::new(dx, dz);
        let q = quadrant(sx, sz);
        let mut cur = from;
        let mut info = self.spans[from as usize];
        let mut rank = cur - start[info.column as usize];
        loop {
            if dda.done() {
                return cur == to;
            }
            let r = u64::from(info.ahead[q]).saturating_sub(1);
            if r > 0 {
                if dda.nx - dda.kx <= r && dda.nz - dda.kz <= r {
                    // The target column lies inside the clear square: the walk reaches the
                    // span of the same rank there.
                    return start[(walk.b.1 * nx + walk.b.0) as usize] + rank == to;
                }
                let (kx, kz) = dda.before_leaving(r);
                let (ox, oz) = (sx * kx as i64, sz * kz as i64);
                let col = ((walk.a.1 + oz) * nx + walk.a.0 + ox) as usize;
                let land = start[col] + rank;
                if land < start[col + 1] {
                    let land_info = self.spans[land as usize];
                    if !walk.on_profile(ox, oz, land_info.y) {
                        return false;
                    }
                    dda.kx = kx;
                    dda.kz = kz;
                    cur = land;
                    info = land_info;
                }
            }
            let d = dda.step();
            if info.same_rank & (1 << d) != 0 {
                let col = (i64::from(info.column) + self.offsets[d]) as usize;
                cur = start[col] + rank;
                info = self.spans[cur as usize];
            } else {
                if info.linked & (1 << d) == 0 {
                    // Blocked: known from the packed record, without reading the span.
                    return false;
                }
                cur = self.grid.spans[cur as usize].links[d];
                if cur == NONE {
                    return false;
                }
                info = self.spans[cur as usize];
                rank = cur - start[info.column as usize];
            }
            if !walk.on_profile(sx * dda.kx as i64, sz * dda.kz as i64, info.y) {
                return false;
            }
        }
    }
}

/// Quadrant index of a walk direction: bit 0 set when heading to -x, bit 1 when heading to
/// -z (a walk along an axis uses the quadrant on the positive side of the other axis).
#[inline]
pub(super) fn quadrant(sx: i64, sz: i64) -> usize {
    usize::from(sx < 0) | (usize::from(sz < 0) << 1)
}

/// Fills `ahead` of every packed span: per quadrant `q`, the largest-square recurrence
/// `L(s) = 1 + min(L(x), L(z), L(diagonal))` over the three forward links of the quadrant
/// (all to the same rank, within the flat limit; otherwise `L(s) = 1`), with columns visited
/// from the far corner so that forward neighbours come first. Two sweeps over the rows (from
/// the last row for the quadrants heading to +z, from the first for those heading to -z),
/// each row visited in both x orders while it is in cache. The first span of each column
/// (nearly all spans) is computed from dense per-row copies of its height, links and sizes
/// (the x neighbour's size carried in a register); spans above it read their neighbours from
/// the packed records. Walkability is not read: the builder links walkable spans only, what
/// a walk needs is the links, and a span without its forward links (size 1) is never jumped
/// over.
pub(super) fn squares_ahead(grid: &NavGrid, packed: &mut [SightSpan]) {
    let flat = FLAT_FRACTION * grid.params.body.max_climb;
    let (nx, nz) = (grid.nx as usize, grid.nz as usize);
    let start = &grid.column_start;
    if nx == 0 || start.len() < nx * nz + 1 {
        return;
    }
    let n = packed.len();
    // Per column of the current row, at index ix + 1 (one entry of padding on each side):
    // its first span (`NONE` when it has none) and how many spans it has above it; the
    // first span's height and same-rank links; the heights of the row before (the row the
    // forward z links lead to). Entries of columns without spans, and the padding, are only
    // read for a link that does not exist, and then ignored.
    let mut first = vec![(NONE, 0u32); nx + 2];
    let mut mask = vec![0u8; nx + 2];
    let (mut y, mut y_prev) = (vec![0f32; nx + 2], vec![0f32; nx + 2]);
    // Per quadrant of the sweep (heading to +x, to -x): sizes of the first spans of the
    // current row and of the row before.
    let mut size = [vec![0u8; nx + 2], vec![0u8; nx + 2]];
    let mut size_prev = [vec![0u8; nx + 2], vec![0u8; nx + 2]];
    // Columns of the current row holding more than one span, by x.
    let mut stacked: Vec<usize> = Vec::new();
    for sz in [1i32, -1] {
        for step_z in 0..nz {
            let iz = if sz > 0 { nz - 1 - step_z } else { step_z };
            std::mem::swap(&mut y, &mut y_prev);
            std::mem::swap(&mut size, &mut size_prev);
            let row = iz * nx;
            stacked.clear();
            for ix in 0..nx {
                let c = row + ix;
                let (s0, s1) = (start[c] as usize, (start[c + 1] as usize).min(n));
                if s0 < s1 {
                    let p = &packed[s0];
                    if s1 - s0 > 1 {
                        stacked.push(ix);
                    }
                    first[ix + 1] = (s0 as u32, (s1 - s0 - 1) as u32);
                    y[ix + 1] = p.y;
                    mask[ix + 1] = p.same_rank;
                } else {
                    first[ix + 1] = (NONE, 0);
                    mask[ix + 1] = 0;
                }
            }
            for (k, sx) in [1i32, -1].into_iter().enumerate() {
                let q = usize::from(sx < 0) | (usize::from(sz < 0) << 1);
                let dir = |dx: i32, dz: i32| DIRS.iter().position(|&d| d == (dx, dz)).unwrap_or(0);
                let (xd, zd, dd) = (dir(sx, 0), dir(0, sz), dir(sx, sz));
                let forward = (1u8 << xd) | (1u8 << zd) | (1u8 << dd);
                let cur = &mut size[k];
                sweep_first_spans(
                    (&mask, &y, &y_prev),
                    (&size_prev[k], cur),
                    forward,
                    flat,
                    sx > 0,
                );
                let offs =
                    [xd, zd, dd].map(|d| i64::from(DIRS[d].0) + i64::from(DIRS[d].1) * nx as i64);
                for (&(s0, _), &l) in first[1..=nx].iter().zip(&cur[1..=nx]) {
                    if s0 != NONE {
                        packed[s0 as usize].ahead[q] = l;
                    }
                }
                // Spans above the first, visited from the far end (their x neighbours come
                // first), from the packed records.
                for t in 0..stacked.len() {
                    let ix = stacked[if sx > 0 { stacked.len() - 1 - t } else { t }];
                    let c = row + ix;
                    let (s0, above) = first[ix + 1];
                    for s in s0 as usize + 1..=s0 as usize + above as usize {
                        let (h, same_rank) = (packed[s].y, packed[s].same_rank);
                        let size = if same_rank & forward != forward {
                            1
                        } else {
                            let rank = (s - s0 as usize) as u32;
                            let mut min = u8::MAX;
                            let mut ok = true;
                            for off in offs {
                                let l = (start[(c as i64 + off) as usize] + rank) as usize;
                                ok &= (packed[l].y - h).abs() <= flat;
                                min = min.min(packed[l].ahead[q]);
                            }
                            if ok {
                                min.saturating_add(1)
                            } else {
                                1
                            }
                        };
                        packed[s].ahead[q] = size;
                    }
                }
            }
        }
    }
}

/// The recurrence of [`squares_ahead`] for the first spans of one row's columns, from dense
/// copies (index ix + 1): their same-rank links and heights, the heights and sizes of the row
/// before, into `cur`; visited from the far end (`plus_x`: heading to +x, so from the last
/// column), the x neighbour's size carried along.
#[inline(never)]
pub(super) fn sweep_first_spans(
    (mask, y, y_prev): (&[u8], &[f32], &[f32]),
    (prev, cur): (&[u8], &mut [u8]),
    forward: u8,
    flat: f32,
    plus_x: bool,
) {
    let m = cur.len();
    if m < 3 {
        return;
    }
    let (mask, y, y_prev, prev) = (&mask[..m], &y[..m], &y_prev[..m], &prev[..m]);
    #[inline(always)]
    fn size(
        (mask, y, y_prev, prev): (&[u8], &[f32], &[f32], &[u8]),
        forward: u8,
        flat: f32,
        i: usize,
        j: usize,
        carry: u8,
    ) -> u8 {
        let h = y[i];
        let ok = (mask[i] & forward == forward)
            & ((y[j] - h).abs() <= flat)
            & ((y_prev[i] - h).abs() <= flat)
            & ((y_prev[j] - h).abs() <= flat);
        let l = carry.min(prev[i]).min(prev[j]).saturating_add(1);
        if ok {
            l
        } else {
            1
        }
    }
    let rows = (mask, y, y_prev, prev);
    let mut carry = 0u8;
    // Index loops (the neighbour is `i ± 1`): iterator adapters compiled slower here.
    if plus_x {
        let mut i = m - 2;
        while i >= 1 {
            carry = size(rows, forward, flat, i, i + 1, carry);
            cur[i] = carry;
            i -= 1;
        }
    } else {
        let mut i = 1;
        while i < m - 1 {
            carry = size(rows, forward, flat, i, i - 1, carry);
            cur[i] = carry;
            i += 1;
        }
    }
}
