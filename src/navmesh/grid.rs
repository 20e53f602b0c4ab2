//! The baked navigation grid: a multi-layer 2.5D grid of walkable floor spans.
//!
//! Each (x, z) column holds zero or more spans, one per floor surface the agent's cylinder
//! fits above (ground floor, upper floor, stair steps). Spans store their links to the
//! neighbouring spans the agent can step to, so stairs connect levels. Columns are stored in
//! compressed form: `column_start[c]..column_start[c + 1]` are the spans of column `c`
//! (`c = iz * nx + ix`), sorted by height.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::params::NavParams;

/// No span (a missing link, no room, no island).
pub const NONE: u32 = u32::MAX;

/// The 8 neighbour directions as (dx, dz): 4 axis directions first, then diagonals.
pub const DIRS: [(i32, i32); 8] = [
    (1, 0),
    (0, 1),
    (-1, 0),
    (0, -1),
    (1, 1),
    (-1, 1),
    (-1, -1),
    (1, -1),
];

/// One walkable-floor candidate in a column.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Span {
    /// Floor height (m).
    pub y: f32,
    /// Free height above the floor up to the next solid (m; `f32::INFINITY` when open).
    pub headroom: f32,
    /// Distance (m) from the span centre to the nearest non-walkable edge.
    pub clearance: f32,
    /// Linked neighbour span per direction of [`DIRS`] (`NONE` when blocked).
    pub links: [u32; 8],
    /// The agent can stand here (cylinder fits, radius clear of obstacles).
    pub walkable: bool,
    /// Room index (into [`NavGrid::rooms`]), `NONE` outside rooms.
    pub room: u32,
    /// Island (connected component of walkable spans), `NONE` when not walkable.
    pub island: u32,
    /// Level index of the room (or of the nearest level below).
    pub level: u16,
}

/// A room as the grid knows it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NavRoom {
    /// Room id in the scene.
    pub id: String,
    /// MINOS class index (0–8).
    pub class: u8,
    /// Level index.
    pub level: u16,
}

/// An object the grid records spans under (doors, and everything above walkable floor).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NavObject {
    /// Instance id in the scene.
    pub id: String,
    /// Best category label.
    pub category: String,
    /// Is a door.
    pub door: bool,
    /// Is an arch.
    pub arch: bool,
    /// World box minimum.
    pub min: [f32; 3],
    /// World box maximum.
    pub max: [f32; 3],
}

/// A connected component of walkable spans.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Island {
    /// Walkable area (m²).
    pub area: f32,
    /// Largest distance (m, in XZ) of a span centre from the island's centroid.
    pub radius: f32,
    /// Number of spans.
    pub spans: u32,
    /// Centroid.
    pub centroid: [f32; 3],
}

/// The baked navigation grid of one scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NavGrid {
    /// Scene id.
    pub scene: String,
    /// Parameters it was built with.
    pub params: NavParams,
    /// World x of the grid's minimum corner.
    pub x0: f32,
    /// World z of the grid's minimum corner.
    pub z0: f32,
    /// Columns along x.
    pub nx: u32,
    /// Columns along z.
    pub nz: u32,
    /// Span index ranges per column (length `nx * nz + 1`).
    pub column_start: Vec<u32>,
    /// All spans, column by column.
    pub spans: Vec<Span>,
    /// Rooms referenced by spans.
    pub rooms: Vec<NavRoom>,
    /// Objects referenced by `span_objects`.
    pub objects: Vec<NavObject>,
    /// `(span, object)` pairs, sorted: the objects above each walkable span.
    pub span_objects: Vec<(u32, u32)>,
    /// Islands referenced by spans.
    pub islands: Vec<Island>,
    /// Floor height of each level.
    pub level_heights: Vec<f32>,
    /// Query structures stored with the grid in its `.nav` file (derived from the fields
    /// above at bake time and checked when read); empty for a grid built in memory or when
    /// the file's copy did not check out. Not part of the grid's identity (see [`Baked`]).
    #[serde(skip)]
    pub baked: Baked,
}

/// Query structures derived from a [`NavGrid`] at bake time and stored in its `.nav` file, so
/// that loading a grid for queries does not rebuild them. Derived data: grids compare equal
/// whatever they carry here, and every user falls back to building what is missing (or of
/// the wrong length).
#[derive(Debug, Clone, Default)]
pub struct Baked {
    /// Per span, the `los::SightIndex`'s side of the clear square ahead
    /// in each quadrant (empty when not stored).
    pub sight_squares: Vec<[u8; 4]>,
    /// The edges and landmark distances of the point-to-point search's sparse graph (see
    /// `geodesic`), when stored.
    pub sparse_edges: Option<SparseEdges>,
    /// The linear part of the sparse graph (areas, vertices, portals), when stored.
    pub sparse_labels: Option<SparseLabels>,
}

/// Flag of a [`SparseLabels::verts`] entry: the vertex is a gate of an uneven zone.
pub const SPARSE_GATE: u32 = 1 << 31;

/// The linear part of the sparse graph of point-to-point queries (`geodesic`), as a `.nav`
/// file stores it: what the plateau and zone labelling, the gates and the portals give. The
/// rest (roles, zone sizes, vertex cells and corners, portal boxes) is recomputed from these
/// and the grid; used only when [`SparseLabels::fits`] a grid of that many spans.
#[derive(Debug, Clone, PartialEq)]
pub struct SparseLabels {
    /// Per span: its region, `1 << 31` plus its zone, or `u32::MAX` when on neither.
    pub area: Vec<u32>,
    /// The vertices' spans in rising order, [`SPARSE_GATE`] added for gates.
    pub verts: Vec<u32>,
    /// Portals as (zone area, region area), in the order the graph numbers them.
    pub portals: Vec<(u32, u32)>,
    /// (portal, gate span) for every gate of every portal.
    pub portal_gates: Vec<(u32, u32)>,
}

impl SparseLabels {
    /// Do the lists fit a grid of `spans` spans: one area per span, zone numbers below the
    /// span count, vertex spans in range and strictly rising, portal gates naming a portal
    /// and a span in range, a gate for every portal? Linear in the size of the lists.
    pub fn fits(&self, spans: usize) -> bool {
        const IN_ZONE: u32 = 1 << 31;
        let zone_ok = |a: u32| a == NONE || a & IN_ZONE == 0 || ((a & !IN_ZONE) as usize) < spans;
        self.area.len() == spans
            && self.area.iter().all(|&a| zone_ok(a))
            && self
                .verts
                .iter()
                .all(|&v| ((v & !SPARSE_GATE) as usize) < spans)
            && self
                .verts
                .windows(2)
                .all(|w| w[0] & !SPARSE_GATE < w[1] & !SPARSE_GATE)
            && self
                .portal_gates
                .iter()
                .all(|&(k, s)| (k as usize) < self.portals.len() && (s as usize) < spans)
            && {
                // Every portal has a gate (its box is theirs).
                let mut gated = vec![false; self.portals.len()];
                for &(k, _) in &self.portal_gates {
                    if let Some(g) = gated.get_mut(k as usize) {
                        *g = true;
                    }
                }
                gated.iter().all(|&g| g)
            }
    }
}

/// Landmarks of the sparse graph's A* heuristic (`geodesic`).
pub const SPARSE_LANDMARKS: usize = 8;

/// The costly part of the sparse graph of point-to-point queries (`geodesic`): its edges
/// (straight walks between vertices) and the landmark distances. The vertices themselves
/// (obstacle corners and zone gates, in span order) come from the stored [`SparseLabels`]
/// or are recomputed from the grid when it is loaded; these lists are used only when they
/// fit that many vertices.
#[derive(Debug, Clone, PartialEq)]
pub struct SparseEdges {
    /// Edges of vertex `i`: `edges[first[i]..first[i + 1]]` (length: vertices + 1).
    pub first: Vec<u32>,
    /// `(vertex, length)` pairs.
    pub edges: Vec<(u32, f32)>,
    /// Per vertex: graph distances to the landmarks (`INFINITY` when not joined).
    pub marks: Vec<[f32; SPARSE_LANDMARKS]>,
}

impl SparseEdges {
    /// Do the lists describe a graph of `vertices` vertices: `first` rising from 0 to the
    /// number of edges, every edge to a vertex in range with a finite length of at least 0,
    /// landmark distances of at least 0 (or infinite)? Linear in the size of the lists.
    pub fn fits(&self, vertices: usize) -> bool {
        self.first.len() == vertices + 1
            && self.marks.len() == vertices
            && self.first.first() == Some(&0)
            && self.first.last().map(|&l| l as usize) == Some(self.edges.len())
            && self.first.windows(2).all(|w| w[0] <= w[1])
            && self
                .edges
                .iter()
                .all(|&(v, l)| (v as usize) < vertices && l.is_finite() && l >= 0.0)
            && self.marks.iter().flatten().all(|&d| d >= 0.0)
    }
}

impl PartialEq for Baked {
    /// Always true: derived data does not make two grids different.
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl NavGrid {
    /// Cell edge (m).
    pub fn cell(&self) -> f32 {
        self.params.cell_size
    }

    /// Column index of cell (ix, iz), if inside the grid.
    pub fn column(&self, ix: i64, iz: i64) -> Option<usize> {
        (ix >= 0 && iz >= 0 && ix < self.nx as i64 && iz < self.nz as i64)
            .then(|| iz as usize * self.nx as usize + ix as usize)
    }

    /// Span index range of a column.
    pub fn column_spans(&self, column: usize) -> std::ops::Range<usize> {
        self.column_start[column] as usize..self.column_start[column + 1] as usize
    }

    /// Cell coordinates of a world point (may be outside the grid).
    pub fn cell_of(&self, x: f32, z: f32) -> (i64, i64) {
        (
            ((x - self.x0) / self.cell()).floor() as i64,
            ((z - self.z0) / self.cell()).floor() as i64,
        )
    }

    /// Column of a span (binary search over `column_start`).
    pub fn column_of_span(&self, span: usize) -> usize {
        self.column_start.partition_point(|&s| s as usize <= span) - 1
    }

    /// World position of a span: the centre of its cell at floor height.
    pub fn span_position(&self, span: usize) -> Vec3 {
        let c = self.column_of_span(span);
        let (ix, iz) = (c % self.nx as usize, c / self.nx as usize);
        Vec3::new(
            self.x0 + (ix as f32 + 0.5) * self.cell(),
            self.spans[span].y,
            self.z0 + (iz as f32 + 0.5) * self.cell(),
        )
    }

    /// Objects recorded above a span.
    pub fn objects_above(&self, span: u32) -> impl Iterator<Item = &NavObject> {
        let start = self.span_objects.partition_point(|&(s, _)| s < span);
        self.span_objects[start..]
            .iter()
            .take_while(move |&&(s, _)| s == span)
            .map(|&(_, o)| &self.objects[o as usize])
    }

    /// Number of walkable spans.
    pub fn walkable_count(&self) -> usize {
        self.spans.iter().filter(|s| s.walkable).count()
    }
}
