//! The mesh of a house written in Matterport3D's layout, as it is built: labelled quads
//! (floors, ceilings, walls with their openings, model parts; each with a `category_id`, a
//! `segment_id` and its kind), the segments' boxes, and the triangles the PLY receives —
//! as they stand ([`MeshOut::plain`]) or tessellated as a scan ([`super::scan`]). Written
//! z-up (`(x, y, z)_y-up → (x, −z, y)`).

use std::collections::HashMap;

use super::plan::Rect;

/// y-up → z-up.
pub(super) fn zup(p: [f64; 3]) -> [f64; 3] {
    [p[0], -p[2], p[1]]
}

/// A z-up box from two y-up corners.
pub(super) fn zbox(a: [f64; 3], b: [f64; 3]) -> [f64; 6] {
    let (a, b) = (zup(a), zup(b));
    [
        a[0].min(b[0]),
        a[1].min(b[1]),
        a[2].min(b[2]),
        a[0].max(b[0]),
        a[1].max(b[1]),
        a[2].max(b[2]),
    ]
}

/// What a quad of the written mesh is (scan tessellation treats them differently).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum QuadKind {
    /// Floors and stairs: walked on, never holed.
    Floor,
    /// Ceilings.
    Ceiling,
    /// Walls.
    Wall,
    /// Furniture, doors, windows, clutter.
    Object,
}

/// One quad of the mesh, counter-clockwise seen from its front, in y-up coordinates.
#[derive(Debug, Clone, Copy)]
pub(super) struct Quad {
    /// Corners; `c[2] = c[1] + c[3] − c[0]` (every quad written is a rectangle).
    pub(super) c: [[f64; 3]; 4],
    /// `category_id` of its faces.
    pub(super) category: i32,
    /// `segment_id` of its faces (ids from 100000 are objects: `id − 100000`).
    pub(super) segment: i32,
    /// What it is.
    pub(super) kind: QuadKind,
}

/// An `E` record: a segment, the object it belongs to (`-1`: none), its area and z-up box.
#[derive(Debug, Clone, Copy)]
pub(super) struct SegmentRec {
    pub(super) id: i32,
    pub(super) object: i64,
    pub(super) area: f64,
    pub(super) bbox: [f64; 6],
}

/// The mesh to write: triangles with `[material, segment, category]` labels, and its segments.
#[derive(Debug, Default)]
pub(super) struct MeshData {
    pub(super) positions: Vec<[f32; 3]>,
    pub(super) triangles: Vec<[u32; 3]>,
    pub(super) labels: Vec<[i32; 3]>,
    /// Sorted by id.
    pub(super) segments: Vec<SegmentRec>,
}

/// An empty z-up box, to be grown.
pub(super) const EMPTY_BOX: [f64; 6] = [
    f64::INFINITY,
    f64::INFINITY,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::NEG_INFINITY,
    f64::NEG_INFINITY,
];

/// Grows a z-up box by a y-up point.
pub(super) fn grow(b: &mut [f64; 6], p: [f64; 3]) {
    for (k, v) in zup(p).into_iter().enumerate() {
        b[k] = b[k].min(v);
        b[k + 3] = b[k + 3].max(v);
    }
}

/// The object of a segment id of the plain mesh.
pub(super) fn segment_object(id: i32) -> i64 {
    if id >= 100_000 {
        i64::from(id - 100_000)
    } else {
        -1
    }
}

/// The quads being written, with per-segment areas and boxes.
#[derive(Default)]
pub(super) struct MeshOut {
    pub(super) quads: Vec<Quad>,
    /// Per segment id: area and z-up box.
    segments: HashMap<i32, (f64, [f64; 6])>,
}

impl MeshOut {
    /// A quad given counter-clockwise seen from its front, in y-up coordinates.
    fn quad(&mut self, c: [[f64; 3]; 4], category: i32, segment: i32, kind: QuadKind) {
        self.quads.push(Quad {
            c,
            category,
            segment,
            kind,
        });
        let area = 0.5
            * (len3(cross3(sub3(c[1], c[0]), sub3(c[2], c[0])))
                + len3(cross3(sub3(c[2], c[0]), sub3(c[3], c[0]))));
        let e = self.segments.entry(segment).or_insert((0.0, EMPTY_BOX));
        e.0 += area;
        for p in c {
            grow(&mut e.1, p);
        }
    }

    /// A closed axis-aligned box (y-up), faces counter-clockwise seen from outside.
    pub(super) fn aabox(
        &mut self,
        min: [f64; 3],
        max: [f64; 3],
        category: i32,
        segment: i32,
        kind: QuadKind,
    ) {
        let v = |k: usize| crate::scene::box_corner(min, max, k);
        for f in crate::scene::BOX_FACES {
            self.quad(
                [v(f[0]), v(f[1]), v(f[2]), v(f[3])],
                category,
                segment,
                kind,
            );
        }
    }

    /// A horizontal rectangle at height `y`, facing up or down.
    pub(super) fn flat(
        &mut self,
        r: &Rect,
        y: f64,
        up: bool,
        category: i32,
        segment: i32,
        kind: QuadKind,
    ) {
        let c = [
            [r.x0, y, r.z0],
            [r.x0, y, r.z1],
            [r.x1, y, r.z1],
            [r.x1, y, r.z0],
        ];
        if up {
            self.quad(c, category, segment, kind);
        } else {
            self.quad([c[0], c[3], c[2], c[1]], category, segment, kind);
        }
    }

    /// Two triangles per quad, in quad order; one segment per segment id.
    pub(super) fn plain(&self) -> MeshData {
        let mut out = MeshData::default();
        for q in &self.quads {
            let base = out.positions.len() as u32;
            for p in q.c {
                let z = zup(p);
                out.positions.push([z[0] as f32, z[1] as f32, z[2] as f32]);
            }
            for t in [[0, 1, 2], [0, 2, 3]] {
                out.triangles.push([base + t[0], base + t[1], base + t[2]]);
                out.labels.push([0, q.segment, q.category]);
            }
        }
        let mut ids: Vec<i32> = self.segments.keys().copied().collect();
        ids.sort_unstable();
        out.segments = ids
            .into_iter()
            .map(|id| {
                let (area, bbox) = self.segments[&id];
                SegmentRec {
                    id,
                    object: segment_object(id),
                    area,
                    bbox,
                }
            })
            .collect();
        out
    }
}

pub(super) fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(super) fn cross3(u: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

pub(super) fn len3(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}
