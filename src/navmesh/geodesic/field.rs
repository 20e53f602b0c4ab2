//! Distance fields: Lazy Theta* from a set of goal spans, the flood that settles at once what
//! a single goal sees, the clear-square block settling around it, and MINOS's weighted
//! Dijkstra for `clearance_weight > 1` (see the module overview in `mod.rs`).

use super::*;
use crate::prefetch::prefetch;

/// Signs `(sx, sz)` of the steps into quadrant `q` of the [`SightIndex`] (bit 0: towards -x,
/// bit 1: towards -z).
#[inline]
pub(super) fn quadrant_signs(q: usize) -> (i64, i64) {
    (
        if q & 1 != 0 { -1 } else { 1 },
        if q & 2 != 0 { -1 } else { 1 },
    )
}

/// The settled spans of the last search as a field.
pub(super) fn export(sc: &Scratch) -> DistanceField {
    let closed = sc.open + 1;
    let (dist, anchor) = sc
        .nodes
        .iter()
        .map(|n| {
            if n.mark == closed {
                (n.g, n.anchor)
            } else {
                (f32::INFINITY, NONE)
            }
        })
        .unzip();
    DistanceField { dist, anchor }
}

/// The distance field from every span to the nearest of `goals` (see the module
/// documentation). Builds a [`Geodesic`] first; keep one for repeated queries on a grid.
pub fn distance_field(grid: &NavGrid, goals: &[u32]) -> DistanceField {
    Geodesic::new(grid).field(goals)
}

impl<'g> Geodesic<'g> {
    /// The full distance field to the nearest of `goals` (non-walkable or out-of-range goals
    /// are ignored; with none left every span is unreachable).
    pub fn field(&self, goals: &[u32]) -> DistanceField {
        self.with_scratch(|sc| {
            self.run(sc, goals, None);
            export(sc)
        })
    }

    /// A single-pair search from `goal` that stops once `start` is settled (A* with the
    /// admissible straight-line heuristic). Only settled spans have values (the others are
    /// `INFINITY`/`NONE`), enough to follow anchors from `start` to `goal`.
    pub fn search(&self, goal: u32, start: u32) -> DistanceField {
        self.with_scratch(|sc| {
            self.run(sc, &[goal], Some(start));
            export(sc)
        })
    }

    /// The anchor chain from `start` to `goal` of [`Geodesic::search`] (`start` first,
    /// `goal` last), without building a whole field; `None` when `start` is not reached.
    pub(crate) fn search_chain(&self, goal: u32, start: u32) -> Option<Vec<u32>> {
        self.with_scratch(|sc| {
            self.run(sc, &[goal], Some(start));
            let closed = sc.open + 1;
            let nodes = &sc.nodes;
            let mut chain = vec![start];
            let mut s = start;
            loop {
                let node = nodes.get(s as usize).filter(|n| n.mark == closed)?;
                let a = node.anchor;
                if a == s {
                    return Some(chain);
                }
                if a == NONE || chain.len() > nodes.len() {
                    return None;
                }
                chain.push(a);
                s = a;
            }
        })
    }

    pub(super) fn run(&self, sc: &mut Scratch, goals: &[u32], target: Option<u32>) {
        sc.begin();
        let grid = self.grid();
        let valid = |s: u32| grid.spans.get(s as usize).is_some_and(|s| s.walkable);
        if target.is_some_and(|t| !valid(t)) {
            return;
        }
        let open = sc.open;
        let target_pos = target.and_then(|t| self.position(t));
        for &goal in goals {
            if !valid(goal) {
                continue;
            }
            let node = &mut sc.nodes[goal as usize];
            if node.mark == open && node.g == 0.0 {
                continue;
            }
            node.g = 0.0;
            node.anchor = goal;
            node.mark = open;
            let key = match (target_pos, self.position(goal)) {
                (Some(p), Some(q)) => dist(p, q),
                _ => 0.0,
            };
            sc.queue.push(key, goal);
        }
        if self.exact() {
            if target.is_none() && sc.queue.len() == 1 {
                self.flood(sc);
            }
            self.lazy_theta(sc, target);
        } else {
            self.weighted(sc, target);
        }
    }

    /// The first step of a field from a single goal: every span the goal sees by a straight
    /// walk gets the straight-line distance and the goal as anchor (no path is shorter), in
    /// a breadth-first flood over links from the goal, without the queue. Spans the flood
    /// reaches but the goal does not see are repaired from their best settled neighbour and
    /// queued for Lazy Theta*, which settles the rest.
    pub(super) fn flood(&self, sc: &mut Scratch) {
        let Some(goal) = sc.queue.pop() else {
            return;
        };
        let sight = &self.sight;
        let fr = self.frame;
        let (open, closed) = (sc.open, sc.open + 1);
        let nodes = &mut sc.nodes[..];
        let fifo = &mut sc.fifo;
        fifo.clear();
        let cg = self.cell_xz(goal);
        let yg = nodes[goal as usize].y;
        let pg = fr.pos(cg, yg);
        nodes[goal as usize].mark = closed;
        fifo.push(goal);
        for q in 0..4 {
            self.settle_block(goal, cg, q, nodes, fifo, closed);
        }
        let mut head = 0;
        let mut hidden = Vec::new();
        let start = &self.grid().column_start[..];
        let nx = self.grid().nx as usize;
        while let Some(&s) = fifo.get(head) {
            head += 1;
            // The queue knows the order: load records well ahead.
            if let Some(&ahead) = fifo.get(head + 16) {
                prefetch(nodes, ahead as usize);
                sight.prefetch(ahead);
            }
            if let Some(&ahead) = fifo.get(head + 8) {
                let c = sight.column_height(ahead).0 as usize;
                prefetch(start, c.wrapping_sub(nx));
                prefetch(start, c + nx);
            }
            if let Some(&ahead) = fifo.get(head + 4) {
                let c = sight.column_height(ahead).0 as usize;
                for cc in [c.wrapping_sub(nx), c + nx] {
                    if let Some(&t) = start.get(cc) {
                        prefetch(nodes, t as usize);
                    }
                }
            }
            let here = self.here(s);
            for (m, d) in self.links(&here, s) {
                let node = &mut nodes[m as usize];
                if node.mark == closed || node.mark == open {
                    continue;
                }
                let (dx, dz) = DIRS[d];
                let cm = (here.xz.0 + i64::from(dx), here.xz.1 + i64::from(dz));
                if sight.straight_line_between((goal, cg, yg), (m, cm, node.y)) {
                    node.g = dist(pg, fr.pos(cm, node.y));
                    node.anchor = goal;
                    node.mark = closed;
                    fifo.push(m);
                } else {
                    node.g = f32::INFINITY;
                    node.anchor = NONE;
                    node.mark = open;
                    hidden.push(m);
                }
            }
        }
        // Repair the hidden spans next to the seen ones, as Lazy Theta* would.
        for m in hidden {
            let here = self.here(m);
            let pm = fr.pos(here.xz, nodes[m as usize].y);
            let (mut best, mut best_k) = (f32::INFINITY, NONE);
            for (k, d) in self.links(&here, m) {
                let nk = &nodes[k as usize];
                if nk.mark == closed {
                    let (dx, dz) = DIRS[d];
                    let pk = fr.pos((here.xz.0 + i64::from(dx), here.xz.1 + i64::from(dz)), nk.y);
                    let c = nk.g + dist(pk, pm);
                    if c < best || (c == best && k < best_k) {
                        best = c;
                        best_k = k;
                    }
                }
            }
            if best_k != NONE {
                let node = &mut nodes[m as usize];
                node.g = best;
                node.anchor = best_k;
                sc.queue.push(best, m);
            }
        }
    }

    /// Number of cells `k` per axis of the square of columns from `goal` (at cell `cg`, rank
    /// `rank` in its column) into quadrant `q` whose spans of that rank all have their three
    /// forward links of the quadrant to flat spans of the same rank (0 when the goal has
    /// not). Read from the [`SightIndex`]'s squares (capped at 255 cells): beyond, the square
    /// is tiled by squares of 254 cells, each certified by the square ahead of its corner.
    pub(super) fn clear_side(&self, goal: u32, cg: (i64, i64), rank: u32, q: usize) -> i64 {
        let sight = &self.sight;
        let l0 = i64::from(sight.square_ahead(goal, q));
        if l0 < 255 {
            return (l0 - 1).max(0);
        }
        const TILE: i64 = 254;
        let grid = self.grid();
        let start = &grid.column_start;
        let (sx, sz) = quadrant_signs(q);
        // Cells to the grid's edge along each axis, the goal's included.
        let reach = |c: i64, s: i64, n: u32| if s > 0 { i64::from(n) - c } else { c + 1 };
        let most = reach(cg.0, sx, grid.nx).min(reach(cg.1, sz, grid.nz));
        let corner = |ox: i64, oz: i64| -> Option<u32> {
            let col = grid.column(cg.0 + sx * ox, cg.1 + sz * oz)?;
            let s = start.get(col)?.checked_add(rank)?;
            (s < *start.get(col + 1)?).then_some(s)
        };
        // Tiles of TILE cells from offsets 0, TILE, 2 TILE, ..., the last one moved back
        // to end on the square's edge (k >= TILE).
        let clear = |k: i64| {
            let at = |i: i64| (i * TILE).min(k - TILE);
            let tiles = (k + TILE - 1) / TILE;
            (0..tiles).all(|j| {
                (0..tiles).all(|i| {
                    corner(at(i), at(j)).is_some_and(|t| i64::from(sight.square_ahead(t, q)) > TILE)
                })
            })
        };
        // `clear` holds exactly when the k × k square is clear, so it is monotone in k.
        let (mut lo, mut hi) = (TILE, most.max(TILE));
        while lo < hi {
            let mid = lo + (hi - lo + 1) / 2;
            if clear(mid) {
                lo = mid;
            } else {
                hi = mid - 1;
            }
        }
        lo
    }

    /// Settles at once the rectangle of spans ahead of `goal` (at cell `cg`) in quadrant `q`
    /// that the goal sees whole, without walking to each: in the clear square of
    /// [`Geodesic::clear_side`], the rows from the goal's while the floor heights of the
    /// rectangle stay within half the profile tolerance. A straight walk from the goal to
    /// a span of the rectangle then steps only on spans of the rectangle, of the goal's rank,
    /// and its height checks pass, so it succeeds (the answer the flood's walk would give).
    /// Spans whose links may lead out of the rectangle go on the flood's queue so that their
    /// links are followed: those on its edges, and inside, those with links to other ranks
    /// (where the rows around are not all single-span columns, read from the link masks).
    /// Not inlined: its loops need the registers.
    #[inline(never)]
    pub(super) fn settle_block(
        &self,
        goal: u32,
        cg: (i64, i64),
        q: usize,
        nodes: &mut [State],
        fifo: &mut Vec<u32>,
        closed: u32,
    ) {
        let grid = self.grid();
        let start = &grid.column_start[..];
        let Some(&first) = grid.column(cg.0, cg.1).and_then(|c| start.get(c)) else {
            return;
        };
        let rank = goal.wrapping_sub(first);
        let k = self.clear_side(goal, cg, rank, q);
        let (sx, sz) = quadrant_signs(q);
        // The rectangle's columns must lie in the grid (they do: its spans exist).
        if k < 2
            || grid
                .column(cg.0 + sx * (k - 1), cg.1 + sz * (k - 1))
                .is_none()
        {
            return;
        }
        let ku = k as usize;
        let fr = self.frame;
        let yg = nodes[goal as usize].y;
        if yg.is_nan() {
            return;
        }
        let pg = fr.pos(cg, yg);
        let limit = 0.5 * crate::navmesh::los::profile_tolerance(grid);
        let (mut lo, mut hi) = (yg, yg);
        let nx = i64::from(grid.nx);
        // Whether a row's columns of the rectangle (one more on each side, inside the grid)
        // all hold a single span.
        let x0 = cg.0;
        let (xa, xb) = if sx > 0 {
            ((x0 - 1).max(0), (x0 + k).min(nx - 1))
        } else {
            ((x0 - k).max(0), (x0 + 1).min(nx - 1))
        };
        let single = |iz: i64| {
            let r = (iz * nx) as usize;
            let (a, b) = (r + xa as usize, r + xb as usize + 1);
            start
                .get(a..=b)
                .is_some_and(|w| w.windows(2).all(|p| p[1].wrapping_sub(p[0]) == 1))
        };
        // Spans of the current and previous rows, lowest x first.
        let mut row: Vec<u32> = Vec::with_capacity(ku);
        let mut pending: Vec<u32> = Vec::with_capacity(ku);
        // Single-span rows: the previous row's and the one before it.
        let (mut single_prev2, mut single_prev) = (false, false);
        let mut settled = 0;
        // The rectangle's columns in a row, lowest x first.
        let xmin = if sx > 0 { x0 } else { x0 - (k - 1) };
        for oz in 0..k {
            let iz = cg.1 + sz * oz;
            // The row's spans (of the goal's rank), and their height range.
            let c = (iz * nx + xmin) as usize;
            let Some(bounds) = start.get(c..=c + ku) else {
                break;
            };
            row.clear();
            for w in bounds.windows(2) {
                match w[0].checked_add(rank) {
                    Some(s) if s < w[1] => row.push(s),
                    _ => break,
                }
            }
            if row.len() < ku {
                break;
            }
            let (mut rlo, mut rhi, mut nan) = (lo, hi, false);
            for &s in &row {
                let y = nodes[s as usize].y;
                rlo = if y < rlo { y } else { rlo };
                rhi = if y > rhi { y } else { rhi };
                nan |= y.is_nan();
            }
            if nan || rhi - rlo > limit {
                break;
            }
            (lo, hi) = (rlo, rhi);
            let single_cur = rank == 0 && single(iz);
            for (i, &s) in row.iter().enumerate() {
                let node = &mut nodes[s as usize];
                if node.mark != closed {
                    let cm = (xmin + i as i64, iz);
                    node.g = dist(pg, fr.pos(cm, node.y));
                    node.anchor = goal;
                    node.mark = closed;
                }
            }
            // The previous row is inside (not the first row): its spans other than the end
            // ones need their links followed only when they may lead to another rank.
            if oz >= 2 {
                if single_prev2 && single_prev && single_cur {
                    fifo.push(pending[0]);
                    fifo.push(pending[ku - 1]);
                } else {
                    for (ox, &s) in pending.iter().enumerate() {
                        let (same, linked) = self.sight.link_masks(s);
                        if ox == 0 || ox == ku - 1 || linked & !same != 0 {
                            fifo.push(s);
                        }
                    }
                }
            } else if oz == 1 {
                fifo.extend_from_slice(&pending);
            }
            std::mem::swap(&mut row, &mut pending);
            (single_prev2, single_prev) = (single_prev, single_cur);
            settled = oz + 1;
        }
        // The last row settled is an edge of the rectangle.
        if settled > 0 {
            fifo.extend_from_slice(&pending);
        }
    }

    /// Lazy Theta* (see the module documentation).
    pub(super) fn lazy_theta(&self, sc: &mut Scratch, target: Option<u32>) {
        let sight = &self.sight;
        let fr = self.frame;
        let (open, closed) = (sc.open, sc.open + 1);
        let nodes = &mut sc.nodes[..];
        let queue = &mut sc.queue;
        let tp = target.and_then(|t| self.position(t));
        while let Some(s) = queue.pop() {
            let su = s as usize;
            let node = nodes[su];
            if node.mark == closed {
                continue;
            }
            if let Some(next) = queue.peek() {
                prefetch(nodes, next as usize);
                sight.prefetch(next);
            }
            let cell = self.here(s);
            let mut a = node.anchor;
            let mut na = nodes[a as usize];
            let mut ca = self.cell_xz(a);
            let (ix, iz) = cell.xz;
            if a != s && !sight.straight_line_between((a, ca, na.y), (s, (ix, iz), node.y)) {
                // Repair from the best settled neighbour (the one that proposed the anchor is
                // among them, so there is one).
                let ps = fr.pos((ix, iz), node.y);
                let (mut best, mut best_k) = (f32::INFINITY, NONE);
                for (k, d) in self.links(&cell, s) {
                    let nk = &nodes[k as usize];
                    if nk.mark == closed {
                        let (dx, dz) = DIRS[d];
                        let pk = fr.pos((ix + i64::from(dx), iz + i64::from(dz)), nk.y);
                        let c = nk.g + dist(pk, ps);
                        if c < best || (c == best && k < best_k) {
                            best = c;
                            best_k = k;
                        }
                    }
                }
                let slot = &mut nodes[su];
                slot.g = best;
                slot.anchor = best_k;
                slot.mark = closed;
                if best_k == NONE {
                    continue;
                }
                a = best_k;
                na = nodes[a as usize];
                ca = self.cell_xz(a);
            } else {
                nodes[su].mark = closed;
            }
            if target == Some(s) {
                return;
            }
            let (ga, pa) = (na.g, fr.pos(ca, na.y));
            for (nb, d) in self.links(&cell, s) {
                let m = &mut nodes[nb as usize];
                // Closed, or already proposed this anchor (the same distance again).
                if m.mark == closed || (m.mark == open && m.anchor == a) {
                    continue;
                }
                let (dx, dz) = DIRS[d];
                let pn = fr.pos((ix + i64::from(dx), iz + i64::from(dz)), m.y);
                let c = ga + dist(pa, pn);
                if m.mark != open || c < m.g {
                    m.g = c;
                    m.anchor = a;
                    m.mark = open;
                    let key = tp.map_or(c, |p| c + dist(p, pn));
                    queue.push(key, nb);
                }
            }
        }
    }

    /// MINOS's clearance-weighted 8-connected Dijkstra (A* towards `target` if given).
    pub(super) fn weighted(&self, sc: &mut Scratch, target: Option<u32>) {
        let grid = self.grid();
        let spans = &grid.spans;
        let threshold = grid.params.body.radius + grid.params.clearance_margin;
        let weight = grid.params.clearance_weight;
        let fr = self.frame;
        let (open, closed) = (sc.open, sc.open + 1);
        let nodes = &mut sc.nodes[..];
        let queue = &mut sc.queue;
        let tp = target.and_then(|t| self.position(t));
        while let Some(s) = queue.pop() {
            let su = s as usize;
            let node = nodes[su];
            if node.mark == closed {
                continue;
            }
            nodes[su].mark = closed;
            if target == Some(s) {
                return;
            }
            let cell = self.here(s);
            let (ix, iz) = cell.xz;
            let ps = fr.pos((ix, iz), node.y);
            for (nb, d) in self.links(&cell, s) {
                let m = &mut nodes[nb as usize];
                if m.mark == closed {
                    continue;
                }
                let w = if spans[nb as usize].clearance < threshold {
                    weight
                } else {
                    1.0
                };
                let (dx, dz) = DIRS[d];
                let pn = fr.pos((ix + i64::from(dx), iz + i64::from(dz)), m.y);
                let c = node.g + dist(ps, pn) * w;
                if m.mark != open || c < m.g {
                    m.g = c;
                    m.anchor = s;
                    m.mark = open;
                    let key = tp.map_or(c, |p| c + dist(p, pn));
                    queue.push(key, nb);
                }
            }
        }
    }
}
