//! Point-to-point paths over the sparse graph: plateau and zone labelling, portals and their
//! gates, corner vertices with straight-walk edges and landmark distances (stored in `.nav`
//! since format 3–4, recomputed otherwise), and the search with landmark and portal bounds.
//!
//! # Files
//!
//! `mod.rs` the graph's types, its building from labels and edges, and the accessors the
//! `.nav` writer reads; `labels.rs` the linear part (plateaus, zones, areas, portals and
//! vertices, computed or taken from a `.nav` file); `landmarks.rs` the landmark distances;
//! `search.rs` the point-to-point search and its portal bound.

use super::*;

mod labels;
mod landmarks;
mod search;

use landmarks::landmarks;

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
}
