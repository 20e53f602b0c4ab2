//! The path from a start to the nearest of several goal regions (an object category's
//! instances) as one query over the sparse graph, without a distance field.
//!
//! A field from a region settles every span of the island, so an episode sampler that draws
//! among many categories (open-vocabulary ObjectGoal: ≈ 30 per generated house) pays a
//! field per category for a few draws each. This search costs about what a point-to-point
//! query costs: A* over the corners and gates from the start, as [`Geodesic::sparse_chain`],
//! where the goal is every span of the regions.
//!
//! - From each settled vertex (and the start), each region is a candidate at the distance to
//!   its box; once popped, its entry spans (those linked to a walkable span outside it: a
//!   straight walk from outside enters there) are tried nearest first, each one's straight
//!   walk checked when it pops. From a corner only the entries a shortest path could bend
//!   towards are tried: round the corner's obstacle, turning to its side.
//! - The heuristic is the larger of the straight line to the nearest region's box and the
//!   landmark bound: per landmark, its graph distance to the regions (computed once per
//!   [`GoalRegions`], through the vertices that see an entry span) less its distance to the
//!   vertex. Candidates' keys are at least a vertex's heuristic too, so a vertex behind a
//!   wall from a region tries none of its entries.
//! - Keys are exact for goals and lower bounds elsewhere, so the first goal that pops ends a
//!   shortest path.
//! - Uneven zones that hold the start or a goal span join the search span by span, as in the
//!   point-to-point search.
//!
//! Queries that the sparse graph cannot answer return `None` and the caller uses a field: no
//! sparse graph, the weighted mode, such a zone of more than [`ZONE_NODES_MAX`] spans, or a
//! start the graph does not join to any region.

use super::*;

/// Goal regions prepared for [`Geodesic::nearest_chain`]: their spans, the spans a path enters
/// each by, and each region's box.
#[derive(Debug, Clone)]
pub struct GoalRegions {
    /// Every walkable span of every region, sorted and distinct.
    members: Vec<u32>,
    /// Entry spans of region `r`: `entries[first[r]..first[r + 1]]`.
    first: Vec<u32>,
    entries: Vec<u32>,
    /// Per entry span: its position and cell.
    entry_at: Vec<(Vec3, (i64, i64))>,
    /// Per region: the (min, max) corners of its spans' positions.
    boxes: Vec<(Vec3, Vec3)>,
    /// The uneven zones ([`Sparse`] area values) that hold a span of a region.
    zones: Vec<u32>,
    /// Per landmark of the sparse graph: the graph distance from it to the nearest region
    /// (through the vertices that see an entry span), for the search's landmark bound;
    /// `None` where a region lies in an uneven zone.
    to_goal: Option<[f32; LANDMARKS]>,
    /// False when the sparse search cannot serve these regions (no sparse graph).
    usable: bool,
}

impl GoalRegions {
    /// Is `span` in one of the regions?
    pub fn contains(&self, span: u32) -> bool {
        self.members.binary_search(&span).is_ok()
    }

    /// Number of regions.
    pub fn len(&self) -> usize {
        self.boxes.len()
    }

    /// True when there is no region (or none has a walkable span).
    pub fn is_empty(&self) -> bool {
        self.boxes.is_empty()
    }
}

/// What a queue item of [`Geodesic::nearest_chain`] does when it pops.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Step {
    /// Reach `node` from `parent` at distance `g` (bits); `lazy` when the straight walk is
    /// still to be checked.
    Node {
        node: u32,
        parent: u32,
        g: u32,
        lazy: bool,
    },
    /// List region `region`'s entry spans as seen from the settled span `from`.
    Region { from: u32, region: u32 },
    /// Try the entry span `candidates[at]` (of `candidates[at..end]`, nearest first) from the
    /// settled span `from`.
    Candidate { from: u32, at: u32, end: u32 },
}

/// A queue item: pops by key (f32 bits of the distance plus the heuristic), then by step.
type Item = Reverse<(u32, Step)>;

impl<'g> Geodesic<'g> {
    /// Prepares `regions` (each a set of spans; spans that are not walkable are left out, and
    /// so are regions left empty) for [`Geodesic::nearest_chain`].
    pub fn goal_regions(&self, regions: &[&[u32]]) -> GoalRegions {
        let grid = self.grid();
        let spans = &grid.spans;
        let walkable = |s: u32| spans.get(s as usize).is_some_and(|s| s.walkable);
        let sparse = if self.exact() { self.sparse() } else { None };
        let mut out = GoalRegions {
            members: Vec::new(),
            first: vec![0],
            entries: Vec::new(),
            entry_at: Vec::new(),
            boxes: Vec::new(),
            zones: Vec::new(),
            to_goal: None,
            usable: sparse.is_some(),
        };
        for region in regions {
            let mut own: Vec<u32> = region.iter().copied().filter(|&s| walkable(s)).collect();
            own.sort_unstable();
            own.dedup();
            let Some(&first) = own.first() else {
                continue;
            };
            let p0 = self.position(first).unwrap_or(Vec3::ZERO);
            let (mut lo, mut hi) = (p0, p0);
            for &s in &own {
                let p = self.position(s).unwrap_or(p0);
                (lo, hi) = (lo.min(p), hi.max(p));
                if let Some(sp) = sparse {
                    let area = sp.labels.area[s as usize];
                    if area != NONE && area & IN_ZONE != 0 {
                        out.zones.push(area);
                    }
                }
                let outside = spans[s as usize]
                    .links
                    .iter()
                    .any(|&l| l != NONE && walkable(l) && own.binary_search(&l).is_err());
                if outside {
                    out.entries.push(s);
                    out.entry_at.push((p, self.cell_xz(s)));
                }
            }
            out.first.push(out.entries.len() as u32);
            out.boxes.push((lo, hi));
            out.members.extend_from_slice(&own);
        }
        out.members.sort_unstable();
        out.members.dedup();
        out.zones.sort_unstable();
        out.zones.dedup();
        if let Some(sp) = sparse.filter(|_| out.zones.is_empty() && !out.is_empty()) {
            out.to_goal = Some(self.landmarks_to(sp, &out));
        }
        out
    }

    /// [`GoalRegions::to_goal`]: per landmark, the smallest of its graph distance to a vertex
    /// plus the straight walk from there to an entry span the vertex sees and could bend
    /// towards. Vertices nearest the regions first; a vertex, or an entry, that cannot lower
    /// any landmark's distance is skipped (as the point-to-point search does for its goal).
    fn landmarks_to(&self, sp: &Sparse, goals: &GoalRegions) -> [f32; LANDMARKS] {
        let spans = &self.grid().spans;
        let mut islands: Vec<u32> = goals
            .members
            .iter()
            .map(|&s| spans[s as usize].island)
            .collect();
        islands.sort_unstable();
        islands.dedup();
        let mut near: Vec<(u32, u32)> = sp
            .labels
            .verts
            .iter()
            .enumerate()
            .filter(|(_, v)| {
                islands
                    .binary_search(&spans[v.span as usize].island)
                    .is_ok()
            })
            .map(|(i, v)| {
                let d = goals
                    .boxes
                    .iter()
                    .map(|&(lo, hi)| box_distance(lo, hi, v.pos))
                    .fold(f32::INFINITY, f32::min);
                (d.to_bits(), i as u32)
            })
            .collect();
        near.sort_unstable();
        let mut to_goal = [f32::INFINITY; LANDMARKS];
        let lowers = |marks: &[f32; LANDMARKS], d: f32, to_goal: &[f32; LANDMARKS]| {
            marks.iter().zip(to_goal).any(|(m, t)| m + d < *t)
        };
        let mut list: Vec<(u32, u32)> = Vec::new();
        for &(d, i) in &near {
            let marks = &sp.marks[i as usize];
            if !lowers(marks, f32::from_bits(d), &to_goal) {
                continue;
            }
            let v = &sp.labels.verts[i as usize];
            list.clear();
            list.extend(
                goals
                    .entry_at
                    .iter()
                    .enumerate()
                    .filter(|(_, &(_, ce))| v.gate || v.allows(ce))
                    .map(|(k, &(pe, _))| (dist(v.pos, pe).to_bits(), k as u32)),
            );
            list.sort_unstable();
            for &(de, k) in &list {
                let de = f32::from_bits(de);
                if !lowers(marks, de, &to_goal) {
                    break;
                }
                if self.sight.straight_line(v.span, goals.entries[k as usize]) {
                    for (t, m) in to_goal.iter_mut().zip(marks) {
                        *t = t.min(m + de);
                    }
                    break;
                }
            }
        }
        to_goal
    }

    /// The anchor chain (`start` first, a span of a region last) of the shortest path from
    /// `start` to the nearest span of `goals` over the sparse graph; `None` when the search
    /// cannot answer (see the module documentation) and a field should be used instead.
    pub fn nearest_chain(&self, start: u32, goals: &GoalRegions) -> Option<Vec<u32>> {
        if !goals.usable || goals.is_empty() || !self.exact() {
            return None;
        }
        let sp = self.sparse()?;
        let spans = &self.grid().spans;
        if !spans.get(start as usize).is_some_and(|s| s.walkable) {
            return None;
        }
        if goals.contains(start) {
            return Some(vec![start]);
        }
        let area = |s: u32| sp.labels.area[s as usize];
        let zone_of = |s: u32| Some(area(s)).filter(|&a| a != NONE && a & IN_ZONE != 0);
        if area(start) == NONE {
            return None;
        }
        // The zones holding the start or a goal: their spans are nodes too, joined by their
        // links to each other and to the gates around them (as in the point-to-point search).
        let mut zones: Vec<u32> = goals.zones.clone();
        zones.extend(zone_of(start));
        zones.sort_unstable();
        zones.dedup();
        let big = |z: &u32| {
            sp.labels
                .zone_spans
                .get((z & !IN_ZONE) as usize)
                .is_none_or(|&size| size > ZONE_NODES_MAX)
        };
        if zones.iter().any(big) {
            return None;
        }
        let active = |s: u32| zone_of(s).is_some_and(|z| zones.binary_search(&z).is_ok());
        let island = spans[start as usize].island;
        let sight = &self.sight;
        let vertex = |s: u32| sp.labels.verts.get(sp.labels.role[s as usize] as usize);
        let is_node = |s: u32| active(s) || vertex(s).is_some_and(|v| v.gate);
        let pos = |s: u32| match vertex(s) {
            Some(v) => v.pos,
            None => self.position(s).unwrap_or(Vec3::ZERO),
        };
        // A lower bound on the distance from a span to the nearest region: the straight line
        // to the nearest region's box, and for a vertex outside the active zones the landmark
        // bound (a path from a landmark to the regions is no longer than through the vertex).
        let h = |s: u32| {
            let p = pos(s);
            let mut best = goals
                .boxes
                .iter()
                .map(|&(lo, hi)| box_distance(lo, hi, p))
                .fold(f32::INFINITY, f32::min);
            if let (Some(to_goal), Some(marks)) = (
                goals.to_goal.as_ref(),
                sp.marks
                    .get(sp.labels.role[s as usize] as usize)
                    .filter(|_| !active(s)),
            ) {
                for (m, t) in marks.iter().zip(to_goal) {
                    let d = t - m;
                    if d.is_finite() {
                        best = best.max(d);
                    }
                }
            }
            best
        };
        // The heuristic of a vertex, once per search (`hcache`: per vertex, the open mark of
        // the search that computed it and its value).
        let h_of = |hcache: &mut [(u32, f32)], open: u32, s: u32| match hcache
            .get_mut(sp.labels.role[s as usize] as usize)
        {
            Some(c) if c.0 == open => c.1,
            Some(c) => {
                *c = (open, h(s));
                c.1
            }
            None => h(s),
        };
        let push_node = |queue: &mut BinaryHeap<Item>,
                         hcache: &mut [(u32, f32)],
                         open: u32,
                         node,
                         parent,
                         g: f32,
                         lazy| {
            let f = g + h_of(hcache, open, node);
            let g = g.to_bits();
            queue.push(Reverse((
                f.to_bits(),
                Step::Node {
                    node,
                    parent,
                    g,
                    lazy,
                },
            )));
        };
        let cs = self.cell_xz(start);
        let ps = pos(start);
        self.with_scratch(|sc| {
            sc.begin();
            let (open, closed) = (sc.open, sc.open + 1);
            sc.hcache.resize(sp.labels.verts.len(), (0, 0.0));
            let (nodes, hcache) = (&mut sc.nodes[..], &mut sc.hcache[..]);
            let mut queue: BinaryHeap<Item> = BinaryHeap::new();
            // Entry spans of the regions, by distance from the span that listed them.
            let mut candidates: Vec<(u32, u32)> = Vec::new();
            push_node(&mut queue, hcache, open, start, start, 0.0, false);
            while let Some(Reverse((_, step))) = queue.pop() {
                match step {
                    Step::Node {
                        node: n,
                        parent,
                        g,
                        lazy,
                    } => {
                        if nodes[n as usize].mark == closed
                            || (lazy && !sight.straight_line(parent, n))
                        {
                            continue;
                        }
                        let gn = f32::from_bits(g);
                        let slot = &mut nodes[n as usize];
                        slot.g = gn;
                        slot.anchor = parent;
                        slot.mark = closed;
                        if goals.contains(n) {
                            return chain_to(nodes, start, n, None);
                        }
                        let pn = pos(n);
                        if n == start || vertex(n).is_some() {
                            // No region is nearer than the heuristic's bound.
                            let hn = h_of(hcache, open, n);
                            for (r, &(lo, hi)) in goals.boxes.iter().enumerate() {
                                let f = gn + box_distance(lo, hi, pn).max(hn);
                                queue.push(Reverse((
                                    f.to_bits(),
                                    Step::Region {
                                        from: n,
                                        region: r as u32,
                                    },
                                )));
                            }
                        }
                        let (pa, ga) = (pos(parent), nodes[parent as usize].g);
                        // Theta*: past a gate or a zone span, a neighbour may see the parent
                        // too (checked lazily); past a corner, the corner's obstacle is in
                        // the way.
                        let theta = parent != n && vertex(n).is_none_or(|v| v.gate);
                        let relax = |queue: &mut BinaryHeap<Item>,
                                     nodes: &mut [State],
                                     hcache: &mut [(u32, f32)],
                                     m: u32,
                                     g: f32| {
                            let node = &mut nodes[m as usize];
                            if !node.relaxable(open) {
                                return;
                            }
                            if theta && node.anchor != parent {
                                let lazy = ga + dist(pa, pos(m));
                                if lazy <= node.g {
                                    node.anchor = parent;
                                    push_node(queue, hcache, open, m, parent, lazy, true);
                                }
                            }
                            if g < node.g {
                                node.g = g;
                                push_node(queue, hcache, open, m, n, g, false);
                            }
                        };
                        if n == start {
                            // Lazy edges to every vertex that could bend towards the start.
                            for v in &sp.labels.verts {
                                if v.span != start
                                    && spans[v.span as usize].island == island
                                    && v.allows(cs)
                                {
                                    push_node(
                                        &mut queue,
                                        hcache,
                                        open,
                                        v.span,
                                        start,
                                        dist(ps, v.pos),
                                        true,
                                    );
                                }
                            }
                        } else if let Some(&i) = sp.labels.role.get(n as usize) {
                            if sp.labels.verts.get(i as usize).is_some() {
                                let (a, b) = (sp.first[i as usize], sp.first[i as usize + 1]);
                                for &(j, len) in &sp.edges[a as usize..b as usize] {
                                    let m = sp.labels.verts[j as usize].span;
                                    relax(&mut queue, nodes, hcache, m, gn + len);
                                }
                            }
                        }
                        if !zones.is_empty() && (n == start || is_node(n)) {
                            for &l in &spans[n as usize].links {
                                if l != NONE
                                    && (goals.contains(l) || active(l) || (active(n) && is_node(l)))
                                {
                                    relax(&mut queue, nodes, hcache, l, gn + dist(pn, pos(l)));
                                }
                            }
                        }
                    }
                    Step::Region { from, region } => {
                        let pf = pos(from);
                        // A corner bends only towards the quadrants beside its obstacle.
                        // A corner bends only around its obstacle: towards the quadrants
                        // beside the obstacle's, and turning to the obstacle's side of the
                        // way in (a shortest path is taut).
                        let bends = vertex(from).filter(|v| from != start && !v.gate);
                        let way_in = {
                            let a = nodes[from as usize].anchor;
                            let (ca, cf) = (self.cell_xz(a), self.cell_xz(from));
                            (cf.0 - ca.0, cf.1 - ca.1)
                        };
                        let r = region as usize;
                        let span = goals.first[r] as usize..goals.first[r + 1] as usize;
                        let at = candidates.len();
                        candidates.extend(
                            goals.entries[span.clone()]
                                .iter()
                                .zip(&goals.entry_at[span])
                                .filter(|(_, &(_, ce))| bends.is_none_or(|v| taut(v, way_in, ce)))
                                .map(|(&e, &(pe, _))| (dist(pf, pe).to_bits(), e)),
                        );
                        candidates[at..].sort_unstable();
                        if candidates.len() > at {
                            let gf = nodes[from as usize].g;
                            let f =
                                gf + f32::from_bits(candidates[at].0).max(h_of(hcache, open, from));
                            queue.push(Reverse((
                                f.to_bits(),
                                Step::Candidate {
                                    from,
                                    at: at as u32,
                                    end: candidates.len() as u32,
                                },
                            )));
                        }
                    }
                    Step::Candidate { from, mut at, end } => {
                        // The next candidates of the list while they would pop next anyway,
                        // without the queue.
                        let gf = nodes[from as usize].g;
                        let hf = h_of(hcache, open, from);
                        loop {
                            let e = candidates[at as usize].1;
                            if sight.straight_line(from, e) {
                                return chain_to(nodes, start, from, Some(e));
                            }
                            at += 1;
                            if at >= end {
                                break;
                            }
                            let f = gf + f32::from_bits(candidates[at as usize].0).max(hf);
                            let next = Reverse((f.to_bits(), Step::Candidate { from, at, end }));
                            if queue.peek().is_some_and(|top| *top > next) {
                                queue.push(next);
                                break;
                            }
                        }
                    }
                }
            }
            None
        })
    }
}

/// The settled spans' anchors from `last` back to `start`, reversed, then `goal` if given.
fn chain_to(nodes: &[State], start: u32, last: u32, goal: Option<u32>) -> Option<Vec<u32>> {
    let mut chain = vec![last];
    let mut s = last;
    while s != start {
        s = nodes.get(s as usize)?.anchor;
        if s == NONE || chain.len() > nodes.len() {
            return None;
        }
        chain.push(s);
    }
    chain.reverse();
    chain.extend(goal.filter(|&g| g != last));
    Some(chain)
}

/// Can a shortest path that reaches corner `v` going `way_in` (a cell offset) bend there
/// towards cell `to`? Only where [`Vertex::allows`] it and the turn goes round one of the
/// corner's obstacles: `to` lies on the obstacle's side of the line in (or on it).
fn taut(v: &Vertex, way_in: (i64, i64), to: (i64, i64)) -> bool {
    if !v.allows(to) {
        return false;
    }
    let cross = |a: (i64, i64), b: (i64, i64)| a.0 * b.1 - a.1 * b.0;
    let turn = cross(way_in, (to.0 - v.xz.0, to.1 - v.xz.1));
    if way_in == (0, 0) || turn == 0 {
        return true;
    }
    let mut bits = v.corners;
    while bits != 0 {
        let k = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let (dx, dz) = DIRS[4 + k];
        let side = cross(way_in, (i64::from(dx), i64::from(dz)));
        if side == 0 || (side > 0) == (turn > 0) {
            return true;
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::navmesh::los;
    use crate::navmesh::testmaps::{rows_from, stairs, MapSpec};
    use crate::navmesh::NavParams;
    use crate::seed::Rng;

    /// Two rooms joined by a doorway, with a pillar and a table-like block in the second.
    fn rooms() -> MapSpec {
        let rows = rows_from(160, 90, |x, z| {
            let inside = x > 0 && z > 0 && x < 159 && z < 89;
            let wall = (78..82).contains(&x) && !(40..52).contains(&z);
            let pillar = (100..108).contains(&x) && (30..38).contains(&z);
            let table = (120..140).contains(&x) && (55..65).contains(&z);
            inside && !wall && !pillar && !table
        });
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        MapSpec::ascii(&refs, 0.05)
    }

    /// Walkable spans within `radius` (m, on the floor plane) of span `at`.
    fn blob(grid: &NavGrid, at: u32, radius: f32) -> Vec<u32> {
        let c = grid.span_position(at as usize);
        (0..grid.spans.len() as u32)
            .filter(|&s| {
                let p = grid.span_position(s as usize);
                grid.spans[s as usize].walkable
                    && (p.x - c.x).hypot(p.z - c.z) <= radius
                    && (p.y - c.y).abs() < 0.5
            })
            .collect()
    }

    /// Length of an anchor chain, checking that each step is a link or a straight walk.
    fn chain_length(geo: &Geodesic<'_>, chain: &[u32]) -> f32 {
        let grid = geo.grid();
        chain
            .windows(2)
            .map(|w| {
                let linked = grid.spans[w[0] as usize].links.contains(&w[1]);
                assert!(
                    linked || los::straight_line(grid, w[0], w[1]),
                    "no straight walk {} -> {}",
                    w[0],
                    w[1]
                );
                dist(geo.position(w[0]).unwrap(), geo.position(w[1]).unwrap())
            })
            .sum()
    }

    /// From random starts, the search reaches a span of a region along straight walks, by a
    /// path no more than 1 % longer than the field's distance to the regions (an independent
    /// search whose any-angle paths are themselves a little long, more so on ramps), and
    /// answers exactly where the field reaches.
    fn agrees_with_the_field(grid: &NavGrid, regions: &[Vec<u32>], seed: u64) -> usize {
        let geo = Geodesic::new(grid);
        let refs: Vec<&[u32]> = regions.iter().map(Vec::as_slice).collect();
        let goals = geo.goal_regions(&refs);
        let all: Vec<u32> = regions.iter().flatten().copied().collect();
        let field = geo.field(&all);
        let spans = grid.walkable_spans(None);
        let mut rng = Rng::new(seed);
        let mut answered = 0;
        for _ in 0..150 {
            let start = *rng.pick(&spans).unwrap();
            let got = geo.nearest_chain(start, &goals);
            let Some(want) = field.distance(start) else {
                assert!(got.is_none(), "{start}: unreachable, yet a path");
                continue;
            };
            let chain = got.unwrap_or_else(|| panic!("{start}: no answer"));
            assert_eq!(chain[0], start);
            assert!(
                goals.contains(*chain.last().unwrap()),
                "{start}: ends off the goals"
            );
            let len = chain_length(&geo, &chain);
            assert!(
                len <= 1.01 * want + 1e-3 && len >= 0.95 * want,
                "{start}: {len} vs the field's {want}"
            );
            answered += 1;
        }
        answered
    }

    #[test]
    fn paths_to_the_nearest_region_agree_with_the_field() {
        for spec in [rooms(), super::super::tests::l_corridor()] {
            let grid = spec.build(NavParams::default());
            let spans = grid.walkable_spans(None);
            let mut rng = Rng::new(3);
            for round in 0..3 {
                let regions: Vec<Vec<u32>> = (0..=round)
                    .map(|_| blob(&grid, *rng.pick(&spans).unwrap(), 0.3))
                    .collect();
                assert!(agrees_with_the_field(&grid, &regions, round) > 100);
            }
        }
    }

    #[test]
    fn regions_and_starts_in_an_uneven_zone_are_served() {
        let grid = stairs().build(NavParams::default());
        let geo = Geodesic::new(&grid);
        let on = |x: usize, z: usize, y: f32| {
            (0..grid.spans.len() as u32)
                .find(|&s| {
                    let p = grid.span_position(s as usize);
                    grid.spans[s as usize].walkable
                        && (p.x - (x as f32 + 0.5) * 0.1).abs() < 0.06
                        && (p.z - (z as f32 + 0.5) * 0.1).abs() < 0.06
                        && (p.y - y).abs() < 0.2
                })
                .expect("a span there")
        };
        // Half-way up the ramp, and on the upper floor.
        let ramp = blob(&grid, on(40, 4, 1.55), 0.15);
        let upper = blob(&grid, on(74, 12, 3.0), 0.3);
        let zones = geo.goal_regions(&[&ramp]).zones.len();
        assert!(zones > 0, "the ramp is an uneven zone");
        assert!(agrees_with_the_field(&grid, std::slice::from_ref(&ramp), 5) > 100);
        assert!(agrees_with_the_field(&grid, &[ramp, upper], 6) > 100);
    }

    #[test]
    fn a_single_span_region_gets_the_point_to_point_path() {
        let grid = rooms().build(NavParams::default());
        let geo = Geodesic::new(&grid);
        let spans = grid.walkable_spans(None);
        let mut rng = Rng::new(11);
        for _ in 0..100 {
            let (start, goal) = (*rng.pick(&spans).unwrap(), *rng.pick(&spans).unwrap());
            let goals = geo.goal_regions(&[&[goal]]);
            let chain = geo.nearest_chain(start, &goals).expect("joined");
            assert_eq!(chain.last(), Some(&goal));
            let pair = geo.path_chain(start, goal).expect("joined");
            let (got, want) = (chain_length(&geo, &chain), chain_length(&geo, &pair));
            assert!(
                (got - want).abs() <= 1e-4 * want + 1e-5,
                "{start}->{goal}: {got} vs the point-to-point {want}"
            );
        }
    }

    #[test]
    fn a_start_inside_is_its_own_path_and_the_weighted_mode_declines() {
        let spec = rooms();
        let grid = spec.build(NavParams::default());
        let geo = Geodesic::new(&grid);
        let spans = grid.walkable_spans(None);
        let region = blob(&grid, spans[spans.len() / 2], 0.3);
        let goals = geo.goal_regions(&[&region]);
        assert_eq!(goals.len(), 1);
        assert_eq!(geo.nearest_chain(region[0], &goals), Some(vec![region[0]]));
        assert!(geo.goal_regions(&[]).is_empty());
        assert_eq!(geo.nearest_chain(spans[0], &geo.goal_regions(&[])), None);
        let weighted = spec.build(NavParams {
            clearance_weight: 10.0,
            ..NavParams::default()
        });
        let geo = Geodesic::new(&weighted);
        let goals = geo.goal_regions(&[&region]);
        assert_eq!(geo.nearest_chain(spans[0], &goals), None);
    }
}
