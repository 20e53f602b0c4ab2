//! Shortest paths between two spans, as string-pulled polylines with the rooms and doors
//! they pass.
//!
//! A path is the chain of a geodesic search (see `geodesic`): the A* over the sparse graph
//! of obstacle corners and zone gates (falling back to the cell-level Lazy Theta* search where
//! that graph does not join the pair), or the anchors of a precomputed [`DistanceField`].
//! [`shortest_path`] and [`shortest_path_in`] run the same search, so they return the same
//! path. The chain is string-pulled once more (consecutive segments merge wherever a
//! straight walk allows), its corners are refined, and its segments are walked span by span
//! to list the rooms and door objects on the way ([`shortest_polyline_in`] leaves that walk
//! out, [`add_rooms_and_doors`] adds it; refinement looks again only at corners next to a
//! change). In MINOS's weighted mode the chain is the grid path of the cell-level search;
//! only collinear steps are merged.
//!
//! Where this module's job ends: it answers one pair (or follows one field); choosing
//! endpoints, snapping positions to spans and episodes are other modules' jobs.

use glam::Vec3;

use super::geodesic::{DistanceField, Geodesic, GoalRegions};
use super::grid::{NavGrid, NONE};
use super::los;

/// A walkable path from one span to another.
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    /// The spans where the polyline bends, from the start span to the goal span (a
    /// sub-sequence of the anchor chain).
    pub spans: Vec<u32>,
    /// Positions of `spans` (cell centres at floor height): the polyline, no grid zig-zag.
    pub points: Vec<Vec3>,
    /// Length of the polyline (m, 3D).
    pub length: f32,
    /// Room indices (into [`NavGrid::rooms`]) passed in order; consecutive duplicates and
    /// spans outside rooms removed.
    pub rooms: Vec<u32>,
    /// Doorway object indices (into [`NavGrid::objects`]: doors and arches) whose spans the
    /// path passes, in order of first passage, without duplicates.
    pub doors: Vec<u32>,
}

/// The answer to a path query.
#[derive(Debug, Clone, PartialEq)]
pub enum PathResult {
    /// No path: an endpoint is not a walkable span, or the two lie on different islands.
    Unreachable,
    /// The shortest path found.
    Found(Path),
}

impl PathResult {
    /// The path, if one was found.
    pub fn path(&self) -> Option<&Path> {
        match self {
            PathResult::Found(p) => Some(p),
            PathResult::Unreachable => None,
        }
    }

    /// The path's length, if one was found.
    pub fn length(&self) -> Option<f32> {
        self.path().map(|p| p.length)
    }
}

/// Is `s` a walkable span of `grid`?
fn walkable(grid: &NavGrid, s: u32) -> bool {
    grid.spans.get(s as usize).is_some_and(|s| s.walkable)
}

/// Both endpoints walkable and not known to lie on different islands.
fn may_connect(grid: &NavGrid, from: u32, to: u32) -> bool {
    if !walkable(grid, from) || !walkable(grid, to) {
        return false;
    }
    let (a, b) = (
        grid.spans[from as usize].island,
        grid.spans[to as usize].island,
    );
    a == NONE || b == NONE || a == b
}

/// The shortest path from span `from` to span `to` (see the module documentation).
/// Builds a [`Geodesic`] first; use [`shortest_path_in`] for repeated queries on one grid.
pub fn shortest_path(grid: &NavGrid, from: u32, to: u32) -> PathResult {
    if !may_connect(grid, from, to) {
        return PathResult::Unreachable;
    }
    shortest_path_in(&Geodesic::new(grid), from, to)
}

/// [`shortest_path`] with precomputed geodesic data.
pub fn shortest_path_in(geo: &Geodesic<'_>, from: u32, to: u32) -> PathResult {
    let mut result = shortest_polyline_in(geo, from, to);
    if let PathResult::Found(path) = &mut result {
        add_rooms_and_doors(geo.grid(), path);
    }
    result
}

/// [`shortest_path_in`] without the walk that lists rooms and doors: the same spans, points
/// and length, with `rooms` and `doors` left empty. For callers that may discard the path
/// by its length; [`add_rooms_and_doors`] completes a kept one.
pub fn shortest_polyline_in(geo: &Geodesic<'_>, from: u32, to: u32) -> PathResult {
    let grid = geo.grid();
    if !may_connect(grid, from, to) {
        return PathResult::Unreachable;
    }
    match geo.path_chain(from, to) {
        Some(chain) => PathResult::Found(polyline(grid, Some(geo), chain)),
        None => PathResult::Unreachable,
    }
}

/// The shortest path from `from` to the nearest span of `goals` as one sparse query
/// ([`Geodesic::nearest_chain`]), with `rooms` and `doors` left empty as in
/// [`shortest_polyline_in`]; `None` when that query cannot answer, where a field from the
/// goals ([`path_from_field`]) can.
pub fn nearest_polyline_in(geo: &Geodesic<'_>, from: u32, goals: &GoalRegions) -> Option<Path> {
    geo.nearest_chain(from, goals)
        .map(|chain| polyline(geo.grid(), Some(geo), chain))
}

/// Fills a path's `rooms` and `doors` by walking its segments span by span (what
/// [`shortest_path_in`] adds to [`shortest_polyline_in`]).
pub fn add_rooms_and_doors(grid: &NavGrid, path: &mut Path) {
    (path.rooms, path.doors) = rooms_and_doors(grid, &path.spans);
}

/// The path from span `from` to the nearest goal of a precomputed field, following its
/// anchors. `Unreachable` when `from` cannot reach a goal or the field does not belong to
/// this grid.
pub fn path_from_field(grid: &NavGrid, field: &DistanceField, from: u32) -> PathResult {
    let n = grid.spans.len();
    if field.dist.len() != n || field.anchor.len() != n || !walkable(grid, from) {
        return PathResult::Unreachable;
    }
    if !field.reachable(from) {
        return PathResult::Unreachable;
    }
    let mut chain = vec![from];
    let mut s = from;
    loop {
        let a = field.anchor[s as usize];
        if a == s {
            break;
        }
        if a == NONE || a as usize >= n || chain.len() > n {
            return PathResult::Unreachable;
        }
        chain.push(a);
        s = a;
    }
    finish(grid, None, chain)
}

/// String-pulls and refines an anchor chain (start first), and collects rooms and doors.
fn finish(grid: &NavGrid, geo: Option<&Geodesic<'_>>, chain: Vec<u32>) -> PathResult {
    let mut path = polyline(grid, geo, chain);
    add_rooms_and_doors(grid, &mut path);
    PathResult::Found(path)
}

/// String-pulls and refines an anchor chain (start first); rooms and doors left empty.
fn polyline(grid: &NavGrid, geo: Option<&Geodesic<'_>>, chain: Vec<u32>) -> Path {
    let pos = |s: u32| match geo.and_then(|g| g.position(s)) {
        Some(p) => p,
        None => grid.span_position(s as usize),
    };
    let chain = if grid.params.clearance_weight <= 1.0 {
        let straight = |a: u32, b: u32| match geo {
            Some(g) => g.sight().straight_line(a, b),
            None => los::straight_line(grid, a, b),
        };
        let pulled = string_pull(&chain, &straight);
        refine(grid, pulled, &pos, &straight)
    } else {
        merge_collinear(&chain, &pos)
    };
    let points: Vec<Vec3> = chain.iter().map(|&s| pos(s)).collect();
    let length = points.windows(2).map(|w| w[0].distance(w[1])).sum();
    Path {
        spans: chain,
        points,
        length,
        rooms: Vec::new(),
        doors: Vec::new(),
    }
}

/// Greedy string pulling: from each kept span, skip ahead while a straight walk reaches the
/// span after next.
fn string_pull(chain: &[u32], straight: &impl Fn(u32, u32) -> bool) -> Vec<u32> {
    let mut out = vec![chain[0]];
    let mut i = 0;
    while i + 1 < chain.len() {
        let mut j = i + 1;
        while j + 1 < chain.len() && straight(chain[i], chain[j + 1]) {
            j += 1;
        }
        out.push(chain[j]);
        i = j;
    }
    out
}

/// Local improvement of a string-pulled chain: drops corners that became unnecessary and
/// moves each corner to the neighbouring span that shortens its two segments while both stay
/// straight walks, until nothing changes. Anchors sit on cell centres, so corners found by
/// the search can be up to a cell from the best one; this brings paths within a fraction of
/// a cell per corner of the optimum and makes A→B and B→A agree.
fn refine(
    grid: &NavGrid,
    mut chain: Vec<u32>,
    pos: &impl Fn(u32) -> Vec3,
    straight: &impl Fn(u32, u32) -> bool,
) -> Vec<u32> {
    // A corner whose own span and neighbours are as they were when it last changed nothing
    // would change nothing again: only corners next to a change are looked at again (the
    // same result as looking at every corner in every pass, with fewer straight walks).
    let mut dirty = vec![true; chain.len()];
    for _ in 0..32 {
        let mut changed = false;
        let mut i = 1;
        while i + 1 < chain.len() {
            if !dirty[i] {
                i += 1;
                continue;
            }
            let (p, q) = (chain[i - 1], chain[i + 1]);
            if straight(p, q) {
                chain.remove(i);
                dirty.remove(i);
                dirty[i - 1] = true;
                dirty[i] = true;
                changed = true;
                continue;
            }
            let (pp, pq) = (pos(p), pos(q));
            let cost = |s: u32| {
                let ps = pos(s);
                pp.distance(ps) + ps.distance(pq)
            };
            let mut best = (cost(chain[i]), chain[i]);
            for n in grid.spans[chain[i] as usize].links {
                if n == NONE {
                    continue;
                }
                let c = cost(n);
                if c < best.0 - 1e-5 && straight(p, n) && straight(n, q) {
                    best = (c, n);
                }
            }
            if best.1 != chain[i] {
                chain[i] = best.1;
                dirty[i - 1] = true;
                dirty[i + 1] = true;
                changed = true;
            } else {
                dirty[i] = false;
            }
            i += 1;
        }
        if !changed {
            break;
        }
    }
    chain
}

/// Drops chain spans that lie on the straight 3D line between their neighbours.
fn merge_collinear(chain: &[u32], pos: &impl Fn(u32) -> Vec3) -> Vec<u32> {
    let mut out = vec![chain[0]];
    for k in 1..chain.len() {
        let last = k + 1 == chain.len();
        if !last {
            let p = pos(out[out.len() - 1]);
            let q = pos(chain[k]);
            let r = pos(chain[k + 1]);
            let (u, v) = (q - p, r - q);
            if u.cross(v).length() <= 1e-4 * u.length() * v.length() && u.dot(v) > 0.0 {
                continue;
            }
        }
        out.push(chain[k]);
    }
    out
}

/// Rooms and doors met walking the chain's segments span by span.
fn rooms_and_doors(grid: &NavGrid, chain: &[u32]) -> (Vec<u32>, Vec<u32>) {
    let mut rooms: Vec<u32> = Vec::new();
    let mut doors: Vec<u32> = Vec::new();
    let mut visit = |s: u32| {
        let room = grid.spans[s as usize].room;
        if room != NONE && rooms.last() != Some(&room) {
            rooms.push(room);
        }
        let start = grid.span_objects.partition_point(|&(t, _)| t < s);
        for &(t, o) in &grid.span_objects[start..] {
            if t != s {
                break;
            }
            // Doorways: doors and arches (MINOS's door categories, `arch` and `door`; a
            // generated house joins open-plan rooms with arches).
            let is_door = grid
                .objects
                .get(o as usize)
                .is_some_and(|obj| obj.door || obj.arch);
            if is_door && !doors.contains(&o) {
                doors.push(o);
            }
        }
    };
    if chain.len() == 1 {
        visit(chain[0]);
    }
    for w in chain.windows(2) {
        if !los::walk_line(grid, w[0], w[1], &mut visit) {
            visit(w[1]);
        }
    }
    (rooms, doors)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::navmesh::geodesic::distance_field;
    use crate::navmesh::testmaps::{
        reference_geodesic, rows_from, stairs, stairs_reference, MapSpec,
    };
    use crate::navmesh::NavParams;

    fn span_at(grid: &NavGrid, ix: usize, iz: usize) -> u32 {
        grid.column_start[iz * grid.nx as usize + ix]
    }

    fn found(r: PathResult) -> Path {
        match r {
            PathResult::Found(p) => p,
            PathResult::Unreachable => panic!("expected a path"),
        }
    }

    #[test]
    fn empty_room_path_is_one_straight_segment() {
        let rows = rows_from(80, 60, |x, z| x > 0 && z > 0 && x < 79 && z < 59);
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        let grid = MapSpec::ascii(&refs, 0.05).build(NavParams::default());
        let (a, b) = (span_at(&grid, 3, 50), span_at(&grid, 70, 4));
        let path = found(shortest_path(&grid, a, b));
        assert_eq!(path.spans, vec![a, b]);
        assert_eq!(path.points.len(), 2);
        let euclid = grid
            .span_position(a as usize)
            .distance(grid.span_position(b as usize));
        assert!((path.length - euclid).abs() < 1e-4);
        assert!(path.rooms.is_empty() && path.doors.is_empty());
        let same = found(shortest_path(&grid, a, a));
        assert_eq!((same.spans.len(), same.length), (1, 0.0));
    }

    #[test]
    fn corridor_path_bends_only_at_the_corner() {
        let rows = rows_from(200, 200, |x, z| {
            ((2..40).contains(&x) && (2..198).contains(&z))
                || ((2..198).contains(&x) && (160..198).contains(&z))
        });
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        let spec = MapSpec::ascii(&refs, 0.05);
        let grid = spec.build(NavParams::default());
        let (a, b) = (span_at(&grid, 20, 10), span_at(&grid, 190, 175));
        let path = found(shortest_path(&grid, a, b));
        assert_eq!(path.spans.first(), Some(&a));
        assert_eq!(path.spans.last(), Some(&b));
        assert!((3..=4).contains(&path.points.len()), "{:?}", path.points);
        for w in path.spans.windows(2) {
            assert!(los::line_of_sight(&grid, w[0], w[1]));
        }
        let want = reference_geodesic(|x, z| spec.free(x, z), 200, 200, (20, 10), (190, 175))
            .unwrap()
            * 0.05;
        let err = (f64::from(path.length) - want).abs() / want;
        assert!(err < 0.01, "{} vs {want}", path.length);
        // The same path from a precomputed field.
        let field = distance_field(&grid, &[b]);
        let again = found(path_from_field(&grid, &field, a));
        assert!((again.length - path.length).abs() / path.length < 0.005);
        assert!(again.length <= field.distance(a).unwrap() + 1e-3);
    }

    #[test]
    fn unreachable_pairs_say_so() {
        let rows = [
            "############",
            "#....#.....#",
            "#....#.###.#",
            "#....#.#.#.#",
            "#....#.###.#",
            "############",
        ];
        let grid = MapSpec::ascii(&rows, 0.1).build(NavParams::default());
        let a = span_at(&grid, 1, 1);
        assert_eq!(
            shortest_path(&grid, a, span_at(&grid, 8, 3)),
            PathResult::Unreachable
        );
        assert_eq!(
            shortest_path(&grid, a, span_at(&grid, 10, 1)),
            PathResult::Unreachable
        );
        assert_eq!(
            shortest_path(&grid, a, span_at(&grid, 5, 1)),
            PathResult::Unreachable
        );
        assert_eq!(shortest_path(&grid, a, u32::MAX), PathResult::Unreachable);
        let field = distance_field(&grid, &[a]);
        assert_eq!(
            path_from_field(&grid, &field, span_at(&grid, 8, 3)),
            PathResult::Unreachable
        );
        assert!(path_from_field(&grid, &field, span_at(&grid, 4, 4))
            .path()
            .is_some());
        // Islands unknown to the grid: the search itself finds no path.
        let mut unlabelled = grid.clone();
        unlabelled.spans.iter_mut().for_each(|s| s.island = NONE);
        let to = span_at(&unlabelled, 10, 1);
        assert_eq!(shortest_path(&unlabelled, a, to), PathResult::Unreachable);
    }

    #[test]
    fn rooms_and_doors_are_listed_in_passing_order() {
        // Rooms a | b | c joined by doors D (a-b) and E (b-c); a table in room a; another
        // door F off the path.
        let rows = [
            "##################################",
            "#aaaaaaaaa#bbbbbbbbbbb#ccccccccccc#",
            "#aaaaaaaaa#bbbbbbbbbbb#ccccccccccc#",
            "#aaaa*aaaaDbbbbbbbbbbbEccccccccccc#",
            "#aaaaaaaaaDbbbbbbbbbbbEccccccccccc#",
            "#aaaaaaaaa#bbbbbbbbbbb#ccccccccccc#",
            "#aaaaaaaaa#bbbbbbbbbbb#ccccccccccc#",
            "######FF##########################",
        ];
        let grid = MapSpec::ascii(&rows, 0.1).build(NavParams::default());
        let (d, e, f, table) = (0u32, 1u32, 2u32, 3u32);
        assert!(grid.objects[d as usize].door && grid.objects[f as usize].door);
        assert!(!grid.objects[table as usize].door);
        let from = span_at(&grid, 30, 3);
        let to = span_at(&grid, 2, 3);
        let path = found(shortest_path(&grid, from, to));
        assert_eq!(path.rooms, vec![2, 1, 0]);
        assert_eq!(path.doors, vec![e, d]);
        let back = found(shortest_path(&grid, to, from));
        assert_eq!(back.rooms, vec![0, 1, 2]);
        assert_eq!(back.doors, vec![d, e]);
        // An arch is a doorway too.
        let mut arched = grid.clone();
        arched.objects[d as usize].door = false;
        arched.objects[d as usize].arch = true;
        assert_eq!(found(shortest_path(&arched, from, to)).doors, vec![e, d]);
        arched.objects[d as usize].arch = false;
        assert_eq!(found(shortest_path(&arched, from, to)).doors, vec![e]);
        // Through the table's span: it is recorded, but is not a door.
        let via_table = found(shortest_path(
            &grid,
            span_at(&grid, 5, 1),
            span_at(&grid, 5, 6),
        ));
        assert_eq!(via_table.rooms, vec![0]);
        assert!(via_table.doors.is_empty());
    }

    #[test]
    fn weighted_paths_keep_away_from_walls() {
        // A 1.5 m wide hall; both ends next to the lower wall. The exact path hugs the wall,
        // MINOS's weighting pulls it into the middle where clearance is high.
        let rows = rows_from(100, 32, |x, z| x > 0 && z > 0 && x < 99 && z < 31);
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        let spec = MapSpec::ascii(&refs, 0.05);
        let weighted = spec.build(NavParams {
            clearance_weight: 10.0,
            ..NavParams::default()
        });
        let exact = spec.build(NavParams::default());
        let (a, b) = (span_at(&exact, 2, 1), span_at(&exact, 97, 1));
        let p1 = found(shortest_path(&exact, a, b));
        assert_eq!(p1.points.len(), 2);
        let p10 = found(shortest_path(&weighted, a, b));
        let max_z = p10.points.iter().map(|p| p.z).fold(0.0f32, f32::max);
        assert!(max_z > 0.05 + 0.3, "weighted path stays at z <= {max_z}");
        assert!(p10.length > p1.length);
        // Collinear steps are merged: far fewer points than spans walked.
        assert!(p10.points.len() < 12, "{} points", p10.points.len());
        let from_field = found(path_from_field(
            &weighted,
            &distance_field(&weighted, &[b]),
            a,
        ));
        assert!((from_field.length - p10.length).abs() < 0.05);
    }

    /// The path of the cell-level search (what point-to-point queries fall back to).
    fn cell_level(geo: &Geodesic<'_>, a: u32, b: u32) -> Option<f32> {
        let chain = geo.search_chain(b, a)?;
        finish(geo.grid(), Some(geo), chain).length()
    }

    #[test]
    fn sparse_paths_are_as_short_as_cell_level_paths_on_cluttered_maps() {
        // Two rooms and a corridor joined by doorways, with scattered boxes. Many short paths
        // bend around several boxes here, each bend half a cell off the exact corner, so both
        // searches stay up to ~12 % above the exact length on this map; the sparse search
        // must not be worse than the cell-level one, nor shorter than exact.
        let (nx, nz) = (90usize, 64usize);
        let mut rng = crate::seed::Rng::new(21);
        let mut blocked: Vec<bool> = (0..nx * nz)
            .map(|i| {
                let (x, z) = (i % nx, i / nx);
                let border = x == 0 || z == 0 || x == nx - 1 || z == nz - 1;
                let wall_x = x == 40 && !(20..26).contains(&z);
                let wall_z = z == 34 && x > 40 && !(60..66).contains(&x);
                border || wall_x || wall_z
            })
            .collect();
        // Boxes keep a free cell to everything else, so that no two blocked cells touch at a
        // corner only (the exact reference would squeeze through such a gap, the grid not).
        let mut placed = 0;
        while placed < 30 {
            let (x0, z0) = (rng.range_usize(2, nx - 6), rng.range_usize(2, nz - 6));
            let (w, h) = (rng.range_usize(1, 5), rng.range_usize(1, 5));
            let clear =
                (z0 - 1..z0 + h + 1).all(|z| (x0 - 1..x0 + w + 1).all(|x| !blocked[z * nx + x]));
            if !clear {
                continue;
            }
            for z in z0..z0 + h {
                for x in x0..x0 + w {
                    blocked[z * nx + x] = true;
                }
            }
            placed += 1;
        }
        let rows = rows_from(nx, nz, |x, z| !blocked[z * nx + x]);
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        let spec = MapSpec::ascii(&refs, 0.05);
        let grid = spec.build(NavParams::default());
        let geo = Geodesic::new(&grid);
        let free: Vec<(usize, usize)> = (0..nx * nz)
            .filter(|&i| !blocked[i])
            .map(|i| (i % nx, i / nx))
            .collect();
        let mut checked = 0;
        for _ in 0..60 {
            let (&a, &b) = (rng.pick(&free).unwrap(), rng.pick(&free).unwrap());
            let (sa, sb) = (span_at(&grid, a.0, a.1), span_at(&grid, b.0, b.1));
            let got = shortest_path_in(&geo, sa, sb).length();
            let cell = cell_level(&geo, sa, sb);
            let Some(want) = reference_geodesic(
                |x, z| spec.free(x, z),
                nx,
                nz,
                (a.0 as i64, a.1 as i64),
                (b.0 as i64, b.1 as i64),
            ) else {
                assert_eq!((got, cell), (None, None), "{a:?}->{b:?} is unreachable");
                continue;
            };
            let want = want * 0.05;
            let (got, cell) = (got.unwrap(), cell.unwrap());
            let err = (f64::from(got) - want) / want.max(1e-9);
            assert!(
                err > -1e-4,
                "{a:?}->{b:?}: shorter than exact: {got} vs {want}"
            );
            assert!(
                got <= cell * 1.002 + 1e-4,
                "{a:?}->{b:?}: {got} vs cell-level {cell}"
            );
            checked += 1;
        }
        assert!(checked > 40);
    }

    #[test]
    fn sparse_paths_cross_ramps_like_the_cell_level_search() {
        // The ramp is an uneven zone: crossed between its gates, walked span by span when an
        // end lies on it.
        let grid = stairs().build(NavParams::default());
        let geo = Geodesic::new(&grid);
        let spans = grid.walkable_spans(None);
        let mut rng = crate::seed::Rng::new(4);
        for _ in 0..150 {
            let (&a, &b) = (rng.pick(&spans).unwrap(), rng.pick(&spans).unwrap());
            let (Some(got), Some(cell)) = (
                shortest_path_in(&geo, a, b).length(),
                cell_level(&geo, a, b),
            ) else {
                panic!("{a}->{b} unreachable");
            };
            assert!(
                got <= cell * 1.005 + 1e-4,
                "{a}->{b}: {got} vs cell-level {cell}"
            );
            assert!(got >= cell * 0.98, "{a}->{b}: {got} vs cell-level {cell}");
            let back = shortest_path_in(&geo, b, a).length().unwrap();
            assert!(
                (got - back).abs() <= 0.01 * got.max(0.05),
                "{a}<->{b}: {got} vs {back}"
            );
        }
    }

    #[test]
    fn a_floor_that_is_one_big_zone_uses_the_cell_level_search() {
        // 160 x 160 cells rising 6 mm per cell along x: no plateau, one zone of 25k spans.
        let rows = rows_from(160, 160, |x, z| x > 0 && z > 0 && x < 159 && z < 159);
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        let mut spec = MapSpec::ascii(&refs, 0.05);
        for x in 0..160 {
            for z in 0..160 {
                spec.set_height(x, z, x as f32 * 0.006);
            }
        }
        spec.fill(60, 20, 64, 140, '#');
        let grid = spec.build(NavParams::default());
        let geo = Geodesic::new(&grid);
        let (a, b) = (span_at(&grid, 20, 80), span_at(&grid, 120, 30));
        let path = found(shortest_path_in(&geo, a, b));
        assert_eq!(Some(path.length), cell_level(&geo, a, b));
        assert!(path.points.len() >= 3, "around the wall: {:?}", path.points);
    }

    #[test]
    fn every_entry_point_gives_the_same_path() {
        let grid = stairs().build(NavParams::default());
        let geo = Geodesic::new(&grid);
        let spans = grid.walkable_spans(None);
        let mut rng = crate::seed::Rng::new(12);
        for _ in 0..20 {
            let (&a, &b) = (rng.pick(&spans).unwrap(), rng.pick(&spans).unwrap());
            let shared = shortest_path_in(&geo, a, b);
            assert_eq!(shortest_path(&grid, a, b), shared, "{a}->{b}");
            assert_eq!(shortest_path_in(&geo, a, b), shared, "{a}->{b} again");
        }
    }

    #[test]
    fn a_shared_geodesic_answers_threads_like_one_thread() {
        let grid = stairs().build(NavParams::default());
        let geo = Geodesic::new(&grid);
        let spans = grid.walkable_spans(None);
        let mut rng = crate::seed::Rng::new(31);
        let pairs: Vec<(u32, u32)> = (0..40)
            .map(|_| (*rng.pick(&spans).unwrap(), *rng.pick(&spans).unwrap()))
            .collect();
        let alone: Vec<PathResult> = pairs
            .iter()
            .map(|&(a, b)| shortest_path_in(&geo, a, b))
            .collect();
        let field = geo.field(&[pairs[0].1]);
        std::thread::scope(|scope| {
            let workers: Vec<_> = (0..3)
                .map(|k| {
                    let (geo, pairs) = (&geo, &pairs);
                    scope.spawn(move || {
                        let paths: Vec<PathResult> = pairs
                            .iter()
                            .cycle()
                            .skip(k * 7)
                            .take(pairs.len())
                            .map(|&(a, b)| shortest_path_in(geo, a, b))
                            .collect();
                        (paths, geo.field(&[pairs[0].1]))
                    })
                })
                .collect();
            for (k, worker) in workers.into_iter().enumerate() {
                let (paths, f) = worker.join().expect("worker");
                assert_eq!(f, field);
                for (i, p) in paths.iter().enumerate() {
                    assert_eq!(p, &alone[(i + k * 7) % pairs.len()]);
                }
            }
        });
    }

    #[test]
    fn stairs_path_climbs_between_floors() {
        let grid = stairs().build(NavParams::default());
        let low = span_at(&grid, 3, 2);
        let high = span_at(&grid, 75, 5) + 1;
        let path = found(shortest_path(&grid, low, high));
        let want = stairs_reference((0.35, 0.25), (7.55, 0.55));
        assert!(
            (f64::from(path.length) - want).abs() / want < 0.015,
            "{} vs {want} (chords may cut slope changes by the profile tolerance)",
            path.length
        );
        assert_eq!(path.points.first().map(|p| p.y), Some(0.0));
        assert_eq!(path.points.last().map(|p| p.y), Some(3.0));
        // Bends at the foot and the top of the ramp, not a chord through the air.
        assert!(path.points.len() >= 4, "{:?}", path.points);
    }
}
