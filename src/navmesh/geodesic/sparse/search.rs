//! The point-to-point search over the sparse graph: A* with lazy straight-walk checks,
//! bounded by the landmarks and the portals of the goal's area.

use super::*;

impl<'g> Geodesic<'g> {
    /// A* from `start` to `goal` over the sparse graph (see the module documentation);
    /// `None` when the graph does not join them.
    pub(in crate::navmesh::geodesic) fn sparse_chain(
        &self,
        sp: &Sparse,
        start: u32,
        goal: u32,
    ) -> Option<Vec<u32>> {
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
                    if !node.relaxable(open) {
                        return;
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
}
