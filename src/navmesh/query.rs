//! Point queries on a baked grid: snapping a world point to the nearest walkable span,
//! walkability, islands, goal sets (a room's spans, the spans near an object) and seeded
//! uniform sampling of walkable points.

use glam::Vec3;

use crate::seed::Rng;

use super::grid::{NavGrid, NONE};

/// How far (m) [`NavGrid::snap`] looks around a point.
pub const SNAP_RADIUS: f32 = 2.0;

impl NavGrid {
    /// The walkable span of the column under `p` whose floor is closest to `p.y`, if any
    /// (the agent stands there: `p.y` is the floor height under it).
    pub fn span_at(&self, p: Vec3) -> Option<u32> {
        let (ix, iz) = self.cell_of(p.x, p.z);
        let c = self.column(ix, iz)?;
        self.column_spans(c)
            .filter(|&s| self.spans[s].walkable)
            .min_by(|&a, &b| {
                (self.spans[a].y - p.y)
                    .abs()
                    .total_cmp(&(self.spans[b].y - p.y).abs())
            })
            .filter(|&s| (self.spans[s].y - p.y).abs() <= self.params.body.height)
            .map(|s| s as u32)
    }

    /// True when an agent standing at `p` (y = floor height) is on walkable floor.
    pub fn is_walkable(&self, p: Vec3) -> bool {
        self.span_at(p)
            .is_some_and(|s| (self.spans[s as usize].y - p.y).abs() <= self.params.body.max_climb)
    }

    /// The nearest walkable span to `p` within [`SNAP_RADIUS`] (3D distance between `p` and
    /// span positions), searched ring by ring.
    pub fn snap(&self, p: Vec3) -> Option<u32> {
        let (cx, cz) = self.cell_of(p.x, p.z);
        let rings = (SNAP_RADIUS / self.cell()).ceil() as i64;
        let mut best: Option<(f32, u32)> = None;
        for r in 0..=rings {
            // Once a hit is closer than anything the next ring can hold, stop.
            if let Some((d, _)) = best {
                if d < (r as f32 - 1.0).max(0.0) * self.cell() {
                    break;
                }
            }
            for iz in cz - r..=cz + r {
                for ix in cx - r..=cx + r {
                    if (iz - cz).abs() != r && (ix - cx).abs() != r {
                        continue;
                    }
                    let Some(c) = self.column(ix, iz) else {
                        continue;
                    };
                    // The column's centre, as `span_position` computes it (without its
                    // search for the column).
                    let (x, z) = (
                        self.x0 + (ix as f32 + 0.5) * self.cell(),
                        self.z0 + (iz as f32 + 0.5) * self.cell(),
                    );
                    for s in self.column_spans(c) {
                        if !self.spans[s].walkable {
                            continue;
                        }
                        let d = Vec3::new(x, self.spans[s].y, z).distance(p);
                        if d <= SNAP_RADIUS
                            && best.is_none_or(|(bd, bs)| d < bd || (d == bd && (s as u32) < bs))
                        {
                            best = Some((d, s as u32));
                        }
                    }
                }
            }
        }
        best.map(|(_, s)| s)
    }

    /// Island of the walkable span nearest to `p`.
    pub fn island_of(&self, p: Vec3) -> Option<u32> {
        self.snap(p)
            .map(|s| self.spans[s as usize].island)
            .filter(|&i| i != NONE)
    }

    /// Walkable spans of a room (goal set of a RoomGoal).
    pub fn room_spans(&self, room: u32) -> Vec<u32> {
        (0..self.spans.len() as u32)
            .filter(|&s| self.spans[s as usize].walkable && self.spans[s as usize].room == room)
            .collect()
    }

    /// Walkable spans within `radius` (m, in XZ) of an object's box and within the agent's
    /// height of it vertically: where an agent can stand "at" the object.
    pub fn object_spans(&self, object: u32, radius: f32) -> Vec<u32> {
        let Some(o) = self.objects.get(object as usize) else {
            return Vec::new();
        };
        let (ix0, iz0) = self.cell_of(o.min[0] - radius, o.min[2] - radius);
        let (ix1, iz1) = self.cell_of(o.max[0] + radius, o.max[2] + radius);
        let mut out = Vec::new();
        for iz in iz0..=iz1 {
            for ix in ix0..=ix1 {
                let Some(c) = self.column(ix, iz) else {
                    continue;
                };
                for s in self.column_spans(c) {
                    let span = &self.spans[s];
                    if !span.walkable
                        || span.y > o.max[1] + self.params.body.max_climb
                        || span.y + self.params.body.height < o.min[1]
                    {
                        continue;
                    }
                    let p = self.span_position(s);
                    let dx = (o.min[0] - p.x).max(0.0).max(p.x - o.max[0]);
                    let dz = (o.min[2] - p.z).max(0.0).max(p.z - o.max[2]);
                    if (dx * dx + dz * dz).sqrt() <= radius {
                        out.push(s as u32);
                    }
                }
            }
        }
        out
    }

    /// Walkable spans, of one island or of all.
    pub fn walkable_spans(&self, island: Option<u32>) -> Vec<u32> {
        (0..self.spans.len() as u32)
            .filter(|&s| {
                let span = &self.spans[s as usize];
                span.walkable && island.is_none_or(|i| span.island == i)
            })
            .collect()
    }

    /// A point drawn uniformly by area from `candidates` (walkable spans, e.g. from
    /// [`NavGrid::walkable_spans`]): a uniform span, then a uniform offset within its cell.
    pub fn random_point_from(&self, rng: &mut Rng, candidates: &[u32]) -> Option<(u32, Vec3)> {
        let &s = rng.pick(candidates)?;
        let c = self.span_position(s as usize);
        let h = 0.5 * f64::from(self.cell());
        let p = Vec3::new(
            c.x + rng.range_f64(-h, h) as f32,
            c.y,
            c.z + rng.range_f64(-h, h) as f32,
        );
        Some((s, p))
    }

    /// A walkable point drawn uniformly by area, on `island` when given (builds the candidate
    /// list: samplers drawing many points keep [`NavGrid::walkable_spans`] and call
    /// [`NavGrid::random_point_from`]).
    pub fn random_point(&self, rng: &mut Rng, island: Option<u32>) -> Option<(u32, Vec3)> {
        self.random_point_from(rng, &self.walkable_spans(island))
    }
}
