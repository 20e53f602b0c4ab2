//! Geodesic distance fields over the span grid: the walking distance from every span to the
//! nearest of a set of goal spans.
//!
//! Distances approximate the true shortest path through free space, not the octile metric of
//! an 8-connected grid search (which overestimates by up to 8 %). The propagation is Lazy
//! Theta*: each span keeps a distance `g` and an *anchor*, the span its path heads to in a
//! straight line. Relaxing neighbour `n` of a popped span `s` proposes `s`'s anchor, at cost
//! `g(anchor) + |anchor − n|` (3D distance between span positions, so stairs count their
//! rise). When a span is popped its anchor is verified with
//! [`SightIndex::straight_line`]; if the straight walk fails, the span is repaired from the
//! best settled linked neighbour `k` (`g(k) + |k − n|`, anchor `k`). Following anchors from
//! any span therefore gives a string-pulled polyline to the goal whose length is the field's
//! distance.
//!
//! With `clearance_weight > 1` the field uses MINOS's weighting instead: a plain 8-connected
//! Dijkstra in which entering a span whose clearance is below `agent_radius +
//! clearance_margin` costs the step length times the weight (in the direction of propagation,
//! away from the goals). Those values are weighted costs, not metres, and paths follow the
//! grid; that mode is not an exact geodesic. The default weight 1 keeps the exact mode.
//!
//! The priority queue orders by `f32::total_cmp` and then by span index, and repairs prefer
//! the lower span index on ties, so results depend on nothing but the grid and the goals (not
//! on their order).
//!
//! Cost: one line-of-sight walk per settled span, made cheap by the [`SightIndex`] (jumps
//! across open floor: about two jumps and two single steps per walk on a house-like grid),
//! neighbours enumerated from its packed copy of the spans, and the next span's record loaded
//! one iteration early. Measured on the 2-core build box, 1000 x 1000 cells of 5 cm with 100
//! rooms (935k walkable spans): [`Geodesic::new`] 40 ms, a full field about 195 ms, a
//! single-pair search across the whole grid about 28 ms. Accuracy against exact shortest
//! paths: within 0.6 % on the tests' corridors and doorways (the anchors are cell centres, so
//! a path passes about half a cell off each corner it turns).
//!
//! Where this module's job ends: it produces fields and single-pair searches; turning anchors
//! into paths with rooms and doors is `path`.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use glam::Vec3;

use super::grid::{NavGrid, NONE};
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

/// A heap entry: min-heap on `key` by `f32::total_cmp`, ties broken by the smaller span.
#[derive(Debug, Clone, Copy)]
struct Entry {
    key: f32,
    span: u32,
}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        // Reversed: `BinaryHeap` is a max-heap.
        other
            .key
            .total_cmp(&self.key)
            .then_with(|| other.span.cmp(&self.span))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Entry {}

/// Everything repeated geodesic queries on one grid need, computed once: span positions and
/// the line-of-sight index.
#[derive(Debug, Clone)]
pub struct Geodesic<'g> {
    sight: SightIndex<'g>,
    pos: Vec<Vec3>,
}

impl<'g> Geodesic<'g> {
    /// Precomputes span positions and the [`SightIndex`] (linear in the number of spans).
    pub fn new(grid: &'g NavGrid) -> Self {
        let sight = SightIndex::new(grid);
        let size = grid.cell();
        let pos = (0..grid.spans.len() as u32)
            .zip(&grid.spans)
            .map(|(s, span)| {
                let (ix, iz) = sight.cell(s);
                Vec3::new(
                    grid.x0 + (ix as f32 + 0.5) * size,
                    span.y,
                    grid.z0 + (iz as f32 + 0.5) * size,
                )
            })
            .collect();
        Geodesic { sight, pos }
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
        self.pos.get(span as usize).copied()
    }

    /// True when fields are exact geodesics (`clearance_weight <= 1`), false in MINOS's
    /// weighted mode.
    pub fn exact(&self) -> bool {
        self.grid().params.clearance_weight <= 1.0
    }

    /// The full distance field to the nearest of `goals` (non-walkable or out-of-range goals
    /// are ignored; with none left every span is unreachable).
    pub fn field(&self, goals: &[u32]) -> DistanceField {
        self.run(goals, None)
    }

    /// A single-pair search from `goal` that stops once `start` is settled (A* with the
    /// admissible straight-line heuristic). Only settled spans have values (the others are
    /// `INFINITY`/`NONE`), enough to follow anchors from `start` to `goal`.
    pub fn search(&self, goal: u32, start: u32) -> DistanceField {
        self.run(&[goal], Some(start))
    }

    fn run(&self, goals: &[u32], target: Option<u32>) -> DistanceField {
        let grid = self.grid();
        let n = grid.spans.len();
        let mut field = DistanceField {
            dist: vec![f32::INFINITY; n],
            anchor: vec![NONE; n],
        };
        let valid = |s: u32| grid.spans.get(s as usize).is_some_and(|s| s.walkable);
        if target.is_some_and(|t| !valid(t)) {
            return field;
        }
        let mut closed = vec![false; n];
        let mut heap = BinaryHeap::with_capacity(1024);
        let target_pos = target.map(|t| self.pos[t as usize]);
        for &goal in goals {
            if valid(goal) && field.dist[goal as usize] != 0.0 {
                field.dist[goal as usize] = 0.0;
                field.anchor[goal as usize] = goal;
                let key = target_pos.map_or(0.0, |p| p.distance(self.pos[goal as usize]));
                heap.push(Entry { key, span: goal });
            }
        }
        if self.exact() {
            self.lazy_theta(&mut field, &mut closed, &mut heap, target);
        } else {
            self.weighted(&mut field, &mut closed, &mut heap, target);
        }
        if target.is_some() {
            for (s, &done) in closed.iter().enumerate() {
                if !done {
                    field.dist[s] = f32::INFINITY;
                    field.anchor[s] = NONE;
                }
            }
        }
        field
    }

    /// Lazy Theta* (see the module documentation).
    fn lazy_theta(
        &self,
        field: &mut DistanceField,
        closed: &mut [bool],
        heap: &mut BinaryHeap<Entry>,
        target: Option<u32>,
    ) {
        let sight = &self.sight;
        let pos = &self.pos;
        let g = &mut field.dist;
        let anchor = &mut field.anchor;
        let target_pos = target.map(|t| pos[t as usize]);
        while let Some(Entry { span: s, .. }) = heap.pop() {
            let su = s as usize;
            if closed[su] {
                continue;
            }
            // Start loading the next span's record now: the load overlaps with this
            // iteration's work instead of stalling the next one.
            if let Some(next) = heap.peek() {
                std::hint::black_box(sight.touch(next.span));
            }
            let a = anchor[su];
            if a != s && !sight.straight_line_unchecked(a, s) {
                // Repair from the best settled neighbour (the one that proposed the anchor is
                // among them, so there is one).
                let ps = pos[su];
                let (mut best, mut best_k) = (f32::INFINITY, NONE);
                sight.for_each_link(s, |k| {
                    if closed[k as usize] {
                        let c = g[k as usize] + pos[k as usize].distance(ps);
                        if c < best || (c == best && k < best_k) {
                            best = c;
                            best_k = k;
                        }
                    }
                });
                g[su] = best;
                anchor[su] = best_k;
                if best_k == NONE {
                    closed[su] = true;
                    continue;
                }
            }
            closed[su] = true;
            if target == Some(s) {
                return;
            }
            let a = anchor[su];
            let (ga, pa) = (g[a as usize], pos[a as usize]);
            sight.for_each_link(s, |nb| {
                if closed[nb as usize] {
                    return;
                }
                let pn = pos[nb as usize];
                let c = ga + pa.distance(pn);
                if c < g[nb as usize] {
                    g[nb as usize] = c;
                    anchor[nb as usize] = a;
                    let key = target_pos.map_or(c, |p| c + p.distance(pn));
                    heap.push(Entry { key, span: nb });
                }
            });
        }
    }

    /// MINOS's clearance-weighted 8-connected Dijkstra (A* towards `target` if given).
    fn weighted(
        &self,
        field: &mut DistanceField,
        closed: &mut [bool],
        heap: &mut BinaryHeap<Entry>,
        target: Option<u32>,
    ) {
        let grid = self.grid();
        let spans = &grid.spans;
        let pos = &self.pos;
        let threshold = grid.params.agent_radius + grid.params.clearance_margin;
        let weight = grid.params.clearance_weight;
        let target_pos = target.map(|t| pos[t as usize]);
        while let Some(Entry { span: s, .. }) = heap.pop() {
            let su = s as usize;
            if closed[su] {
                continue;
            }
            closed[su] = true;
            if target == Some(s) {
                return;
            }
            let (gs, ps) = (field.dist[su], pos[su]);
            self.sight.for_each_link(s, |nb| {
                if closed[nb as usize] {
                    return;
                }
                let pn = pos[nb as usize];
                let w = if spans[nb as usize].clearance < threshold {
                    weight
                } else {
                    1.0
                };
                let c = gs + ps.distance(pn) * w;
                if c < field.dist[nb as usize] {
                    field.dist[nb as usize] = c;
                    field.anchor[nb as usize] = s;
                    let key = target_pos.map_or(c, |p| c + p.distance(pn));
                    heap.push(Entry { key, span: nb });
                }
            });
        }
    }
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
