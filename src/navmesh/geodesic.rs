//! Geodesic distances over the span grid: distance fields (the walking distance from every
//! span to the nearest of a set of goal spans) and point-to-point shortest paths.
//!
//! Distances approximate the true shortest path through free space, not the octile metric of
//! an 8-connected grid search (which overestimates by up to 8 %).
//!
//! # Fields: Lazy Theta*
//!
//! Each span keeps a distance `g` and an *anchor*, the span its path heads to in a straight
//! line. Relaxing neighbour `n` of a popped span `s` proposes `s`'s anchor, at cost
//! `g(anchor) + |anchor − n|` (3D distance between span positions, so stairs count their
//! rise). When a span is popped its anchor is verified with the [`SightIndex`]'s straight
//! walk; if the walk fails, the span is repaired from the best settled linked neighbour `k`
//! (`g(k) + |k − n|`, anchor `k`). Following anchors from any span therefore gives a
//! string-pulled polyline to the goal whose length is the field's distance.
//!
//! With `clearance_weight > 1` the field uses MINOS's weighting instead: a plain 8-connected
//! Dijkstra in which entering a span whose clearance is below `agent_radius +
//! clearance_margin` costs the step length times the weight (in the direction of propagation,
//! away from the goals). Those values are weighted costs, not metres, and paths follow the
//! grid; that mode is not an exact geodesic. The default weight 1 keeps the exact mode.
//!
//! The search state is one 16-byte record per span (height, distance, anchor, mark) so that
//! relaxing a neighbour touches one cache line; neighbours are found from the line-of-sight
//! index's packed copy of the spans (same-layer links from column offsets). Marks carry a
//! generation number, so a search clears nothing: a [`Geodesic`] keeps its records in a small
//! pool (one per concurrent query) and a search costs only what it visits. The queue is a
//! binary heap of `(key bits, span)` words: spans pop by key and then by index, and repairs
//! prefer the lower span index on ties, so results depend on nothing but the grid and the
//! goals (not on their order, nor on which pooled records a query used).
//!
//! A field from a single goal starts with a flood: breadth first over links from the goal,
//! every span the goal sees by a straight walk is settled at once with the straight-line
//! distance and the goal as anchor (no path is shorter), without the queue and with the
//! records of spans about to be expanded loaded ahead; the spans the flood reaches but the
//! goal does not see are repaired from their best settled neighbour and queued, and Lazy
//! Theta* settles the rest. On open floor the whole field is the flood. Around the goal the
//! flood does not walk to each span: per quadrant, the [`SightIndex`]'s clear squares (tiled
//! beyond their 255-cell cap) give a square of floor in which every walk from the goal
//! succeeds as long as the heights stay within half the profile tolerance, so its rows are
//! settled in memory order while they do, and only the spans whose links may leave that
//! rectangle (its edges; inside, links to other layers) are expanded by the breadth-first
//! flood. The set settled and the values are the same as walking to each span.
//!
//! [`Geodesic::search`] is the same propagation from one goal as an A* towards one start
//! (admissible straight-line heuristic, no flood), stopping once the start is settled.
//!
//! # Point-to-point paths: a sparse graph
//!
//! Shortest paths between two spans (`path` module) search a much smaller graph, built once
//! per [`Geodesic`] on the first such query (its edges and landmark distances, the costly
//! part, are taken from the grid's `.nav` file when stored there and they fit the vertices;
//! so are its labels, the plateaus, zones, vertices and portals, when they fit the grid: see
//! `file`, [`Geodesic::sparse_edges`] and [`Geodesic::sparse_labels`]):
//!
//! - *Plateaus* are spans joined by links with height steps of at most 5 mm, at least 256
//!   spans within 5 cm of height; walkable spans on no plateau form uneven *zones* (stairs,
//!   ramps, steps). On a plateau a straight walk's height profile never fails, so shortest
//!   paths bend only around obstacles.
//! - *Vertices* are the spans that touch an obstacle corner diagonally (the diagonal link is
//!   missing while both axis links beside it exist) and the *gates*, plateau spans linked to
//!   a zone (paths bend there where the floor's slope changes).
//! - An *edge* joins two vertices of one island when the straight walk between them exists
//!   and a shortest path could bend at both ends: around a corner, only towards the two
//!   quadrants beside the obstacle's. Zones are crossed by the edges between their gates.
//!
//! A query is an A* over this graph from the start to the goal (a straight walk between them
//! answers at once). The start is joined to every vertex that could bend towards it, lazily:
//! the straight walk is checked when the entry pops. The goal is joined to the vertices that
//! could bend towards it and see it; those needed for the landmark bound below (nearest
//! first, skipping any that cannot lower a landmark's distance) are checked up front, the
//! others when their entry pops. The spans of the zones holding the start or the goal are
//! nodes too, joined by their links (with Theta*'s shortcut to the parent, checked lazily),
//! as bends inside a zone are not all at vertices. The heuristic is the largest of the
//! straight-line distance, a bound through the portals between regions and zones (reaching
//! the goal's region means entering it by one of its portals; leaving a region, leaving by
//! one of its own), and eight landmarks: graph distances to landmarks chosen farthest-first,
//! of which only the bound `d(landmark, goal) − d(landmark, vertex)` is used (the other
//! direction could be undercut by a shortcut through the goal). When the goal lies in a zone,
//! `d(landmark, goal)` is bounded through the zone's portals instead (every path into the
//! zone passes one of their gates: the nearest gate's landmark distance plus the distance
//! from the portal's box to the goal, less one cell for a walk that crosses a gate's cell off
//! its centre); vertices inside the zones of the ends get no landmark bound (a path from
//! there may stay in the zone, bending where the graph cannot). Spans of the start's zone,
//! when the goal lies outside it, are bounded through the zone's exit portals: the distance
//! to a portal's box plus the landmark bound of its farthest gate. A node keeps one pending
//! lazy entry per parent, and none longer than its best checked entry (duplicates only cost
//! pops and failing walks again). When the graph does not join the pair (or has more than 4096 vertices, or the
//! start or goal lies in a zone of more than 20,000 spans), the query falls back to
//! [`Geodesic::search`]; so does the weighted mode.
//!
//! # Costs
//!
//! Measured on the 2-core build box with `cargo bench --bench navigation` (one core, best of
//! 2–3 runs on a shared, noisy box): a full field over the open 50 × 50 m floor (992k
//! walkable spans, [`distance_field`] including [`Geodesic::new`]) about 30 ms, of which
//! building the [`SightIndex`] takes about 22 ms (a grid read from its `.nav` file carries the
//! index's clear squares, which halves `Geodesic::new` on the episode bench's houses), the
//! flood about 5 ms and the search records and the exported field the rest; on the largest generated house (145k walkable
//! spans, two levels) about 19 ms; point-to-point paths there about 0.13 ms per
//! query with a shared [`Geodesic`] (building the sparse graph on the first query: about
//! 7 ms), and 0.016 ms on a furnished 100 m² level (about 2 ms to build). Accuracy: fields
//! within 0.6 % of exact shortest paths on the tests' corridors and doorways (the anchors are
//! cell centres, so a path passes about half a cell off each corner it turns); sparse paths
//! as short as the cell-level search's within 0.4 % on 3600 random pairs of 12 generated
//! houses (shorter as often as not).
//!
//! Where this module's job ends: it produces fields and anchor chains; turning them into
//! paths with rooms and doors is `path`.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::{Mutex, OnceLock, PoisonError};

use glam::Vec3;

use super::grid::{
    NavGrid, Span, SparseEdges, SparseLabels, DIRS, NONE, SPARSE_GATE, SPARSE_LANDMARKS,
};
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

    /// Number of queued entries.
    fn len(&self) -> usize {
        self.heap.len()
    }
}

/// Reusable state of one search: the per-span records and the queue.
#[derive(Debug)]
struct Scratch {
    nodes: Vec<State>,
    /// Open mark of the current search (its closed mark is `open + 1`).
    open: u32,
    queue: Queue,
    /// Queue of the sparse point-to-point search.
    entries: BinaryHeap<Entry>,
    /// Per sparse vertex: the open mark of the search in which it was found to see the goal,
    /// or that mark plus one when it was found not to.
    sees: Vec<u32>,
    /// Candidate vertices of the goal, by distance.
    near: Vec<(u32, u32)>,
    /// Breadth-first queue of the flood from a single goal.
    fifo: Vec<u32>,
    /// Per sparse vertex: (open mark of the search, its heuristic).
    hcache: Vec<(u32, f32)>,
}

impl Scratch {
    /// Starts a new search: new marks (older marks read as "not reached"), empty queue.
    fn begin(&mut self) {
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

/// Height step (m) between linked spans of one plateau.
const PLATEAU_STEP: f32 = 0.005;
/// Largest height range (m) of a plateau.
const PLATEAU_RANGE: f32 = 0.05;
/// Smallest plateau (spans); smaller ones belong to uneven zones.
const PLATEAU_MIN: u32 = 256;
/// Most vertices (corners and gates) the sparse graph is built for; beyond, point-to-point
/// queries use the cell-level search.
const SPARSE_MAX_VERTICES: usize = 4096;
/// Largest zone whose spans a point-to-point query takes as nodes; beyond, the query uses the
/// cell-level search.
const ZONE_NODES_MAX: u32 = 20_000;
/// Landmarks of the sparse graph's A* heuristic.
const LANDMARKS: usize = SPARSE_LANDMARKS;
/// Role of a span that is not a node of the sparse graph.
const PLAIN: u32 = NONE;
/// Role of a span of an uneven zone.
const ZONE: u32 = NONE - 1;

/// Where a region meets a zone: a path between different regions and zones passes here.
#[derive(Debug, Clone, Copy)]
struct Portal {
    /// [`Sparse::area`] value of the zone.
    zone: u32,
    /// [`Sparse::area`] value of the region.
    region: u32,
    lo: Vec3,
    hi: Vec3,
    /// Per landmark: the smallest and the largest graph distance from the landmark to the
    /// portal's gates (`INFINITY` when a gate is not joined to it).
    near: [f32; LANDMARKS],
    far: [f32; LANDMARKS],
}

/// Flag of [`Sparse::area`] values that name a zone.
const IN_ZONE: u32 = 1 << 31;

/// A vertex of the sparse graph: a corner or a gate.
#[derive(Debug, Clone, Copy)]
struct Vertex {
    span: u32,
    /// Cell.
    xz: (i64, i64),
    /// Position.
    pos: Vec3,
    /// Bit `k`: the diagonal `DIRS[4 + k]` is blocked while both axis links beside it exist,
    /// i.e. the corner of an obstacle touches the span there.
    corners: u8,
    /// Linked to a span of an uneven zone: paths may bend here for the floor's shape, not
    /// around an obstacle.
    gate: bool,
}

impl Vertex {
    /// Can a shortest path bend at this vertex coming from (or going to) cell `p`? Around a
    /// corner it can only when `p` lies in one of the two quadrants beside the obstacle's.
    #[inline]
    fn allows(&self, p: (i64, i64)) -> bool {
        if self.gate {
            return true;
        }
        let (ux, uz) = (p.0 - self.xz.0, p.1 - self.xz.1);
        let mut bits = self.corners;
        while bits != 0 {
            let k = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let (dx, dz) = DIRS[4 + k];
            let (ax, az) = (ux * i64::from(dx), uz * i64::from(dz));
            if (ax >= 0 && az <= 0) || (ax <= 0 && az >= 0) {
                return true;
            }
        }
        false
    }
}

/// The graph point-to-point queries search: corners of obstacles and gates of uneven zones
/// joined by straight walks, and the spans of uneven zones joined by their links.
#[derive(Debug, Clone)]
struct Sparse {
    /// Which spans are vertices, regions, zones and portals.
    labels: Labels,
    /// Edges of vertex `i`: `edges[first[i]..first[i + 1]]`, as (vertex, length).
    first: Vec<u32>,
    edges: Vec<(u32, f32)>,
    /// Per vertex: graph distances to the landmarks (`INFINITY` when not joined).
    marks: Vec<[f32; LANDMARKS]>,
}

/// The linear part of the sparse graph (see [`Sparse`]), computed from the grid or taken
/// from its stored [`SparseLabels`].
#[derive(Debug, Clone)]
struct Labels {
    /// Per span: index into `verts`, [`ZONE`] or [`PLAIN`].
    role: Vec<u32>,
    /// Per walkable span: its region (plateau spans joined by links; zones cut regions
    /// apart), or [`IN_ZONE`] plus its zone; `NONE` when not walkable.
    area: Vec<u32>,
    /// Number of spans of each zone.
    zone_spans: Vec<u32>,
    /// Portals: per (zone, region) next to each other, the zone, the region and the
    /// bounding box (min, max) of the region's spans linked to the zone.
    portals: Vec<Portal>,
    /// (portal, gate span) for every gate of every portal.
    portal_gates: Vec<(u32, u32)>,
    verts: Vec<Vertex>,
}

/// An entry of the sparse search's queue: reach `node` from `parent` with distance `g`;
/// `lazy` when the straight walk from `parent` is still to be checked. Pops by key, then
/// node, then parent, checked entries first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Entry {
    /// `(f32 bits of g + heuristic) << 32 | node`.
    key: u64,
    parent: u32,
    g: u32,
    lazy: bool,
}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        // Reversed: `BinaryHeap` is a max-heap.
        (other.key, other.parent, other.lazy).cmp(&(self.key, self.parent, self.lazy))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

/// Everything repeated geodesic queries on one grid need, computed once: the line-of-sight
/// index, the per-span search records (kept in a small pool, one per concurrent query), and
/// the sparse graph of point-to-point queries (built by the first). Shared between threads,
/// it gives every query the same answer whichever records it used.
pub struct Geodesic<'g> {
    sight: SightIndex<'g>,
    frame: Frame,
    /// Column index offset of one step in each direction.
    offsets: [i64; 8],
    pool: Mutex<Vec<Scratch>>,
    /// The sparse graph of point-to-point queries, built on first use (`None` when the grid
    /// has too many vertices for it).
    sparse: OnceLock<Option<Sparse>>,
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
            sparse: self.sparse.clone(),
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
            sparse: OnceLock::new(),
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

    /// Fresh search records: heights copied, every span unreached.
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
            entries: BinaryHeap::new(),
            sees: Vec::new(),
            near: Vec::new(),
            fifo: Vec::new(),
            hcache: Vec::new(),
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

    /// The linked spans of `span`, whose [`Here`] is known.
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

    /// The linked spans of a span (a valid index), without working out its cell.
    #[inline(always)]
    fn links_of(&self, span: u32) -> Links<'_> {
        let grid = self.grid();
        let (column, _) = self.sight.column_height(span);
        let (same, linked) = self.sight.link_masks(span);
        let first = grid
            .column_start
            .get(column as usize)
            .copied()
            .unwrap_or(span);
        Links {
            start: &grid.column_start,
            offsets: &self.offsets,
            spans: &grid.spans,
            span,
            column: i64::from(column),
            rank: span.wrapping_sub(first),
            same,
            other: linked & !same,
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

    /// The anchor chain of the shortest path from `start` to `goal` (`start` first) as
    /// point-to-point queries find it: the sparse search where the graph exists and connects
    /// the pair, the cell-level search otherwise (and always in the weighted mode).
    pub(crate) fn path_chain(&self, start: u32, goal: u32) -> Option<Vec<u32>> {
        let grid = self.grid();
        let valid = |s: u32| grid.spans.get(s as usize).is_some_and(|s| s.walkable);
        if !valid(start) || !valid(goal) {
            return None;
        }
        if self.exact() {
            if let Some(sparse) = self.sparse() {
                if let Some(chain) = self.sparse_chain(sparse, start, goal) {
                    return Some(chain);
                }
            }
        }
        self.search_chain(goal, start)
    }

    /// The sparse graph, built on first use.
    fn sparse(&self) -> Option<&Sparse> {
        self.sparse.get_or_init(|| self.build_sparse()).as_ref()
    }

    /// Builds the sparse graph: plateaus (spans joined by links with a height step of at most
    /// [`PLATEAU_STEP`]; at least [`PLATEAU_MIN`] spans within [`PLATEAU_RANGE`]), the uneven
    /// zones (the linked spans of no plateau), regions and zones as areas with the portals
    /// between them, the vertices (spans touching an obstacle corner diagonally, and plateau
    /// spans linked to a zone), an edge between two vertices of one island whenever a
    /// shortest path could bend at both ends and the straight walk between them exists, and
    /// the landmark distances. `None` beyond [`SPARSE_MAX_VERTICES`] vertices.
    fn build_sparse(&self) -> Option<Sparse> {
        let n = self.grid().spans.len();
        let labels = match self.grid().baked.sparse_labels.as_ref() {
            Some(l) if l.fits(n) => self.stored_labels(l),
            _ => self.label_spans(),
        }?;
        let spans = &self.grid().spans;
        let verts = &labels.verts;
        // The edges and landmarks stored with the grid, when they fit these vertices.
        if let Some(g) = self.grid().baked.sparse_edges.as_ref() {
            if g.fits(verts.len()) {
                let (first, edges, marks) = (g.first.clone(), g.edges.clone(), g.marks.clone());
                return Some(finish_sparse(labels, (first, edges, marks)));
            }
        }
        let mut lists: Vec<Vec<(u32, f32)>> = vec![Vec::new(); verts.len()];
        for (i, u) in verts.iter().enumerate() {
            let island = spans[u.span as usize].island;
            for (j, v) in verts.iter().enumerate().skip(i + 1) {
                if spans[v.span as usize].island != island || !u.allows(v.xz) || !v.allows(u.xz) {
                    continue;
                }
                if self.sight.straight_line(u.span, v.span) {
                    let len = dist(u.pos, v.pos);
                    lists[i].push((j as u32, len));
                    lists[j].push((i as u32, len));
                }
            }
        }
        let mut first = Vec::with_capacity(verts.len() + 1);
        let mut edges = Vec::new();
        for list in &lists {
            first.push(edges.len() as u32);
            edges.extend_from_slice(list);
        }
        first.push(edges.len() as u32);
        let marks = landmarks(&first, &edges);
        Some(finish_sparse(labels, (first, edges, marks)))
    }

    /// Bits of [`Vertex::corners`] for a span: the diagonals blocked while both axis links
    /// beside them exist.
    fn corners(&self, s: u32) -> u8 {
        let mask = self.sight.link_masks(s).1;
        let mut corners = 0u8;
        for (k, (ax, az)) in [(0, 1), (2, 1), (2, 3), (0, 3)].into_iter().enumerate() {
            // DIRS[4 + k] is the diagonal between the axis directions ax and az.
            if mask & (1 << ax) != 0 && mask & (1 << az) != 0 && mask & (16 << k) == 0 {
                corners |= 1 << k;
            }
        }
        corners
    }

    /// The linear part of the sparse graph from the grid's stored labels (checked by the
    /// caller with [`SparseLabels::fits`]): roles and zone sizes from the areas, vertex cells
    /// and corners from the grid, portal boxes from their gates' positions. `None` beyond
    /// [`SPARSE_MAX_VERTICES`] vertices.
    fn stored_labels(&self, l: &SparseLabels) -> Option<Labels> {
        if l.verts.len() > SPARSE_MAX_VERTICES {
            return None;
        }
        let mut zone_spans: Vec<u32> = Vec::new();
        let mut role = Vec::with_capacity(l.area.len());
        for &a in &l.area {
            if a != NONE && a & IN_ZONE != 0 {
                // Below the span count (checked).
                let z = (a & !IN_ZONE) as usize;
                if z >= zone_spans.len() {
                    zone_spans.resize(z + 1, 0);
                }
                zone_spans[z] += 1;
                role.push(ZONE);
            } else {
                role.push(PLAIN);
            }
        }
        let verts: Vec<Vertex> = l
            .verts
            .iter()
            .map(|&v| {
                let s = v & !SPARSE_GATE;
                Vertex {
                    span: s,
                    xz: self.cell_xz(s),
                    pos: self.position(s).unwrap_or(Vec3::ZERO),
                    corners: self.corners(s),
                    gate: v & SPARSE_GATE != 0,
                }
            })
            .collect();
        for (i, v) in verts.iter().enumerate() {
            if let Some(r) = role.get_mut(v.span as usize) {
                *r = i as u32;
            }
        }
        let mut portals: Vec<Portal> = l
            .portals
            .iter()
            .map(|&(zone, region)| Portal {
                zone,
                region,
                lo: Vec3::INFINITY,
                hi: Vec3::NEG_INFINITY,
                near: [f32::INFINITY; LANDMARKS],
                far: [0.0; LANDMARKS],
            })
            .collect();
        for &(k, s) in &l.portal_gates {
            let p = self.position(s).unwrap_or(Vec3::ZERO);
            if let Some(q) = portals.get_mut(k as usize) {
                q.lo = q.lo.min(p);
                q.hi = q.hi.max(p);
            }
        }
        Some(Labels {
            role,
            area: l.area.clone(),
            zone_spans,
            portals,
            portal_gates: l.portal_gates.clone(),
            verts,
        })
    }

    /// The linear part of the sparse graph: plateaus, zones, areas, gates and portals, and
    /// the vertices (see [`Geodesic::build_sparse`]). `None` beyond [`SPARSE_MAX_VERTICES`]
    /// vertices.
    fn label_spans(&self) -> Option<Labels> {
        let spans = &self.grid().spans;
        let n = spans.len();
        let sight = &self.sight;
        // Reads only the packed spans: links from masks and column offsets, heights. Spans
        // without links (the builder links walkable spans only) are on no plateau and in no
        // zone.
        let linked = |s: u32| sight.link_masks(s).1 != 0;
        let height = |s: u32| sight.column_height(s).1;
        // Plateau components by a depth-first flood over links with small steps, noting the
        // links between components (seen from the side labelled last) and the spans that
        // have such links (the only ones that can be gates).
        let mut comp = vec![NONE; n];
        let mut stats: Vec<(u32, f32, f32)> = Vec::new();
        let mut between: Vec<(u32, u32)> = Vec::new();
        let mut edge_spans: Vec<u32> = Vec::new();
        let mut stack = Vec::new();
        for seed in 0..n as u32 {
            if comp[seed as usize] != NONE || !linked(seed) {
                continue;
            }
            let id = stats.len() as u32;
            comp[seed as usize] = id;
            stack.push(seed);
            let (mut size, mut lo, mut hi) = (0u32, height(seed), height(seed));
            while let Some(s) = stack.pop() {
                let y = height(s);
                size += 1;
                lo = lo.min(y);
                hi = hi.max(y);
                let mut edge = false;
                for (l, _) in self.links_of(s) {
                    let c = comp[l as usize];
                    if (height(l) - y).abs() <= PLATEAU_STEP {
                        if c == NONE {
                            comp[l as usize] = id;
                            stack.push(l);
                        }
                    } else {
                        edge = true;
                        if c != NONE && c != id {
                            between.push((c, id));
                        }
                    }
                }
                if edge {
                    edge_spans.push(s);
                }
            }
            stats.push((size, lo, hi));
        }
        let is_zone: Vec<bool> = stats
            .iter()
            .map(|&(size, lo, hi)| !(size >= PLATEAU_MIN && hi - lo <= PLATEAU_RANGE))
            .collect();
        let zone_span = |s: u32| comp[s as usize] != NONE && is_zone[comp[s as usize] as usize];
        // Regions join linked plateaus, zones join linked zone components; numbered in the
        // order of their first span.
        let mut parts = Forest::new(stats.len());
        for &(a, b) in &between {
            if is_zone[a as usize] == is_zone[b as usize] {
                parts.union(a, b);
            }
        }
        let mut part_area = vec![NONE; stats.len()];
        let (mut regions, mut zones) = (0u32, 0u32);
        for c in 0..stats.len() as u32 {
            let r = parts.find(c) as usize;
            if part_area[r] == NONE {
                part_area[r] = if is_zone[c as usize] {
                    zones += 1;
                    IN_ZONE | (zones - 1)
                } else {
                    regions += 1;
                    regions - 1
                };
            }
            part_area[c as usize] = part_area[r];
        }
        let area: Vec<u32> = comp
            .iter()
            .map(|&c| {
                if c == NONE {
                    NONE
                } else {
                    part_area[c as usize]
                }
            })
            .collect();
        let mut zone_spans = vec![0u32; zones as usize];
        for &a in &area {
            if a != NONE && a & IN_ZONE != 0 {
                zone_spans[(a & !IN_ZONE) as usize] += 1;
            }
        }
        let mut role: Vec<u32> = (0..n as u32)
            .map(|s| if zone_span(s) { ZONE } else { PLAIN })
            .collect();
        // Gates (plateau spans linked to a zone) and the portals they form.
        let mut gates: Vec<u32> = Vec::new();
        let mut portals: Vec<Portal> = Vec::new();
        let mut portal_of = std::collections::BTreeMap::new();
        let mut portal_gates: Vec<(u32, u32)> = Vec::new();
        for &s in &edge_spans {
            if zone_span(s) {
                continue;
            }
            let mut gate = false;
            for (l, _) in self.links_of(s) {
                if !zone_span(l) {
                    continue;
                }
                gate = true;
                let (zone, region) = (area[l as usize], area[s as usize]);
                let p = self.position(s).unwrap_or(Vec3::ZERO);
                let k = *portal_of.entry((zone, region)).or_insert_with(|| {
                    portals.push(Portal {
                        zone,
                        region,
                        lo: p,
                        hi: p,
                        near: [f32::INFINITY; LANDMARKS],
                        far: [0.0; LANDMARKS],
                    });
                    portals.len() - 1
                });
                portals[k].lo = portals[k].lo.min(p);
                portals[k].hi = portals[k].hi.max(p);
                portal_gates.push((k as u32, s));
            }
            if gate {
                gates.push(s);
            }
        }
        gates.sort_unstable();
        // Vertices: corners (from the link masks) and gates, in span order.
        let mut corner_spans: Vec<(u32, u8, bool)> = Vec::new();
        let mut next_gate = gates.iter().peekable();
        for s in 0..n as u32 {
            let corners = self.corners(s);
            let gate = next_gate.next_if(|&&g| g == s).is_some();
            if gate || corners != 0 {
                corner_spans.push((s, corners, gate));
            }
        }
        if corner_spans.len() > SPARSE_MAX_VERTICES {
            return None;
        }
        corner_spans.sort_unstable_by_key(|v| v.0);
        let verts: Vec<Vertex> = corner_spans
            .iter()
            .map(|&(s, corners, gate)| Vertex {
                span: s,
                xz: self.cell_xz(s),
                pos: self.position(s).unwrap_or(Vec3::ZERO),
                corners,
                gate,
            })
            .collect();
        for (i, v) in verts.iter().enumerate() {
            role[v.span as usize] = i as u32;
        }
        Some(Labels {
            role,
            area,
            zone_spans,
            portals,
            portal_gates,
            verts,
        })
    }

    /// The edges and landmark distances of the sparse graph (built on first use), as a
    /// `.nav` file stores them; `None` when the grid has too many vertices for the graph.
    pub fn sparse_edges(&self) -> Option<SparseEdges> {
        self.sparse().map(|sp| SparseEdges {
            first: sp.first.clone(),
            edges: sp.edges.clone(),
            marks: sp.marks.clone(),
        })
    }

    /// The linear part of the sparse graph (built on first use), as a `.nav` file stores it;
    /// `None` when the grid has too many vertices for the graph.
    pub fn sparse_labels(&self) -> Option<SparseLabels> {
        self.sparse().map(|sp| SparseLabels {
            area: sp.labels.area.clone(),
            verts: sp
                .labels
                .verts
                .iter()
                .map(|v| v.span | if v.gate { SPARSE_GATE } else { 0 })
                .collect(),
            portals: sp
                .labels
                .portals
                .iter()
                .map(|q| (q.zone, q.region))
                .collect(),
            portal_gates: sp.labels.portal_gates.clone(),
        })
    }

    /// A* from `start` to `goal` over the sparse graph (see the module documentation);
    /// `None` when the graph does not join them.
    fn sparse_chain(&self, sp: &Sparse, start: u32, goal: u32) -> Option<Vec<u32>> {
        if start == goal {
            return Some(vec![start]);
        }
        if self.sight.straight_line(start, goal) {
            return Some(vec![start, goal]);
        }
        let spans = &self.grid().spans;
        let island = spans[start as usize].island;
        let vertex = |s: u32| sp.labels.verts.get(sp.labels.role[s as usize] as usize);
        let pos = |s: u32| match vertex(s) {
            Some(v) => v.pos,
            None => self.position(s).unwrap_or(Vec3::ZERO),
        };
        let (ps, pt) = (pos(start), pos(goal));
        let (cs, ct) = (self.cell_xz(start), self.cell_xz(goal));
        // The spans of the zones that hold the start or the goal are nodes too, joined by
        // their links to each other and to the gates around them.
        let zone_of =
            |s: u32| Some(sp.labels.area[s as usize]).filter(|&a| a != NONE && a & IN_ZONE != 0);
        let (zs, zg) = (zone_of(start), zone_of(goal));
        let zones = zs.is_some() || zg.is_some();
        // A zone that is most of the grid (a sloped or noisy floor): the cell-level search
        // does better.
        let big = |z: Option<u32>| {
            z.and_then(|z| sp.labels.zone_spans.get((z & !IN_ZONE) as usize))
                .is_some_and(|&size| size > ZONE_NODES_MAX)
        };
        if big(zs) || big(zg) {
            return None;
        }
        let active = |s: u32| zones && zone_of(s).is_some_and(|a| Some(a) == zs || Some(a) == zg);
        let is_node = |s: u32| active(s) || vertex(s).is_some_and(|v| v.gate);
        let portal_bound = self.portal_bound(sp, goal, pt);
        let slack = self.frame.size;
        self.with_scratch(|sc| {
            sc.begin();
            let (open, closed) = (sc.open, sc.open + 1);
            // Landmark distances to the goal. Outside a zone: through the vertices that see
            // it and could bend towards it (nearest first, skipping those that cannot lower
            // any). In a zone: a lower bound through the zone's portals (a path into the
            // zone passes one of their gates; one cell of slack for a straight walk that
            // crosses a gate's cell off its centre).
            let (seen, blocked) = (open, open + 1);
            sc.sees.resize(sp.labels.verts.len(), 0);
            sc.near.clear();
            let mut to_goal = [f32::INFINITY; LANDMARKS];
            if let Some(zg) = zg {
                for q in sp.labels.portals.iter().filter(|q| q.zone == zg) {
                    let d = (box_distance(q.lo, q.hi, pt) - slack).max(0.0);
                    for (t, m) in to_goal.iter_mut().zip(&q.near) {
                        *t = t.min(m + d);
                    }
                }
            } else {
                for (i, v) in sp.labels.verts.iter().enumerate() {
                    if v.span != goal && spans[v.span as usize].island == island && v.allows(ct) {
                        sc.near.push((dist(v.pos, pt).to_bits(), i as u32));
                    }
                }
            }
            sc.near.sort_unstable();
            for &(d, i) in &sc.near {
                let d = f32::from_bits(d);
                let marks = &sp.marks[i as usize];
                if !marks.iter().zip(&to_goal).any(|(m, t)| m + d < *t) {
                    continue;
                }
                // Walks start at the goal: those that fail mostly fail near it, in cache.
                if self
                    .sight
                    .straight_line(goal, sp.labels.verts[i as usize].span)
                {
                    sc.sees[i as usize] = seen;
                    for (t, m) in to_goal.iter_mut().zip(marks) {
                        *t = t.min(m + d);
                    }
                } else {
                    sc.sees[i as usize] = blocked;
                }
            }
            // A path from a span of the start's zone to a goal outside it leaves by one of
            // the zone's portals: per portal, the box and a lower bound on the distance from
            // its gates to the goal.
            let exits: Vec<(Vec3, Vec3, f32)> = match zs {
                Some(z) if zs != zg => sp
                    .labels
                    .portals
                    .iter()
                    .filter(|q| q.zone == z)
                    .map(|q| {
                        let rest = q
                            .far
                            .iter()
                            .zip(&to_goal)
                            .map(|(f, t)| t - f)
                            .filter(|d| d.is_finite())
                            .fold(0.0f32, f32::max);
                        (q.lo, q.hi, rest)
                    })
                    .collect(),
                _ => Vec::new(),
            };
            let h = |s: u32, p: Vec3| {
                let mut best = portal_bound(s, p);
                // Not for corners inside the zones of the ends: from there a path may stay in
                // the zone, bending where the graph cannot.
                if let Some(m) = sp
                    .marks
                    .get(sp.labels.role[s as usize] as usize)
                    .filter(|_| !active(s))
                {
                    for (a, b) in m.iter().zip(&to_goal) {
                        let d = b - a;
                        if d.is_finite() {
                            best = best.max(d);
                        }
                    }
                } else if !exits.is_empty() && zs.is_some() && zone_of(s) == zs {
                    let via = exits
                        .iter()
                        .map(|&(lo, hi, rest)| (box_distance(lo, hi, p) - slack).max(0.0) + rest)
                        .fold(f32::INFINITY, f32::min);
                    best = best.max(via);
                }
                best
            };
            // Straight walks to the goal from vertices the landmark bound has not counted
            // would undercut it (from zone spans they cross a gate's cell; into the goal's
            // zone, a portal).
            let may_see_goal =
                |s: u32| zg.is_some() || active(s) || vertex(s).is_some_and(|v| v.allows(ct));
            // The heuristic of a vertex, once per search.
            sc.hcache.resize(sp.labels.verts.len(), (0, 0.0));
            let hcache = std::cell::Cell::from_mut(&mut sc.hcache[..]).as_slice_of_cells();
            let h_of = |s: u32| match hcache.get(sp.labels.role[s as usize] as usize) {
                Some(c) if c.get().0 == open => c.get().1,
                Some(c) => {
                    let v = h(s, pos(s));
                    c.set((open, v));
                    v
                }
                None => h(s, pos(s)),
            };
            let sees = &sc.sees;
            let nodes = &mut sc.nodes[..];
            let entries = &mut sc.entries;
            let push = |entries: &mut BinaryHeap<Entry>, node: u32, parent: u32, g: f32, lazy| {
                let f = g + h_of(node);
                entries.push(Entry {
                    key: (u64::from(f.to_bits()) << 32) | u64::from(node),
                    parent,
                    g: g.to_bits(),
                    lazy,
                });
            };
            let mut next = Some((start, start, 0.0f32));
            loop {
                let (n, parent, gn) = match next.take() {
                    Some(x) => x,
                    None => {
                        let e = entries.pop()?;

                        let m = (e.key & 0xffff_ffff) as u32;
                        if nodes[m as usize].mark == closed
                            || (e.lazy && !self.sight.straight_line(e.parent, m))
                        {
                            continue;
                        }
                        (m, e.parent, f32::from_bits(e.g))
                    }
                };
                let slot = &mut nodes[n as usize];
                slot.g = gn;
                slot.anchor = parent;
                slot.mark = closed;
                if n == goal {
                    let mut chain = vec![goal];
                    let mut s = goal;
                    while s != start {
                        s = nodes[s as usize].anchor;
                        if chain.len() > nodes.len() {
                            return None;
                        }
                        chain.push(s);
                    }
                    chain.reverse();
                    return Some(chain);
                }
                let pn = pos(n);
                let (pa, ga) = (pos(parent), nodes[parent as usize].g);
                // Theta*: past a gate or a zone span, a neighbour may see the parent too
                // (checked lazily); past a corner, the corner's obstacle is in the way.
                let theta = parent != n && vertex(n).is_none_or(|v| v.gate);
                let mut relax = |entries: &mut BinaryHeap<Entry>, m: u32, g: f32| {
                    let node = &mut nodes[m as usize];
                    if node.mark == closed {
                        return;
                    }
                    if node.mark != open {
                        node.mark = open;
                        node.g = f32::INFINITY;
                        node.anchor = NONE;
                    }
                    // While a node is open, `g` is its best checked distance and `anchor`
                    // the parent of its last lazy entry: the same lazy entry again, or one
                    // longer than a checked entry (which pops first and closes the node),
                    // would only cost a straight walk or a pop.
                    if theta && node.anchor != parent && (m != goal || may_see_goal(parent)) {
                        let lazy = ga + dist(pa, pos(m));
                        if lazy <= node.g {
                            node.anchor = parent;
                            push(entries, m, parent, lazy, true);
                        }
                    }
                    if g >= node.g {
                        return;
                    }
                    node.g = g;
                    push(entries, m, n, g, false);
                };
                if n == start {
                    // Lazy edges to every vertex that could bend towards the start.
                    for v in &sp.labels.verts {
                        if v.span != start
                            && spans[v.span as usize].island == island
                            && v.allows(cs)
                        {
                            push(entries, v.span, start, dist(ps, v.pos), true);
                        }
                    }
                } else if let Some(&i) = sp.labels.role.get(n as usize) {
                    if let Some(v) = sp.labels.verts.get(i as usize) {
                        let known = sees[i as usize];
                        if known == seen {
                            relax(entries, goal, gn + dist(pn, pt));
                        } else if known != blocked && v.allows(ct) {
                            push(entries, goal, n, gn + dist(pn, pt), true);
                        }
                        let (a, b) = (sp.first[i as usize], sp.first[i as usize + 1]);
                        for &(j, len) in &sp.edges[a as usize..b as usize] {
                            relax(entries, sp.labels.verts[j as usize].span, gn + len);
                        }
                    }
                }
                if zones && (n == start || is_node(n)) {
                    for &l in &spans[n as usize].links {
                        if l != NONE && (l == goal || active(l) || (active(n) && is_node(l))) {
                            relax(entries, l, gn + dist(pn, pos(l)));
                        }
                    }
                }
            }
        })
    }

    /// The heuristic of the sparse search before landmarks: the straight-line distance to
    /// the goal, and outside the goal's region or zone a bound through the portals (a path
    /// into the goal's area enters by one of its portals, a path out of a region leaves by
    /// one of its own).
    fn portal_bound<'a>(
        &self,
        sp: &'a Sparse,
        goal: u32,
        pt: Vec3,
    ) -> impl Fn(u32, Vec3) -> f32 + 'a {
        let goal_area = sp.labels.area[goal as usize];
        let entry: Vec<(Vec3, Vec3, f32)> = sp
            .labels
            .portals
            .iter()
            .filter(|q| q.region == goal_area || q.zone == goal_area)
            .map(|q| (q.lo, q.hi, box_distance(q.lo, q.hi, pt)))
            .collect();
        let exits: Vec<(u32, Vec3, Vec3, f32)> = sp
            .labels
            .portals
            .iter()
            .map(|p| {
                let w = entry
                    .iter()
                    .map(|&(lo, hi, d)| box_gap(p.lo, p.hi, lo, hi) + d)
                    .fold(f32::INFINITY, f32::min);
                (p.region, p.lo, p.hi, w)
            })
            .filter(|e| e.3.is_finite())
            .collect();
        move |s: u32, p: Vec3| {
            let e = dist(p, pt);
            let a = sp.labels.area[s as usize];
            if a == goal_area {
                return e;
            }
            let via = if a & IN_ZONE != 0 {
                entry
                    .iter()
                    .map(|&(lo, hi, d)| box_distance(lo, hi, p) + d)
                    .fold(f32::INFINITY, f32::min)
            } else {
                exits
                    .iter()
                    .filter(|x| x.0 == a)
                    .map(|&(_, lo, hi, w)| box_distance(lo, hi, p) + w)
                    .fold(f32::INFINITY, f32::min)
            };
            if via.is_finite() {
                e.max(via)
            } else {
                e
            }
        }
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
    fn flood(&self, sc: &mut Scratch) {
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
                prefetch(nodes, ahead);
                sight.prefetch(ahead);
            }
            if let Some(&ahead) = fifo.get(head + 8) {
                let c = sight.column_height(ahead).0 as usize;
                prefetch(start, c.wrapping_sub(nx) as u32);
                prefetch(start, (c + nx) as u32);
            }
            if let Some(&ahead) = fifo.get(head + 4) {
                let c = sight.column_height(ahead).0 as usize;
                for cc in [c.wrapping_sub(nx), c + nx] {
                    if let Some(&t) = start.get(cc) {
                        prefetch(nodes, t);
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
    fn clear_side(&self, goal: u32, cg: (i64, i64), rank: u32, q: usize) -> i64 {
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
    fn settle_block(
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
        let limit = 0.5 * super::los::profile_tolerance(grid);
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
    fn weighted(&self, sc: &mut Scratch, target: Option<u32>) {
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

/// The sparse graph from its parts: the landmark distances of each portal's gates (a path
/// into or out of a zone passes one of them) are gathered here. `role` maps every gate to its
/// vertex and `marks` has one entry per vertex (checked by the caller).
#[allow(clippy::type_complexity)]
fn finish_sparse(
    labels: Labels,
    (first, edges, marks): (Vec<u32>, Vec<(u32, f32)>, Vec<[f32; LANDMARKS]>),
) -> Sparse {
    let mut labels = labels;
    let Labels {
        role,
        portals,
        portal_gates,
        ..
    } = &mut labels;
    for &(k, s) in portal_gates.iter() {
        let m = role
            .get(s as usize)
            .and_then(|&v| marks.get(v as usize))
            .copied()
            .unwrap_or([f32::INFINITY; LANDMARKS]);
        if let Some(portal) = portals.get_mut(k as usize) {
            for ((near, far), &d) in portal.near.iter_mut().zip(&mut portal.far).zip(&m) {
                *near = near.min(d);
                *far = far.max(d);
            }
        }
    }
    Sparse {
        labels,
        first,
        edges,
        marks,
    }
}

/// Graph distances from every vertex of a graph (edges of vertex `i` in
/// `edges[first[i]..first[i + 1]]`) to [`LANDMARKS`] landmarks in its largest connected
/// part, chosen farthest first: the first is the vertex farthest from the part's first
/// vertex, each next one the vertex farthest from those before.
fn landmarks(first: &[u32], edges: &[(u32, f32)]) -> Vec<[f32; LANDMARKS]> {
    let n = first.len().saturating_sub(1);
    let mut marks = vec![[f32::INFINITY; LANDMARKS]; n];
    if n == 0 {
        return marks;
    }
    let dijkstra = |from: usize, out: &mut Vec<f32>| {
        out.clear();
        out.resize(n, f32::INFINITY);
        out[from] = 0.0;
        let mut heap = BinaryHeap::new();
        heap.push(Reverse((0u32, from as u32)));
        while let Some(Reverse((d, v))) = heap.pop() {
            let d = f32::from_bits(d);
            if d > out[v as usize] {
                continue;
            }
            let (a, b) = (first[v as usize] as usize, first[v as usize + 1] as usize);
            for &(w, len) in &edges[a..b] {
                let c = d + len;
                if c < out[w as usize] {
                    out[w as usize] = c;
                    heap.push(Reverse((c.to_bits(), w)));
                }
            }
        }
    };
    // The largest connected part.
    let mut part = vec![u32::MAX; n];
    let (mut seed, mut best, mut stack) = (0, 0, Vec::new());
    for v in 0..n {
        if part[v] != u32::MAX {
            continue;
        }
        part[v] = v as u32;
        stack.push(v);
        let mut size = 0;
        while let Some(u) = stack.pop() {
            size += 1;
            let (a, b) = (first[u] as usize, first[u + 1] as usize);
            for &(w, _) in &edges[a..b] {
                if part[w as usize] == u32::MAX {
                    part[w as usize] = v as u32;
                    stack.push(w as usize);
                }
            }
        }
        if size > best {
            (seed, best) = (v, size);
        }
    }
    let mut dist = Vec::new();
    dijkstra(seed, &mut dist);
    // Distance of each vertex of the part to the nearest landmark so far (-1 outside).
    let mut near: Vec<f32> = dist
        .iter()
        .map(|&d| if d.is_finite() { d } else { -1.0 })
        .collect();
    for k in 0..LANDMARKS {
        let pick = (0..n)
            .max_by(|&a, &b| near[a].total_cmp(&near[b]).then(b.cmp(&a)))
            .unwrap_or(0);
        dijkstra(pick, &mut dist);
        for ((mark, near), &d) in marks.iter_mut().zip(&mut near).zip(&dist) {
            mark[k] = d;
            if *near >= 0.0 {
                *near = if k == 0 { d } else { near.min(d) };
            }
        }
    }
    marks
}

/// Disjoint sets over indices (the root of a set is its smallest member; path halving).
#[derive(Debug)]
struct Forest {
    parent: Vec<u32>,
}

impl Forest {
    fn new(n: usize) -> Self {
        Forest {
            parent: (0..n as u32).collect(),
        }
    }

    fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let up = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = up;
            x = up;
        }
        x
    }

    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra < rb {
            self.parent[rb as usize] = ra;
        } else if rb < ra {
            self.parent[ra as usize] = rb;
        }
    }
}

/// Distance from `p` to the box `[lo, hi]` (0 inside).
#[inline]
fn box_distance(lo: Vec3, hi: Vec3, p: Vec3) -> f32 {
    let d = (lo - p).max(p - hi).max(Vec3::ZERO);
    d.length()
}

/// Smallest distance between the boxes `[a0, a1]` and `[b0, b1]`.
#[inline]
fn box_gap(a0: Vec3, a1: Vec3, b0: Vec3, b1: Vec3) -> f32 {
    (b0 - a1).max(a0 - b1).max(Vec3::ZERO).length()
}

/// Signs `(sx, sz)` of the steps into quadrant `q` of the [`SightIndex`] (bit 0: towards -x,
/// bit 1: towards -z).
#[inline]
fn quadrant_signs(q: usize) -> (i64, i64) {
    (
        if q & 1 != 0 { -1 } else { 1 },
        if q & 2 != 0 { -1 } else { 1 },
    )
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

    /// A map cell (x, z).
    type Cell = (usize, usize);

    /// Each pair's geodesic is within 1 % of the exact shortest path and never shorter.
    fn assert_within_one_percent_of_exact(spec: &MapSpec, pairs: &[(Cell, Cell)]) {
        for &(a, b) in pairs {
            let (got, want) = compare_with_reference(spec, a, b);
            let err = rel(got, want);
            assert!(err < 0.01, "{a:?}->{b:?}: {got} vs exact {want} ({err})");
            assert!(
                f64::from(got) > want * 0.9999,
                "shorter than exact: {got} vs {want}"
            );
        }
    }

    #[test]
    fn l_shaped_corridor_matches_the_exact_shortest_path() {
        let pairs = [
            ((20, 10), (190, 175)),
            ((3, 5), (195, 196)),
            ((38, 30), (150, 162)),
        ];
        assert_within_one_percent_of_exact(&l_corridor(), &pairs);
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
        let pairs = [
            ((20, 20), (30, 120)),
            ((230, 10), (5, 135)),
            ((160, 30), (100, 100)),
        ];
        assert_within_one_percent_of_exact(&spec, &pairs);
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
    fn the_flood_settles_exactly_the_spans_the_goal_sees() {
        // A floor wider than the index's 255-cell squares (so the goal's clear square is
        // tiled), with walls, a gentle slope (the settled rectangles end where the heights
        // spread) and an upper floor over part of it (columns of two spans).
        let n = 300usize;
        let rows = rows_from(n, n, |x, z| {
            let wall = (x == 270 && z < 40) || (z == 275 && (150..220).contains(&x));
            x > 0 && z > 0 && x < n - 1 && z < n - 1 && !wall
        });
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        let mut spec = MapSpec::ascii(&refs, 0.05);
        for iz in 200..n - 1 {
            for ix in 1..n - 1 {
                if spec.ground(ix, iz) == '.' {
                    spec.set_height(ix, iz, 0.02 * (iz - 200) as f32);
                }
            }
        }
        for iz in 30..70 {
            for ix in 140..200 {
                spec.add(ix, iz, 2.5, '.');
            }
        }
        let grid = spec.build(NavParams::default());
        let geo = Geodesic::new(&grid);
        let sight = geo.sight();
        let upper = grid.column_start[50 * n + 150] + 1;
        assert!((grid.spans[upper as usize].y - 2.5).abs() < 1e-6);
        let corner = span_at(&grid, 3, 3);
        assert!(geo.clear_side(corner, (3, 3), 0, 0) > 254, "tiled square");
        for goal in [
            corner,
            span_at(&grid, 150, 120),
            span_at(&grid, 285, 290),
            span_at(&grid, 160, 45),
            upper,
        ] {
            let field = geo.field(&[goal]);
            // The flood's set: spans joined to the goal through spans it sees.
            let mut seen = vec![false; grid.spans.len()];
            seen[goal as usize] = true;
            let mut stack = vec![goal];
            while let Some(s) = stack.pop() {
                for &m in &grid.spans[s as usize].links {
                    if m != NONE && !seen[m as usize] && sight.straight_line(goal, m) {
                        seen[m as usize] = true;
                        stack.push(m);
                    }
                }
            }
            let pg = geo.position(goal).unwrap();
            let mut count = 0;
            for (s, &flooded) in seen.iter().enumerate() {
                let s = s as u32;
                if flooded {
                    let want = dist(pg, geo.position(s).unwrap());
                    assert_eq!(field.anchor[s as usize], goal, "span {s}");
                    assert_eq!(field.dist[s as usize].to_bits(), want.to_bits(), "span {s}");
                    count += 1;
                } else if field.anchor[s as usize] == goal {
                    assert!(sight.straight_line(goal, s), "span {s} anchored unseen");
                }
            }
            assert!(count > 1000, "goal {goal}: {count}");
        }
    }

    #[test]
    fn the_sparse_graph_joins_pairs_without_the_cell_level_fallback() {
        for grid in [
            l_corridor().build(NavParams::default()),
            stairs().build(NavParams::default()),
        ] {
            let geo = Geodesic::new(&grid);
            let sparse = geo.sparse().expect("few vertices");
            assert!(sparse.labels.verts.iter().any(|v| v.corners != 0));
            let spans = grid.walkable_spans(None);
            let mut rng = crate::seed::Rng::new(8);
            for _ in 0..100 {
                let (&a, &b) = (rng.pick(&spans).unwrap(), rng.pick(&spans).unwrap());
                let chain = geo.sparse_chain(sparse, a, b).expect("joined");
                assert_eq!((chain[0], chain[chain.len() - 1]), (a, b));
                for w in chain.windows(2) {
                    let linked = grid.spans[w[0] as usize].links.contains(&w[1]);
                    assert!(
                        linked || los::straight_line(&grid, w[0], w[1]),
                        "{a}->{b}: no straight walk {} -> {}",
                        w[0],
                        w[1]
                    );
                }
            }
        }
        let stairs = stairs().build(NavParams::default());
        let sparse = Geodesic::new(&stairs).sparse().cloned().unwrap();
        let ramp = sparse.labels.role.iter().filter(|&&r| r == ZONE).count();
        assert!(ramp >= 4 * 60, "the ramp is an uneven zone: {ramp} spans");
        assert!(sparse.labels.verts.iter().any(|v| v.gate));
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
