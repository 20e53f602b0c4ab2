//! Furniture placement: per room type, a recipe of models placed against walls, in the
//! middle, around tables or on top of other furniture, without interpenetration, outside the
//! door zones, and keeping the room walkable (every doorway reachable by an agent of radius
//! 0.2 m over at least 40% of the floor).

use crate::scene::RoomClass;
use crate::seed::Rng;

use super::catalog::catalog;
use super::layout::keep_outs;
use super::plan::{LevelPlan, PlacedObject, Rect, Side, WALL_T};
use super::Furnishing;

const GRID: f64 = 0.1;
const AGENT_CLEARANCE: f64 = 0.2;
const MIN_FREE_FRACTION: f64 = 0.4;
/// [`Furnishing::Dense`] adds pieces until at most this fraction of a room's floor is free.
const DENSE_FREE_FRACTION: f64 = 0.42;
/// [`Furnishing::Dense`] stops after this many extra pieces in a row found no place.
const DENSE_MISSES: usize = 8;

/// Places furniture in every room of a level.
pub fn furnish_level(rng: &mut Rng, level: &mut LevelPlan, furnishing: Furnishing) {
    for room in 0..level.rooms.len() {
        let zones = keep_outs(level, room);
        let r = &level.rooms[room];
        let mut p = Placer {
            interior: r.rect.inflate(-WALL_T),
            keep_outs: zones.clone(),
            door_zones: zones,
            placed: Vec::new(),
            objects: Vec::new(),
            base_y: level.base_y,
            room,
        };
        recipe(
            rng,
            &mut p,
            r.class,
            r.raw_type,
            !r.floor_holes.is_empty() || !r.ceiling_holes.is_empty(),
        );
        if furnishing == Furnishing::Dense {
            clutter(rng, &mut p, r.class);
        }
        level.objects.extend(p.objects);
    }
}

fn recipe(rng: &mut Rng, p: &mut Placer, class: RoomClass, raw: &str, stair_hall: bool) {
    let maybe = |rng: &mut Rng, prob: f64| rng.chance(prob);
    match class {
        RoomClass::Bedroom => {
            let bed = if raw == "Bedroom" || maybe(rng, 0.4) {
                "double_bed"
            } else {
                "single_bed"
            };
            if let Some(b) = p.against_wall(rng, bed) {
                for _ in 0..rng.range_usize(1, 2) {
                    if let Some(s) = p.beside(rng, b, "stand") {
                        if maybe(rng, 0.6) {
                            p.on_top(rng, s, "table_lamp");
                        }
                    }
                }
            }
            if maybe(rng, 0.8) {
                p.against_wall(rng, "wardrobe_cabinet");
            }
            if maybe(rng, 0.4) {
                p.against_wall(rng, "dresser");
            }
            if maybe(rng, 0.3) {
                desk_with_chair(rng, p);
            }
            if maybe(rng, 0.3) {
                p.against_wall(rng, "plant");
            }
        }
        RoomClass::LivingRoom => {
            p.against_wall(rng, "sofa");
            if maybe(rng, 0.8) {
                if let Some(t) = p.in_middle(rng, "coffee_table") {
                    if maybe(rng, 0.3) {
                        p.on_top(rng, t, "candle");
                    }
                }
            }
            for _ in 0..rng.range_usize(0, 2) {
                p.against_wall(rng, "armchair");
            }
            if maybe(rng, 0.8) {
                if let Some(s) = p.against_wall(rng, "tv_stand") {
                    p.on_top(rng, s, "television");
                }
            }
            if maybe(rng, 0.6) {
                p.against_wall(rng, "bookshelf");
            }
            if maybe(rng, 0.5) {
                p.against_wall(rng, "floor_lamp");
            }
            if maybe(rng, 0.6) {
                p.against_wall(rng, "plant");
            }
            if maybe(rng, 0.15) {
                p.in_middle(rng, "person");
            }
        }
        RoomClass::Kitchen => {
            p.against_wall(rng, "refrigerator");
            p.against_wall(rng, "range_oven");
            p.against_wall(rng, "sink");
            for _ in 0..rng.range_usize(2, 4) {
                p.against_wall(rng, "kitchen_cabinet");
            }
            if maybe(rng, 0.4) {
                dining_set(rng, p, 2);
            }
        }
        RoomClass::DiningRoom => {
            dining_set(rng, p, 6);
            if maybe(rng, 0.3) {
                p.against_wall(rng, "bookshelf");
            }
            if maybe(rng, 0.4) {
                p.against_wall(rng, "plant");
            }
        }
        RoomClass::Bathroom => {
            p.against_wall(rng, "toilet");
            p.against_wall(rng, "sink");
            if raw != "Toilet" {
                if maybe(rng, 0.5) {
                    p.against_wall(rng, "bathtub");
                } else {
                    p.against_wall(rng, "shower");
                }
            }
        }
        RoomClass::Office => {
            desk_with_chair(rng, p);
            for _ in 0..rng.range_usize(1, 2) {
                p.against_wall(rng, "bookshelf");
            }
            if maybe(rng, 0.3) {
                p.against_wall(rng, "armchair");
            }
            if maybe(rng, 0.5) {
                p.against_wall(rng, "plant");
            }
        }
        RoomClass::Hallway => {
            if !stair_hall && maybe(rng, 0.5) {
                p.against_wall(rng, "shoes_cabinet");
            }
            if maybe(rng, 0.4) {
                p.against_wall(rng, "plant");
            }
        }
        RoomClass::Outdoor => {
            for _ in 0..rng.range_usize(1, 2) {
                p.in_middle(rng, "outdoor_seating");
            }
            if maybe(rng, 0.5) {
                p.against_wall(rng, "plant");
            }
        }
        RoomClass::Other => {
            for _ in 0..rng.range_usize(1, 3) {
                p.against_wall(rng, "bookshelf");
            }
            if maybe(rng, 0.4) {
                p.against_wall(rng, "wardrobe_cabinet");
            }
        }
    }
}

/// Extra pieces of a room class's kinds of furniture (`true`: in the middle of the room, else
/// against a wall) until the room's free floor is down to [`DENSE_FREE_FRACTION`].
fn clutter(rng: &mut Rng, p: &mut Placer, class: RoomClass) {
    let extras: &[(&str, bool)] = match class {
        RoomClass::Bedroom => &[
            ("dresser", false),
            ("wardrobe_cabinet", false),
            ("bookshelf", false),
            ("armchair", false),
            ("stand", false),
            ("plant", false),
            ("desk", false),
        ],
        RoomClass::LivingRoom => &[
            ("armchair", false),
            ("armchair", true),
            ("bookshelf", false),
            ("stand", false),
            ("plant", false),
            ("coffee_table", true),
            ("sofa", true),
        ],
        RoomClass::Kitchen => &[
            ("kitchen_cabinet", false),
            ("kitchen_cabinet", false),
            ("dining_table", true),
            ("chair", true),
            ("plant", false),
        ],
        RoomClass::DiningRoom => &[
            ("bookshelf", false),
            ("kitchen_cabinet", false),
            ("chair", false),
            ("plant", false),
        ],
        RoomClass::Bathroom => &[("sink", false), ("shoes_cabinet", false), ("plant", false)],
        RoomClass::Office => &[
            ("bookshelf", false),
            ("desk", false),
            ("office_chair", true),
            ("armchair", false),
            ("plant", false),
        ],
        RoomClass::Hallway => &[("shoes_cabinet", false), ("plant", false), ("stand", false)],
        RoomClass::Outdoor => &[("outdoor_seating", true), ("plant", false)],
        RoomClass::Other => &[
            ("bookshelf", false),
            ("wardrobe_cabinet", false),
            ("dresser", false),
        ],
    };
    let mut misses = 0;
    while misses < DENSE_MISSES && p.free_fraction() > DENSE_FREE_FRACTION {
        let Some(&(fine, middle)) = rng.pick(extras) else {
            return;
        };
        let placed = if middle {
            p.in_middle(rng, fine)
        } else {
            p.against_wall(rng, fine)
        };
        misses = if placed.is_some() { 0 } else { misses + 1 };
    }
}

fn desk_with_chair(rng: &mut Rng, p: &mut Placer) {
    if let Some(d) = p.against_wall(rng, "desk") {
        p.in_front(rng, d, "office_chair");
    }
}

fn dining_set(rng: &mut Rng, p: &mut Placer, max_chairs: usize) {
    if let Some(t) = p.in_middle(rng, "dining_table") {
        p.around(rng, t, "chair", max_chairs);
        if rng.chance(0.5) {
            p.on_top(rng, t, "candle");
        }
    }
}

/// Placement state of one room.
struct Placer {
    interior: Rect,
    keep_outs: Vec<Rect>,
    door_zones: Vec<Rect>,
    /// Footprints of floor-standing objects (index into `objects`).
    placed: Vec<(Rect, usize)>,
    objects: Vec<PlacedObject>,
    base_y: f64,
    room: usize,
}

impl Placer {
    fn new_object(
        &self,
        rng: &mut Rng,
        fine: &str,
        pos: [f64; 3],
        turns: u8,
    ) -> Option<PlacedObject> {
        let options = catalog().of(fine);
        let model = *rng.pick(options)?;
        let spec = &catalog().models[model];
        // Symmetric furniture is sometimes mirrored, as in SUNCG.
        let mirrored =
            matches!(fine, "chair" | "dining_table" | "coffee_table" | "stand") && rng.chance(0.2);
        let colors = spec
            .materials
            .iter()
            .enumerate()
            .map(|(slot, m)| {
                (slot == 0 && m.alpha >= 1.0 && rng.chance(0.3)).then(|| {
                    let k = rng.range_f64(0.8, 1.1);
                    [
                        (m.rgb[0] * k).min(1.0),
                        (m.rgb[1] * k).min(1.0),
                        (m.rgb[2] * k).min(1.0),
                    ]
                })
            })
            .collect();
        Some(PlacedObject {
            model,
            pos,
            quarter_turns: turns,
            mirrored,
            rooms: vec![self.room],
            colors,
        })
    }

    /// Accepts `obj` if it fits the room, avoids zones and furniture, and keeps it walkable.
    fn try_add(&mut self, obj: PlacedObject, on_floor: bool) -> Option<usize> {
        let fp = obj.footprint();
        if on_floor {
            if !self.interior.contains(&fp)
                || self.keep_outs.iter().any(|k| k.overlaps(&fp, 0.0))
                || self.placed.iter().any(|(r, _)| r.overlaps(&fp, 0.05))
            {
                return None;
            }
            self.placed.push((fp, self.objects.len()));
            if !self.walkable() {
                self.placed.pop();
                return None;
            }
        }
        self.objects.push(obj);
        Some(self.objects.len() - 1)
    }

    fn against_wall(&mut self, rng: &mut Rng, fine: &str) -> Option<usize> {
        let options = catalog().of(fine);
        let model = *rng.pick(options)?;
        let size = catalog().models[model].size;
        for _ in 0..24 {
            let side = Side::ALL[rng.below(4)];
            let turns = side.facing_in();
            let (w, d) = (size[0], size[2]);
            let i = self.interior;
            let gap = 0.02;
            let pos = match side {
                Side::MinZ | Side::MaxZ => {
                    if i.w() < w + 0.1 {
                        continue;
                    }
                    let x = rng.range_f64(i.x0 + w / 2.0 + 0.05, i.x1 - w / 2.0 - 0.05);
                    let z = if side == Side::MinZ {
                        i.z0 + d / 2.0 + gap
                    } else {
                        i.z1 - d / 2.0 - gap
                    };
                    [x, z]
                }
                Side::MinX | Side::MaxX => {
                    if i.d() < w + 0.1 {
                        continue;
                    }
                    let z = rng.range_f64(i.z0 + w / 2.0 + 0.05, i.z1 - w / 2.0 - 0.05);
                    let x = if side == Side::MinX {
                        i.x0 + d / 2.0 + gap
                    } else {
                        i.x1 - d / 2.0 - gap
                    };
                    [x, z]
                }
            };
            let mut obj = self.new_object(
                rng,
                fine,
                [round(pos[0]), self.base_y, round(pos[1])],
                turns,
            )?;
            obj.model = model;
            if let Some(k) = self.try_add(obj, true) {
                return Some(k);
            }
        }
        None
    }

    fn in_middle(&mut self, rng: &mut Rng, fine: &str) -> Option<usize> {
        for _ in 0..24 {
            let i = self.interior.inflate(-0.7);
            if i.w() <= 0.0 || i.d() <= 0.0 {
                return None;
            }
            let pos = [
                round(rng.range_f64(i.x0, i.x1)),
                self.base_y,
                round(rng.range_f64(i.z0, i.z1)),
            ];
            let turns = rng.below(4) as u8;
            let obj = self.new_object(rng, fine, pos, turns)?;
            if let Some(k) = self.try_add(obj, true) {
                return Some(k);
            }
        }
        None
    }

    /// Next to a wall-backed object, along the same wall.
    fn beside(&mut self, rng: &mut Rng, anchor: usize, fine: &str) -> Option<usize> {
        let a = self.objects[anchor].clone();
        let fp = a.footprint();
        let options = catalog().of(fine);
        let model = *rng.pick(options)?;
        let size = catalog().models[model].size;
        let (w, d) = (size[0], size[2]);
        // Back of the anchor: the wall it stands against.
        let back = a.apply([0.0, 0.0, -a.spec().size[2] / 2.0]);
        let front_dir = {
            let f = a.apply([0.0, 0.0, 1.0]);
            [f[0] - a.pos[0], f[2] - a.pos[2]]
        };
        let mut sides = [-1.0, 1.0];
        rng.shuffle(&mut sides);
        for s in sides {
            let pos = if front_dir[0].abs() > 0.5 {
                // Anchor faces ±X: neighbours sit along z.
                let z = if s < 0.0 {
                    fp.z0 - w / 2.0 - 0.05
                } else {
                    fp.z1 + w / 2.0 + 0.05
                };
                [back[0] + front_dir[0] * d / 2.0, z]
            } else {
                let x = if s < 0.0 {
                    fp.x0 - w / 2.0 - 0.05
                } else {
                    fp.x1 + w / 2.0 + 0.05
                };
                [x, back[2] + front_dir[1] * d / 2.0]
            };
            let mut obj = self.new_object(
                rng,
                fine,
                [round(pos[0]), self.base_y, round(pos[1])],
                a.quarter_turns,
            )?;
            obj.model = model;
            if let Some(k) = self.try_add(obj, true) {
                return Some(k);
            }
        }
        None
    }

    /// In front of an object, facing it (a chair at a desk).
    fn in_front(&mut self, rng: &mut Rng, anchor: usize, fine: &str) -> Option<usize> {
        let a = self.objects[anchor].clone();
        let options = catalog().of(fine);
        let model = *rng.pick(options)?;
        let d = catalog().models[model].size[2];
        let p = a.apply([0.0, 0.0, a.spec().size[2] / 2.0 + d / 2.0 + 0.08]);
        let mut obj = self.new_object(
            rng,
            fine,
            [round(p[0]), self.base_y, round(p[2])],
            (a.quarter_turns + 2) % 4,
        )?;
        obj.model = model;
        obj.mirrored = false;
        self.try_add(obj, true)
    }

    /// Chairs on the sides of a table, facing it.
    fn around(&mut self, rng: &mut Rng, table: usize, fine: &str, max: usize) -> usize {
        let fp = self.objects[table].footprint();
        let mut spots: Vec<([f64; 2], u8)> = Vec::new();
        let gap = 0.08;
        let half = 0.25;
        let along = |lo: f64, hi: f64| -> Vec<f64> {
            let n = (((hi - lo) / 0.65).floor() as usize).max(1);
            (0..n)
                .map(|k| lo + (hi - lo) * (k as f64 + 0.5) / n as f64)
                .collect()
        };
        for x in along(fp.x0, fp.x1) {
            spots.push(([x, fp.z1 + gap + half], 2));
            spots.push(([x, fp.z0 - gap - half], 0));
        }
        for z in along(fp.z0, fp.z1) {
            spots.push(([fp.x1 + gap + half, z], 3));
            spots.push(([fp.x0 - gap - half, z], 1));
        }
        rng.shuffle(&mut spots);
        let mut n = 0;
        for (pos, turns) in spots {
            if n >= max {
                break;
            }
            let Some(obj) = self.new_object(
                rng,
                fine,
                [round(pos[0]), self.base_y, round(pos[1])],
                turns,
            ) else {
                break;
            };
            if self.try_add(obj, true).is_some() {
                n += 1;
            }
        }
        n
    }

    /// On the top surface of another object.
    fn on_top(&mut self, rng: &mut Rng, parent: usize, fine: &str) -> Option<usize> {
        let p = self.objects[parent].clone();
        let top = p.spec().top?;
        let pos = [p.pos[0], p.pos[1] + top, p.pos[2]];
        let obj = self.new_object(rng, fine, pos, p.quarter_turns)?;
        let (pf, of) = (p.footprint(), obj.footprint());
        if !pf.contains(&of) {
            return None;
        }
        self.try_add(obj, false)
    }

    /// The room's floor as a grid of [`GRID`] cells: its size and, per cell, whether it is at
    /// least [`AGENT_CLEARANCE`] from every floor-standing piece.
    fn free_cells(&self) -> (usize, usize, Vec<bool>) {
        let i = self.interior;
        let nx = ((i.w() / GRID).floor() as usize).max(1);
        let nz = ((i.d() / GRID).floor() as usize).max(1);
        let free = (0..nx * nz)
            .map(|k| {
                let (x, z) = self.cell_center(nx, k);
                !self
                    .placed
                    .iter()
                    .any(|(r, _)| r.inflate(AGENT_CLEARANCE).contains_point(x, z))
            })
            .collect();
        (nx, nz, free)
    }

    /// The centre of cell `k` of a [`Placer::free_cells`] grid `nx` cells wide.
    fn cell_center(&self, nx: usize, k: usize) -> (f64, f64) {
        let i = self.interior;
        (
            i.x0 + ((k % nx) as f64 + 0.5) * GRID,
            i.z0 + ((k / nx) as f64 + 0.5) * GRID,
        )
    }

    /// The fraction of the room's floor cells that are free ([`Placer::free_cells`]).
    fn free_fraction(&self) -> f64 {
        let (nx, nz, free) = self.free_cells();
        free.iter().filter(|f| **f).count() as f64 / (nx * nz) as f64
    }

    /// Every door zone is reachable from the others over free floor, and enough floor is free.
    fn walkable(&self) -> bool {
        let (nx, nz, free) = self.free_cells();
        let total_free = free.iter().filter(|f| **f).count();
        if (total_free as f64) < MIN_FREE_FRACTION * (nx * nz) as f64 {
            return false;
        }
        let zone_cells: Vec<Vec<usize>> = self
            .door_zones
            .iter()
            .map(|z| {
                (0..nx * nz)
                    .filter(|&k| {
                        free[k] && {
                            let (x, zz) = self.cell_center(nx, k);
                            z.contains_point(x, zz)
                        }
                    })
                    .collect()
            })
            .collect();
        let start = zone_cells
            .iter()
            .flat_map(|c| c.first())
            .next()
            .copied()
            .or_else(|| free.iter().position(|f| *f));
        let Some(start) = start else { return false };
        if zone_cells.iter().any(|c| c.is_empty()) {
            return false;
        }
        let mut seen = vec![false; nx * nz];
        let mut stack = vec![start];
        seen[start] = true;
        let mut reached = 0usize;
        while let Some(k) = stack.pop() {
            reached += 1;
            let (ix, iz) = (k % nx, k / nx);
            let mut push = |n: usize| {
                if free[n] && !seen[n] {
                    seen[n] = true;
                    stack.push(n);
                }
            };
            if ix > 0 {
                push(k - 1);
            }
            if ix + 1 < nx {
                push(k + 1);
            }
            if iz > 0 {
                push(k - nx);
            }
            if iz + 1 < nz {
                push(k + nx);
            }
        }
        zone_cells.iter().all(|c| c.iter().any(|&k| seen[k]))
            && (reached as f64) >= MIN_FREE_FRACTION * (nx * nz) as f64
    }
}

fn round(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}
