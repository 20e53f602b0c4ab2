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
//! rise). When a span is popped its anchor is verified with the `SightIndex`'s straight
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
//! flood does not walk to each span: per quadrant, the `SightIndex`'s clear squares (tiled
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
//! building the `SightIndex` takes about 22 ms (a grid read from its `.nav` file carries the
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
//!
//! # Files
//!
//! `mod.rs` holds [`Geodesic`] (the grid, its sight index, the pooled search records) and
//! [`DistanceField`]; `records.rs` the per-span search state, queue and link iteration;
//! `field.rs` distance fields (flood, Lazy Theta*, the weighted mode); `sparse/` the sparse
//! point-to-point graph (labels, portals, vertices, landmarks) and its search.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::{Mutex, OnceLock, PoisonError};

use glam::Vec3;

use super::grid::{
    NavGrid, Span, SparseEdges, SparseLabels, DIRS, NONE, SPARSE_GATE, SPARSE_LANDMARKS,
};
use super::los::SightIndex;

mod field;
mod nearest;
mod records;
mod sparse;

pub use field::distance_field;
pub use nearest::GoalRegions;
use records::*;
use sparse::*;

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
    /// Precomputes the `SightIndex` and the per-span search records (linear in the number
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

    internal! {
        /// The line-of-sight index.
        pub fn sight(&self) -> &SightIndex<'g> {
            &self.sight
        }
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

    pub(super) fn l_corridor() -> MapSpec {
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
