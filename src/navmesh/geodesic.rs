//! Geodesic distance fields over the span grid: the walking distance from every span to the
//! nearest of a set of goal spans.
//!
//! (module documentation rewritten at the end)

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::{Mutex, PoisonError};

use glam::Vec3;

use super::grid::{NavGrid, Span, DIRS, NONE};
use super::los::SightIndex;

/// Distances from every span to the nearest goal, with the anchor chain to follow there.
#[derive(Debug, Clone, PartialEq)]
pub struct DistanceField {
    /// Per span: distance (m) to the nearest goal; `f32::INFINITY` when unreachable or not
    /// walkable. In the weighted mode (`clearance_weight > 1`) a weighted cost.
    pub dist: Vec<f32>,
    /// Per span: the next span of its path to the goal, reached by a straight walk (a goal
    /// is its own anchor; in the weighted mode the next grid neighbour); `NONE` when
    /// unreachable.
    pub anchor: Vec<u32>,
}

impl DistanceField {
    /// Distance of a span to the nearest goal; `None` when unreachable or out of range.
    pub fn distance(&self, span: u32) -> Option<f32> {
        self.dist
            .get(span as usize)
            .copied()
            .filter(|d| d.is_finite())
    }

    /// Can the span reach a goal?
    pub fn reachable(&self, span: u32) -> bool {
        self.distance(span).is_some()
    }

    /// The anchor of a span (the next span towards the goal); `None` when unreachable.
    pub fn anchor(&self, span: u32) -> Option<u32> {
        self.anchor
            .get(span as usize)
            .copied()
            .filter(|&a| a != NONE)
    }
}

/// Per-span search state, 16 bytes: what relaxing a neighbour reads and writes (four
/// records per cache line).
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(16))]
struct State {
    /// Floor height (a copy of the span's).
    y: f32,
    /// Distance to the nearest goal (valid while `mark` is the search's open or closed mark).
    g: f32,
    /// Anchor (valid like `g`).
    anchor: u32,
    /// The search's open mark, its closed mark (open + 1), or older: not reached.
    mark: u32,
}

/// Where a settled span is and how to find its linked spans (from the [`SightIndex`]'s packed
/// record).
#[derive(Debug, Clone, Copy)]
struct Here {
    /// Cell.
    xz: (i64, i64),
    /// Column index.
    column: u32,
    /// Rank of the span in its column: same-layer links land on the same rank.
    rank: u32,
    /// Bit `d`: link `d` leads to the same rank of the neighbouring column.
    same: u8,
    /// Bit `d`: link `d` leads to another rank (read from the grid's span).
    other: u8,
}

/// Maps cells to world positions: the centre of the cell at floor height, computed exactly
/// as [`NavGrid::span_position`] does.
#[derive(Debug, Clone, Copy)]
struct Frame {
    x0: f32,
    z0: f32,
    size: f32,
}

impl Frame {
    /// Position of cell `(ix, iz)` at height `y`.
    #[inline(always)]
    fn pos(&self, (ix, iz): (i64, i64), y: f32) -> Vec3 {
        Vec3::new(
            self.x0 + (ix as f32 + 0.5) * self.size,
            y,
            self.z0 + (iz as f32 + 0.5) * self.size,
        )
    }
}

/// Distance between two points (the arithmetic of [`Vec3::distance`]).
#[inline(always)]
fn dist(p: Vec3, q: Vec3) -> f32 {
    let (dx, dy, dz) = (p.x - q.x, p.y - q.y, p.z - q.z);
    (dx * dx + dy * dy + dz * dz).sqrt()
}

/// Priority queue of spans: a binary min-heap of 64-bit words `(f32 bits of the key) << 32 |
/// span`. For the non-negative keys of a search the bit pattern orders like the value, so
/// spans pop by key and then by index whatever the order of pushes, and a comparison is one
/// integer compare. (A 4-ary heap and a bucketed queue with the same order measured no
/// faster.)
#[derive(Debug, Default)]
struct Queue {
    heap: BinaryHeap<Reverse<u64>>,
}

impl Queue {
    fn clear(&mut self) {
        self.heap.clear();
    }

    #[inline(always)]
    fn push(&mut self, key: f32, span: u32) {
        self.heap
            .push(Reverse((u64::from(key.to_bits()) << 32) | u64::from(span)));
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<u32> {
        self.heap.pop().map(|Reverse(k)| k as u32)
    }

    /// The span that pops next.
    #[inline(always)]
    fn peek(&self) -> Option<u32> {
        self.heap.peek().map(|Reverse(k)| *k as u32)
    }
}

/// Reusable state of one search: the per-span records and the queue.
#[derive(Debug)]
struct Scratch {
    nodes: Vec<State>,
    /// Open mark of the current search (its closed mark is `open + 1`).
    open: u32,
    queue: Queue,
}

impl Scratch {
    /// Starts a new search: new marks (older marks read as "not reached"), empty queue.
    fn begin(&mut self) {
        if self.open >= u32::MAX - 4 {
            self.nodes.iter_mut().for_each(|n| n.mark = 0);
            self.open = 0;
        }
        self.open += 2;
        self.queue.clear();
    }
}

/// The linked spans of one span: same-layer links from the column offsets, then links to
/// other layers from the grid.
struct Links<'a> {
    start: &'a [u32],
    offsets: &'a [i64; 8],
    spans: &'a [Span],
    span: u32,
    column: i64,
    rank: u32,
    same: u8,
    other: u8,
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

/// Everything repeated geodesic queries on one grid need, computed once: the line-of-sight
/// index and the per-span search records (kept in a small pool, one per concurrent query).
pub struct Geodesic<'g> {
    sight: SightIndex<'g>,
    frame: Frame,
    /// Column index offset of one step in each direction.
    offsets: [i64; 8],
    pool: Mutex<Vec<Scratch>>,
}

impl std::fmt::Debug for Geodesic<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Geodesic")
            .field("scene", &self.grid().scene)
            .field("spans", &self.grid().spans.len())
            .finish_non_exhaustive()
    }
}

impl Clone for Geodesic<'_> {
    fn clone(&self) -> Self {
        Geodesic {
            sight: self.sight.clone(),
            frame: self.frame,
            offsets: self.offsets,
            pool: Mutex::new(Vec::new()),
        }
    }
}

impl<'g> Geodesic<'g> {
    /// Precomputes the [`SightIndex`] and the per-span search records (linear in the number
    /// of spans).
    pub fn new(grid: &'g NavGrid) -> Self {
        let nx = i64::from(grid.nx);
        let offsets = DIRS.map(|(dx, dz)| i64::from(dx) + i64::from(dz) * nx);
        let sight = SightIndex::new(grid);
        let geo = Geodesic {
            sight,
            frame: Frame {
                x0: grid.x0,
                z0: grid.z0,
                size: grid.cell(),
            },
            offsets,
            pool: Mutex::new(Vec::new()),
        };
        let first = geo.new_scratch();
        geo.pool
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(first);
        geo
    }

    /// The grid.
    pub fn grid(&self) -> &'g NavGrid {
        self.sight.grid()
    }

    /// The line-of-sight index.
    pub fn sight(&self) -> &SightIndex<'g> {
        &self.sight
    }

    /// World position of a span (as [`NavGrid::span_position`]); `None` when out of range.
    pub fn position(&self, span: u32) -> Option<Vec3> {
        let y = self.grid().spans.get(span as usize)?.y;
        Some(self.frame.pos(self.cell_xz(span), y))
    }

    /// True when fields are exact geodesics (`clearance_weight <= 1`), false in MINOS's
    /// weighted mode.
    pub fn exact(&self) -> bool {
        self.grid().params.clearance_weight <= 1.0
    }

    fn new_scratch(&self) -> Scratch {
        let nodes = (0..self.grid().spans.len() as u32)
            .map(|s| State {
                y: self.sight.column_height(s).1,
                g: f32::INFINITY,
                anchor: NONE,
                mark: 0,
            })
            .collect();
        Scratch {
            nodes,
            open: 0,
            queue: Queue::default(),
        }
    }

    /// Runs `f` with a scratch from the pool (a new one when all are in use).
    fn with_scratch<R>(&self, f: impl FnOnce(&mut Scratch) -> R) -> R {
        let taken = self
            .pool
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .pop();
        let mut scratch = taken.unwrap_or_else(|| self.new_scratch());
        let out = f(&mut scratch);
        self.pool
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(scratch);
        out
    }

    #[inline(always)]
    fn links(&self, here: &Here, span: u32) -> Links<'_> {
        let grid = self.grid();
        Links {
            start: &grid.column_start,
            offsets: &self.offsets,
            spans: &grid.spans,
            span,
            column: i64::from(here.column),
            rank: here.rank,
            same: here.same,
            other: here.other,
        }
    }

    /// Cell of a span (a valid index).
    #[inline(always)]
    fn cell_xz(&self, span: u32) -> (i64, i64) {
        let (column, _) = self.sight.column_height(span);
        let nx = self.grid().nx.max(1);
        (i64::from(column % nx), i64::from(column / nx))
    }

    /// Cell, column, rank and links of a span (a valid index).
    #[inline(always)]
    fn here(&self, span: u32) -> Here {
        let grid = self.grid();
        let (column, _) = self.sight.column_height(span);
        let (same, linked) = self.sight.link_masks(span);
        let nx = grid.nx.max(1);
        let first = grid
            .column_start
            .get(column as usize)
            .copied()
            .unwrap_or(span);
        Here {
            xz: (i64::from(column % nx), i64::from(column / nx)),
            column,
            rank: span.wrapping_sub(first),
            same,
            other: linked & !same,
        }
    }

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

    fn run(&self, sc: &mut Scratch, goals: &[u32], target: Option<u32>) {
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
            self.lazy_theta(sc, target);
        } else {
            self.weighted(sc, target);
        }
    }

    /// Lazy Theta* (see the module documentation).
    fn lazy_theta(&self, sc: &mut Scratch, target: Option<u32>) {
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
                prefetch(nodes, next);
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
                if m.mark == closed {
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
    fn weighted(&self, sc: &mut Scratch, target: Option<u32>) {
        let grid = self.grid();
        let spans = &grid.spans;
        let threshold = grid.params.agent_radius + grid.params.clearance_margin;
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

/// Asks the CPU to start loading a span's record (a hint; no effect on results).
#[inline(always)]
fn prefetch<T>(records: &[T], span: u32) {
    #[cfg(target_arch = "x86_64")]
    if let Some(n) = records.get(span as usize) {
        // SAFETY: prefetching is a hint that never faults; the pointer is to a live record.
        unsafe {
            std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                (n as *const T).cast::<i8>(),
            );
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (records, span);
}

/// The settled spans of the last search as a field.
fn export(sc: &Scratch) -> DistanceField {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::navmesh::los;
    use crate::navmesh::testmaps::{
        reference_geodesic, rows_from, stairs, stairs_reference, MapSpec,
    };
    use crate::navmesh::NavParams;

    fn span_at(grid: &NavGrid, ix: usize, iz: usize) -> u32 {
        grid.column_start[iz * grid.nx as usize + ix]
    }

    /// Relative error of `got` against `want`.
    fn rel(got: f32, want: f64) -> f64 {
        (f64::from(got) - want).abs() / want
    }

    #[test]
    fn empty_room_distances_are_euclidean() {
        let (nx, nz) = (120, 90);
        let rows = rows_from(nx, nz, |x, z| x > 0 && z > 0 && x < nx - 1 && z < nz - 1);
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        let grid = MapSpec::ascii(&refs, 0.05).build(NavParams::default());
        let goal = span_at(&grid, 7, 80);
        let field = distance_field(&grid, &[goal]);
        let gp = grid.span_position(goal as usize);
        let (mut worst, mut octile_worst) = (0.0f64, 0.0f64);
        for (s, span) in grid.spans.iter().enumerate() {
            if !span.walkable || s as u32 == goal {
                assert_eq!(field.distance(s as u32).is_some(), span.walkable);
                continue;
            }
            let p = grid.span_position(s);
            let want = f64::from(p.distance(gp));
            worst = worst.max(rel(field.dist[s], want));
            let (dx, dz) = ((p.x - gp.x).abs(), (p.z - gp.z).abs());
            let octile = dx.max(dz) + (2f32.sqrt() - 1.0) * dx.min(dz);
            octile_worst = octile_worst.max(rel(octile, want));
        }
        assert!(worst < 0.005, "worst relative error {worst}");
        assert!(
            octile_worst > 0.05,
            "the octile metric would fail this test"
        );
        assert_eq!(field.distance(goal), Some(0.0));
        assert_eq!(field.anchor(goal), Some(goal));
    }

    /// Field distance vs the exact polygonal shortest path (in metres) for a map.
    fn compare_with_reference(spec: &MapSpec, a: (usize, usize), b: (usize, usize)) -> (f32, f64) {
        let grid = spec.build(NavParams::default());
        let field = distance_field(&grid, &[span_at(&grid, b.0, b.1)]);
        let got = field.distance(span_at(&grid, a.0, a.1)).unwrap();
        let want = reference_geodesic(
            |x, z| spec.free(x, z),
            spec.nx,
            spec.nz,
            (a.0 as i64, a.1 as i64),
            (b.0 as i64, b.1 as i64),
        )
        .unwrap()
            * f64::from(spec.cell);
        (got, want)
    }

    fn l_corridor() -> MapSpec {
        let rows = rows_from(200, 200, |x, z| {
            let vertical = (2..40).contains(&x) && (2..198).contains(&z);
            let horizontal = (2..198).contains(&x) && (160..198).contains(&z);
            vertical || horizontal
        });
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        MapSpec::ascii(&refs, 0.05)
    }

    #[test]
    fn l_shaped_corridor_matches_the_exact_shortest_path() {
        let spec = l_corridor();
        for (a, b) in [
            ((20, 10), (190, 175)),
            ((3, 5), (195, 196)),
            ((38, 30), (150, 162)),
        ] {
            let (got, want) = compare_with_reference(&spec, a, b);
            let err = rel(got, want);
            assert!(err < 0.01, "{a:?}->{b:?}: {got} vs exact {want} ({err})");
            assert!(
                f64::from(got) > want * 0.9999,
                "shorter than exact: {got} vs {want}"
            );
        }
    }

    #[test]
    fn wall_with_one_doorway_matches_the_exact_shortest_path() {
        let rows = rows_from(240, 140, |x, z| {
            let inside = (1..239).contains(&x) && (1..139).contains(&z);
            let wall = (68..72).contains(&z) && !(150..170).contains(&x);
            inside && !wall
        });
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        let spec = MapSpec::ascii(&refs, 0.05);
        for (a, b) in [
            ((20, 20), (30, 120)),
            ((230, 10), (5, 135)),
            ((160, 30), (100, 100)),
        ] {
            let (got, want) = compare_with_reference(&spec, a, b);
            let err = rel(got, want);
            assert!(err < 0.01, "{a:?}->{b:?}: {got} vs exact {want} ({err})");
            assert!(
                f64::from(got) > want * 0.9999,
                "shorter than exact: {got} vs {want}"
            );
        }
    }

    #[test]
    fn stairs_connect_floors_and_count_the_rise() {
        let grid = stairs().build(NavParams::default());
        let low = span_at(&grid, 3, 2);
        let high = span_at(&grid, 75, 5) + 1;
        assert!((grid.spans[high as usize].y - 3.0).abs() < 1e-6);
        let under = high - 1;
        let field = distance_field(&grid, &[high]);
        let got = field.distance(low).expect("stairs connect the floors");
        let want = stairs_reference((0.35, 0.25), (7.55, 0.55));
        let err = rel(got, want);
        // Straight walks may cut a slope change by up to `profile_tolerance` (half a climb plus
        // a cell) below the surface, so the chord is a little shorter than the surface path.
        assert!(err < 0.015, "{got} vs surface {want} ({err})");
        // The rise counts: the ramp is sqrt(6² + 3²) - 6 = 0.71 m longer than its run, and
        // the flat straight line would be 7.21 m.
        let flat = (7.2f32 * 7.2 + 0.3 * 0.3).sqrt();
        assert!(got > flat + 0.5, "{got} vs flat {flat}");
        // The ground span under the goal is far: back down the ramp.
        let d_under = field.distance(under).unwrap();
        assert!(d_under > 12.0, "under the upper floor: {d_under}");
        assert!(field.distance(under).unwrap() > field.distance(span_at(&grid, 9, 4)).unwrap());
    }

    #[test]
    fn closed_room_is_unreachable() {
        let rows = [
            "############",
            "#....#.....#",
            "#....#.###.#",
            "#....#.#.#.#",
            "#....#.###.#",
            "############",
        ];
        let grid = MapSpec::ascii(&rows, 0.1).build(NavParams::default());
        let field = distance_field(&grid, &[span_at(&grid, 1, 1)]);
        for (ix, iz) in [(6, 1), (10, 4), (8, 3)] {
            let s = span_at(&grid, ix, iz);
            assert_eq!(field.dist[s as usize], f32::INFINITY);
            assert_eq!(field.anchor[s as usize], NONE);
            assert!(!field.reachable(s));
        }
        assert!(field.reachable(span_at(&grid, 4, 4)));
        // Walls are not walkable and never reached.
        assert_eq!(field.distance(span_at(&grid, 5, 2)), None);
        // Only non-walkable or invalid goals: nothing is reachable.
        let none = distance_field(&grid, &[span_at(&grid, 0, 0), u32::MAX]);
        assert!(none.dist.iter().all(|d| d.is_infinite()));
    }

    #[test]
    fn distances_are_symmetric() {
        let spec = l_corridor();
        let grid = spec.build(NavParams::default());
        let geo = Geodesic::new(&grid);
        let pairs = [
            ((20, 10), (190, 175)),
            ((5, 190), (100, 170)),
            ((30, 100), (180, 161)),
        ];
        for (a, b) in pairs {
            let (a, b) = (span_at(&grid, a.0, a.1), span_at(&grid, b.0, b.1));
            let ab = geo.field(&[b]).distance(a).unwrap();
            let ba = geo.field(&[a]).distance(b).unwrap();
            assert!((ab - ba).abs() / ab < 0.01, "{ab} vs {ba}");
        }
    }

    #[test]
    fn several_goals_give_the_nearest_and_order_does_not_matter() {
        let spec = l_corridor();
        let grid = spec.build(NavParams::default());
        let geo = Geodesic::new(&grid);
        let goals = [
            span_at(&grid, 20, 20),
            span_at(&grid, 190, 190),
            span_at(&grid, 30, 170),
        ];
        let both = geo.field(&goals);
        let mut reversed = goals;
        reversed.reverse();
        assert_eq!(geo.field(&reversed), both, "goal order changed the field");
        let singles: Vec<DistanceField> = goals.iter().map(|&g| geo.field(&[g])).collect();
        let mut checked = 0;
        for s in (0..grid.spans.len()).step_by(97) {
            let Some(d) = both.distance(s as u32) else {
                continue;
            };
            let min = singles
                .iter()
                .map(|f| f.dist[s])
                .fold(f32::INFINITY, f32::min);
            assert!(
                (d - min).abs() <= 0.01 * min + 1e-4,
                "span {s}: {d} vs {min}"
            );
            checked += 1;
        }
        assert!(checked > 50);
    }

    #[test]
    fn weighted_mode_charges_narrow_spans() {
        // A corridor 3 cells wide: every span is within radius + margin of a wall.
        let rows = rows_from(60, 5, |x, z| x > 0 && x < 59 && (1..4).contains(&z));
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        let params = NavParams {
            clearance_weight: 10.0,
            ..NavParams::default()
        };
        let grid = MapSpec::ascii(&refs, 0.05).build(params);
        let goal = span_at(&grid, 2, 2);
        let field = distance_field(&grid, &[goal]);
        let d = field.distance(span_at(&grid, 52, 2)).unwrap();
        assert!((d - 10.0 * 50.0 * 0.05).abs() < 1e-3, "{d}");
        assert_eq!(
            field.anchor(span_at(&grid, 52, 2)),
            Some(span_at(&grid, 51, 2))
        );
        let exact = MapSpec::ascii(&refs, 0.05).build(NavParams::default());
        let d1 = distance_field(&exact, &[span_at(&exact, 2, 2)]).distance(span_at(&exact, 52, 2));
        assert!((d1.unwrap() - 2.5).abs() < 1e-4);
    }

    #[test]
    fn every_anchor_is_in_sight_and_distances_add_up() {
        // Scattered single-cell obstacles (many repairs and jumps next to walls) and the
        // two-level stairs map.
        let (nx, nz) = (90usize, 70usize);
        let mut rng = crate::seed::Rng::new(5);
        let blocked: Vec<bool> = (0..nx * nz)
            .map(|i| {
                let (x, z) = (i % nx, i / nx);
                x == 0 || z == 0 || x == nx - 1 || z == nz - 1 || rng.chance(0.03)
            })
            .collect();
        let rows = rows_from(nx, nz, |x, z| !blocked[z * nx + x]);
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        let cluttered = MapSpec::ascii(&refs, 0.05).build(NavParams::default());
        let two_levels = stairs().build(NavParams::default());
        for grid in [&cluttered, &two_levels] {
            let geo = Geodesic::new(grid);
            let walkable: Vec<u32> = (0..grid.spans.len() as u32)
                .filter(|&s| grid.spans[s as usize].walkable)
                .collect();
            let mut checked = 0;
            for _ in 0..4 {
                let goal = *rng.pick(&walkable).unwrap();
                let field = geo.field(&[goal]);
                for &s in &walkable {
                    let Some(d) = field.distance(s) else {
                        continue;
                    };
                    let a = field.anchor[s as usize];
                    assert!(field.reachable(a));
                    assert!(
                        los::line_of_sight(grid, s, a),
                        "span {s} cannot see anchor {a}"
                    );
                    assert!(los::line_of_sight(grid, a, s), "sight is symmetric");
                    let step = grid
                        .span_position(s as usize)
                        .distance(grid.span_position(a as usize));
                    assert!((d - (field.dist[a as usize] + step)).abs() < 1e-3);
                    assert!(a == s || field.dist[a as usize] < d, "anchors get closer");
                    checked += 1;
                }
            }
            assert!(checked > 1000);
        }
    }

    #[test]
    fn single_pair_search_agrees_with_the_field() {
        let spec = l_corridor();
        let grid = spec.build(NavParams::default());
        let geo = Geodesic::new(&grid);
        let (a, b) = (span_at(&grid, 20, 10), span_at(&grid, 190, 175));
        let field = geo.field(&[b]);
        let search = geo.search(b, a);
        let (df, ds) = (field.distance(a).unwrap(), search.distance(a).unwrap());
        assert!((df - ds).abs() / df < 0.005, "{df} vs {ds}");
        let settled = search.dist.iter().filter(|d| d.is_finite()).count();
        assert!(settled < grid.walkable_count(), "the search stopped early");
        assert!(geo
            .search(b, span_at(&grid, 0, 0))
            .dist
            .iter()
            .all(|d| d.is_infinite()));
    }
}
