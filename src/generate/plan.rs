//! The in-memory plan of a generated house: rooms as rectangles with openings, and placed
//! objects. Writers turn a plan into files; tests compare ingested scenes against it.

use crate::scene::RoomClass;

use super::catalog::{catalog, ModelSpec};

/// Half the thickness of an interior wall: each room owns the half on its side.
pub const WALL_T: f64 = 0.075;
/// Height of room walls (floor to ceiling).
pub const WALL_HEIGHT: f64 = 2.7;
/// Height of balcony railings.
pub const RAILING_HEIGHT: f64 = 1.1;

/// An axis-aligned rectangle in the XZ plane (metres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    /// Minimum x.
    pub x0: f64,
    /// Minimum z.
    pub z0: f64,
    /// Maximum x.
    pub x1: f64,
    /// Maximum z.
    pub z1: f64,
}

impl Rect {
    /// A rectangle from its bounds.
    pub fn new(x0: f64, z0: f64, x1: f64, z1: f64) -> Self {
        Rect { x0, z0, x1, z1 }
    }
    /// Extent along x.
    pub fn w(&self) -> f64 {
        self.x1 - self.x0
    }
    /// Extent along z.
    pub fn d(&self) -> f64 {
        self.z1 - self.z0
    }
    /// Area in m².
    pub fn area(&self) -> f64 {
        self.w() * self.d()
    }
    /// Grown by `m` on every side (shrunk when negative).
    pub fn inflate(&self, m: f64) -> Rect {
        Rect::new(self.x0 - m, self.z0 - m, self.x1 + m, self.z1 + m)
    }
    /// True when the interiors overlap with more than `gap` between them missing.
    pub fn overlaps(&self, o: &Rect, gap: f64) -> bool {
        self.x0 < o.x1 + gap && o.x0 < self.x1 + gap && self.z0 < o.z1 + gap && o.z0 < self.z1 + gap
    }
    /// True when `o` lies inside this rectangle.
    pub fn contains(&self, o: &Rect) -> bool {
        o.x0 >= self.x0 - 1e-9
            && o.x1 <= self.x1 + 1e-9
            && o.z0 >= self.z0 - 1e-9
            && o.z1 <= self.z1 + 1e-9
    }
    /// True when the point lies inside.
    pub fn contains_point(&self, x: f64, z: f64) -> bool {
        x >= self.x0 && x <= self.x1 && z >= self.z0 && z <= self.z1
    }
    /// This rectangle minus `hole`, as up to four rectangles.
    pub fn minus(&self, hole: &Rect) -> Vec<Rect> {
        let h = Rect::new(
            hole.x0.max(self.x0),
            hole.z0.max(self.z0),
            hole.x1.min(self.x1),
            hole.z1.min(self.z1),
        );
        if h.x0 >= h.x1 || h.z0 >= h.z1 {
            return vec![*self];
        }
        let mut out = Vec::new();
        if h.z0 > self.z0 {
            out.push(Rect::new(self.x0, self.z0, self.x1, h.z0));
        }
        if h.z1 < self.z1 {
            out.push(Rect::new(self.x0, h.z1, self.x1, self.z1));
        }
        if h.x0 > self.x0 {
            out.push(Rect::new(self.x0, h.z0, h.x0, h.z1));
        }
        if h.x1 < self.x1 {
            out.push(Rect::new(h.x1, h.z0, self.x1, h.z1));
        }
        out
    }
}

/// A side of a room rectangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// The x = x0 side.
    MinX,
    /// The x = x1 side.
    MaxX,
    /// The z = z0 side.
    MinZ,
    /// The z = z1 side.
    MaxZ,
}

impl Side {
    /// All four sides.
    pub const ALL: [Side; 4] = [Side::MinX, Side::MaxX, Side::MinZ, Side::MaxZ];

    /// Quarter turns that make a model's front (+Z) face away from this wall into the room.
    pub fn facing_in(self) -> u8 {
        match self {
            Side::MinZ => 0,
            Side::MinX => 1,
            Side::MaxZ => 2,
            Side::MaxX => 3,
        }
    }

    /// True for sides that run along x (their position is a z value).
    pub fn along_x(self) -> bool {
        matches!(self, Side::MinZ | Side::MaxZ)
    }
}

/// What fills an opening.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OpeningKind {
    /// A door; `open` tells whether its leaf lets the agent through.
    Door {
        /// Open (passable) or closed.
        open: bool,
    },
    /// An arch (no leaf).
    Arch,
    /// A window.
    Window,
}

/// A hole in one wall of a room.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Opening {
    /// The wall.
    pub side: Side,
    /// Start along the wall (x for sides along x, else z).
    pub u0: f64,
    /// End along the wall.
    pub u1: f64,
    /// Bottom above the room's floor.
    pub y0: f64,
    /// Top above the room's floor.
    pub y1: f64,
    /// What fills it.
    pub kind: OpeningKind,
}

/// A room of the plan.
#[derive(Debug, Clone, PartialEq)]
pub struct RoomPlan {
    /// Outline (walls lie inside it).
    pub rect: Rect,
    /// SUNCG room type written to `roomTypes`.
    pub raw_type: &'static str,
    /// The MINOS class of that type.
    pub class: RoomClass,
    /// Wall height (railing height for balconies).
    pub wall_height: f64,
    /// Written with `hideCeiling: 1` (balconies).
    pub hide_ceiling: bool,
    /// Door, arch and window openings in its walls.
    pub openings: Vec<Opening>,
    /// Holes in the floor (stairwells).
    pub floor_holes: Vec<Rect>,
    /// Holes in the ceiling (stairwells).
    pub ceiling_holes: Vec<Rect>,
}

impl RoomPlan {
    /// The boxes `(min, max)` of the wall on one side, with the openings cut out: each room owns
    /// the half of a wall (thickness [`WALL_T`]) on its side of the boundary.
    pub fn wall_boxes(&self, side: Side, base: f64) -> Vec<([f64; 3], [f64; 3])> {
        let r = self.rect;
        let h = self.wall_height;
        let (u_start, u_end) = if side.along_x() {
            (r.x0, r.x1)
        } else {
            (r.z0, r.z1)
        };
        let openings: Vec<_> = self.openings.iter().filter(|o| o.side == side).collect();
        let mut cuts = vec![u_start, u_end];
        for o in &openings {
            cuts.push(o.u0.clamp(u_start, u_end));
            cuts.push(o.u1.clamp(u_start, u_end));
        }
        cuts.sort_by(f64::total_cmp);
        cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        let mut out = Vec::new();
        for w in cuts.windows(2) {
            let (a, b) = (w[0], w[1]);
            let mut holes: Vec<(f64, f64)> = openings
                .iter()
                .filter(|o| o.u0 <= a + 1e-9 && o.u1 >= b - 1e-9)
                .map(|o| (o.y0.max(0.0), o.y1.min(h)))
                .filter(|(y0, y1)| y1 > y0)
                .collect();
            holes.sort_by(|x, y| x.0.total_cmp(&y.0));
            let mut y = 0.0;
            let mut solid = Vec::new();
            for (y0, y1) in holes {
                if y0 > y {
                    solid.push((y, y0));
                }
                y = y.max(y1);
            }
            if y < h {
                solid.push((y, h));
            }
            for (y0, y1) in solid {
                out.push(match side {
                    Side::MinX => ([r.x0, base + y0, a], [r.x0 + WALL_T, base + y1, b]),
                    Side::MaxX => ([r.x1 - WALL_T, base + y0, a], [r.x1, base + y1, b]),
                    Side::MinZ => ([a, base + y0, r.z0], [b, base + y1, r.z0 + WALL_T]),
                    Side::MaxZ => ([a, base + y0, r.z1 - WALL_T], [b, base + y1, r.z1]),
                });
            }
        }
        out
    }
}

/// An object placed in a level.
#[derive(Debug, Clone, PartialEq)]
pub struct PlacedObject {
    /// Index of the model in the catalog.
    pub model: usize,
    /// World position of the model's origin (centre of its footprint, at its base).
    pub pos: [f64; 3],
    /// Rotation about +Y in quarter turns (counter-clockwise).
    pub quarter_turns: u8,
    /// Mirrored along the model's x axis (negative determinant).
    pub mirrored: bool,
    /// Indices of the rooms it belongs to.
    pub rooms: Vec<usize>,
    /// Per-instance diffuse colours of material slots (`None`: the model's own).
    pub colors: Vec<Option<[f64; 3]>>,
}

impl PlacedObject {
    /// The model.
    pub fn spec(&self) -> &'static ModelSpec {
        &catalog().models[self.model]
    }

    /// Column-major 4×4 model-to-world transform (exact for quarter turns).
    pub fn transform(&self) -> [f64; 16] {
        let (c, s) = match self.quarter_turns % 4 {
            0 => (1.0, 0.0),
            1 => (0.0, 1.0),
            2 => (-1.0, 0.0),
            _ => (0.0, -1.0),
        };
        let m = if self.mirrored { -1.0 } else { 1.0 };
        // R_y(θ) · diag(m, 1, 1), then translation.
        [
            c * m,
            0.0,
            -s * m,
            0.0, //
            0.0,
            1.0,
            0.0,
            0.0, //
            s,
            0.0,
            c,
            0.0, //
            self.pos[0],
            self.pos[1],
            self.pos[2],
            1.0,
        ]
    }

    /// Maps a model-space point to the world.
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let t = self.transform();
        [
            t[0] * p[0] + t[4] * p[1] + t[8] * p[2] + t[12],
            t[1] * p[0] + t[5] * p[1] + t[9] * p[2] + t[13],
            t[2] * p[0] + t[6] * p[1] + t[10] * p[2] + t[14],
        ]
    }

    /// World box `(min, max)` of the placed model.
    pub fn world_box(&self) -> ([f64; 3], [f64; 3]) {
        let spec = self.spec();
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &spec.parts {
            for i in 0..8 {
                let c = [
                    if i & 1 == 0 { p.min[0] } else { p.max[0] },
                    if i & 2 == 0 { p.min[1] } else { p.max[1] },
                    if i & 4 == 0 { p.min[2] } else { p.max[2] },
                ];
                let w = self.apply(c);
                for a in 0..3 {
                    lo[a] = lo[a].min(w[a]);
                    hi[a] = hi[a].max(w[a]);
                }
            }
        }
        (lo, hi)
    }

    /// The footprint on the floor.
    pub fn footprint(&self) -> Rect {
        let (lo, hi) = self.world_box();
        Rect::new(lo[0], lo[2], hi[0], hi[2])
    }
}

/// One level of the plan.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelPlan {
    /// Floor height of the level.
    pub base_y: f64,
    /// Rooms.
    pub rooms: Vec<RoomPlan>,
    /// Objects (furniture, doors, arches, windows, stairs).
    pub objects: Vec<PlacedObject>,
    /// Outdoor ground around the house (level 0 only).
    pub ground: Option<Rect>,
}

/// A whole generated house.
#[derive(Debug, Clone, PartialEq)]
pub struct HousePlan {
    /// House id (32 hex digits, like SUNCG's).
    pub id: String,
    /// Levels from the bottom up.
    pub levels: Vec<LevelPlan>,
}

impl HousePlan {
    /// Number of rooms over all levels.
    pub fn room_count(&self) -> usize {
        self.levels.iter().map(|l| l.rooms.len()).sum()
    }
    /// Number of objects over all levels.
    pub fn object_count(&self) -> usize {
        self.levels.iter().map(|l| l.objects.len()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rect_minus_hole_covers_the_rest_exactly() {
        let r = Rect::new(0.0, 0.0, 4.0, 10.0);
        let hole = Rect::new(0.0, 2.0, 1.5, 7.0);
        let parts = r.minus(&hole);
        let area: f64 = parts.iter().map(Rect::area).sum();
        assert!((area - (40.0 - 7.5)).abs() < 1e-9);
        assert!(parts.iter().all(|p| !p.overlaps(&hole, -1e-9)));
    }

    #[test]
    fn quarter_turns_face_models_into_the_room() {
        // A model against the MaxX wall must face -X.
        let o = PlacedObject {
            model: 0,
            pos: [0.0; 3],
            quarter_turns: Side::MaxX.facing_in(),
            mirrored: false,
            rooms: vec![],
            colors: vec![],
        };
        let front = o.apply([0.0, 0.0, 1.0]);
        assert!((front[0] + 1.0).abs() < 1e-12 && front[2].abs() < 1e-12);
        let o = PlacedObject {
            quarter_turns: Side::MinX.facing_in(),
            ..o
        };
        assert!((o.apply([0.0, 0.0, 1.0])[0] - 1.0).abs() < 1e-12);
    }
}
