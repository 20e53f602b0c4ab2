//! Point-to-point paths over the sparse graph: plateau and zone labelling, portals and their
//! gates, corner vertices with straight-walk edges and landmark distances (stored in `.nav`
//! since format 3–4, recomputed otherwise), and the search with landmark and portal bounds.

use super::*;

/// Height step (m) between linked spans of one plateau.
pub(super) const PLATEAU_STEP: f32 = 0.005;

/// Largest height range (m) of a plateau.
pub(super) const PLATEAU_RANGE: f32 = 0.05;

/// Smallest plateau (spans); smaller ones belong to uneven zones.
pub(super) const PLATEAU_MIN: u32 = 256;

/// Most vertices (corners and gates) the sparse graph is built for; beyond, point-to-point
/// queries use the cell-level search.
pub(super) const SPARSE_MAX_VERTICES: usize = 4096;

/// Largest zone whose spans a point-to-point query takes as nodes; beyond, the query uses the
/// cell-level search.
pub(super) const ZONE_NODES_MAX: u32 = 20_000;

/// Landmarks of the sparse graph's A* heuristic.
pub(super) const LANDMARKS: usize = SPARSE_LANDMARKS;

/// Role of a span that is not a node of the sparse graph.
pub(super) const PLAIN: u32 = NONE;

/// Role of a span of an uneven zone.
pub(super) const ZONE: u32 = NONE - 1;

/// Where a region meets a zone: a path between different regions and zones passes here.
#[derive(Debug, Clone, Copy)]
pub(super) struct Portal {
    /// [`Sparse::area`] value of the zone.
    pub(super) zone: u32,
    /// [`Sparse::area`] value of the region.
    pub(super) region: u32,
    pub(super) lo: Vec3,
    pub(super) hi: Vec3,
    /// Per landmark: the smallest and the largest graph distance from the landmark to the
    /// portal's gates (`INFINITY` when a gate is not joined to it).
    pub(super) near: [f32; LANDMARKS],
    pub(super) far: [f32; LANDMARKS],
}

/// Flag of [`Sparse::area`] values that name a zone.
pub(super) const IN_ZONE: u32 = 1 << 31;

/// A vertex of the sparse graph: a corner or a gate.
#[derive(Debug, Clone, Copy)]
pub(super) struct Vertex {
    pub(super) span: u32,
    /// Cell.
    pub(super) xz: (i64, i64),
    /// Position.
    pub(super) pos: Vec3,
    /// Bit `k`: the diagonal `DIRS[4 + k]` is blocked while both axis links beside it exist,
    /// i.e. the corner of an obstacle touches the span there.
    pub(super) corners: u8,
    /// Linked to a span of an uneven zone: paths may bend here for the floor's shape, not
    /// around an obstacle.
    pub(super) gate: bool,
}

impl Vertex {
    /// Can a shortest path bend at this vertex coming from (or going to) cell `p`? Around a
    /// corner it can only when `p` lies in one of the two quadrants beside the obstacle's.
    #[inline]
    pub(super) fn allows(&self, p: (i64, i64)) -> bool {
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
pub(super) struct Sparse {
    /// Which spans are vertices, regions, zones and portals.
    pub(super) labels: Labels,
    /// Edges of vertex `i`: `edges[first[i]..first[i + 1]]`, as (vertex, length).
    pub(super) first: Vec<u32>,
    pub(super) edges: Vec<(u32, f32)>,
    /// Per vertex: graph distances to the landmarks (`INFINITY` when not joined).
    pub(super) marks: Vec<[f32; LANDMARKS]>,
}

/// The linear part of the sparse graph (see [`Sparse`]), computed from the grid or taken
/// from its stored [`SparseLabels`].
#[derive(Debug, Clone)]
pub(super) struct Labels {
    /// Per span: index into `verts`, [`ZONE`] or [`PLAIN`].
    pub(super) role: Vec<u32>,
    /// Per walkable span: its region (plateau spans joined by links; zones cut regions
    /// apart), or [`IN_ZONE`] plus its zone; `NONE` when not walkable.
    pub(super) area: Vec<u32>,
    /// Number of spans of each zone.
    pub(super) zone_spans: Vec<u32>,
    /// Portals: per (zone, region) next to each other, the zone, the region and the
    /// bounding box (min, max) of the region's spans linked to the zone.
    pub(super) portals: Vec<Portal>,
    /// (portal, gate span) for every gate of every portal.
    pub(super) portal_gates: Vec<(u32, u32)>,
    pub(super) verts: Vec<Vertex>,
}

/// An entry of the sparse search's queue: reach `node` from `parent` with distance `g`;
/// `lazy` when the straight walk from `parent` is still to be checked. Pops by key, then
/// node, then parent, checked entries first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Entry {
    /// `(f32 bits of g + heuristic) << 32 | node`.
    pub(super) key: u64,
    pub(super) parent: u32,
    pub(super) g: u32,
    pub(super) lazy: bool,
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

/// The sparse graph from its parts: the landmark distances of each portal's gates (a path
/// into or out of a zone passes one of them) are gathered here. `role` maps every gate to its
/// vertex and `marks` has one entry per vertex (checked by the caller).
#[allow(clippy::type_complexity)]
pub(super) fn finish_sparse(
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
pub(super) fn landmarks(first: &[u32], edges: &[(u32, f32)]) -> Vec<[f32; LANDMARKS]> {
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
pub(super) struct Forest {
    pub(super) parent: Vec<u32>,
}

impl Forest {
    pub(super) fn new(n: usize) -> Self {
        Forest {
            parent: (0..n as u32).collect(),
        }
    }

    pub(super) fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let up = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = up;
            x = up;
        }
        x
    }

    pub(super) fn union(&mut self, a: u32, b: u32) {
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
pub(super) fn box_distance(lo: Vec3, hi: Vec3, p: Vec3) -> f32 {
    let d = (lo - p).max(p - hi).max(Vec3::ZERO);
    d.length()
}

/// Smallest distance between the boxes `[a0, a1]` and `[b0, b1]`.
#[inline]
pub(super) fn box_gap(a0: Vec3, a1: Vec3, b0: Vec3, b1: Vec3) -> f32 {
    (b0 - a1).max(a0 - b1).max(Vec3::ZERO).length()
}

impl<'g> Geodesic<'g> {
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
    pub(super) fn sparse(&self) -> Option<&Sparse> {
        self.sparse.get_or_init(|| self.build_sparse()).as_ref()
    }

    /// Builds the sparse graph: plateaus (spans joined by links with a height step of at most
    /// [`PLATEAU_STEP`]; at least [`PLATEAU_MIN`] spans within [`PLATEAU_RANGE`]), the uneven
    /// zones (the linked spans of no plateau), regions and zones as areas with the portals
    /// between them, the vertices (spans touching an obstacle corner diagonally, and plateau
    /// spans linked to a zone), an edge between two vertices of one island whenever a
    /// shortest path could bend at both ends and the straight walk between them exists, and
    /// the landmark distances. `None` beyond [`SPARSE_MAX_VERTICES`] vertices.
    pub(super) fn build_sparse(&self) -> Option<Sparse> {
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
    pub(super) fn corners(&self, s: u32) -> u8 {
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
    pub(super) fn stored_labels(&self, l: &SparseLabels) -> Option<Labels> {
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
    pub(super) fn label_spans(&self) -> Option<Labels> {
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
    pub(super) fn sparse_chain(&self, sp: &Sparse, start: u32, goal: u32) -> Option<Vec<u32>> {
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
    pub(super) fn portal_bound<'a>(
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
