//! Floor plans: room programmes, rectangular subdivision of the footprint, doors and arches
//! between neighbouring rooms (a spanning tree plus extras), windows and the front door on
//! exterior walls, and stairs between levels.

use crate::scene::RoomClass;
use crate::seed::Rng;

use super::catalog::{
    catalog, ARCH_HEIGHT, ARCH_WIDTHS, DOOR_HEIGHT, DOOR_WIDTHS, LEVEL_HEIGHT, STAIR_RUN,
    STAIR_STEPS, STAIR_WIDTH, WINDOW_SIZES,
};
use super::plan::{
    LevelPlan, Opening, OpeningKind, PlacedObject, Rect, RoomPlan, Side, RAILING_HEIGHT,
    WALL_HEIGHT, WALL_T,
};

/// A kind of room in a programme, with its typical floor area range.
#[derive(Debug, Clone, Copy)]
pub struct RoomType {
    /// SUNCG `roomTypes` label.
    pub raw: &'static str,
    /// MINOS class.
    pub class: RoomClass,
    /// Floor area range in m².
    pub area: (f64, f64),
}

const fn rt(raw: &'static str, class: RoomClass, lo: f64, hi: f64) -> RoomType {
    RoomType {
        raw,
        class,
        area: (lo, hi),
    }
}

const LIVING: RoomType = rt("Living_Room", RoomClass::LivingRoom, 18.0, 30.0);
const KITCHEN: RoomType = rt("Kitchen", RoomClass::Kitchen, 8.0, 14.0);
const DINING: RoomType = rt("Dining_Room", RoomClass::DiningRoom, 10.0, 15.0);
const BEDROOM: RoomType = rt("Bedroom", RoomClass::Bedroom, 10.0, 16.0);
const CHILD: RoomType = rt("Child_Room", RoomClass::Bedroom, 8.0, 12.0);
const GUEST: RoomType = rt("Guest_Room", RoomClass::Bedroom, 8.0, 12.0);
const BATHROOM: RoomType = rt("Bathroom", RoomClass::Bathroom, 4.5, 7.0);
const TOILET: RoomType = rt("Toilet", RoomClass::Bathroom, 4.0, 5.0);
const OFFICE: RoomType = rt("Office", RoomClass::Office, 7.0, 11.0);
const HALLWAY: RoomType = rt("Hallway", RoomClass::Hallway, 5.0, 9.0);
const STORAGE: RoomType = rt("Storage", RoomClass::Other, 4.0, 6.0);
const BALCONY: RoomType = rt("Balcony", RoomClass::Outdoor, 4.5, 7.0);
/// The stair hall that connects two levels.
pub const STAIR_HALL: RoomType = rt("Hallway", RoomClass::Hallway, 0.0, 0.0);

/// Width of the stair hall strip along the west side of two-level houses.
const STRIP_W: f64 = 2.4;
/// Width of the stair hall strip of houses with three levels: two flights side by side (the
/// first along the west wall rising towards +Z, the second beside it rising towards −Z) and a
/// walkway along the hall's east wall, where its doors are.
const STRIP_W3: f64 = 3.6;
/// West edge of the second lane of stairs (three-level houses).
const LANE_B_X: f64 = 1.2;
/// Landing in front of the bottom step.
const LANDING: f64 = 1.2;
/// Shortest room side.
const MIN_SIDE: f64 = 2.1;
/// Distance kept between an opening and the end of its wall segment.
const OPENING_MARGIN: f64 = 0.2;

/// The room types of one level with `k` rooms (stair hall excluded).
pub fn programme(rng: &mut Rng, k: usize, upper: bool) -> Vec<RoomType> {
    if k == 0 {
        return Vec::new();
    }
    if !upper && k == 1 {
        return vec![*rng
            .pick(&[BEDROOM, LIVING, OFFICE, KITCHEN])
            .unwrap_or(&LIVING)];
    }
    let (head, mut tail): (Vec<RoomType>, Vec<RoomType>) = if upper {
        (
            vec![BEDROOM, BATHROOM],
            vec![
                CHILD, OFFICE, GUEST, STORAGE, BALCONY, TOILET, BEDROOM, BATHROOM, OFFICE, CHILD,
            ],
        )
    } else {
        (
            vec![LIVING, KITCHEN, BEDROOM, BATHROOM],
            vec![
                DINING, HALLWAY, OFFICE, CHILD, STORAGE, BALCONY, GUEST, TOILET, BEDROOM, OFFICE,
            ],
        )
    };
    rng.shuffle(&mut tail);
    head.into_iter().chain(tail).take(k).collect()
}

/// Splits `rect` into one rectangle per area (in order), cutting the longer side in
/// proportion to the areas on each side. `None` when a room would get a side < `MIN_SIDE`.
fn subdivide(rect: Rect, areas: &[f64], rng: &mut Rng) -> Option<Vec<Rect>> {
    if areas.len() == 1 {
        return Some(vec![rect]);
    }
    let k = areas.len() / 2;
    let total: f64 = areas.iter().sum();
    let f = areas[..k].iter().sum::<f64>() / total;
    let jitter = rng.range_f64(-0.04, 0.04);
    let cut = |lo: f64, hi: f64| -> Option<f64> {
        let len = hi - lo;
        if len < 2.0 * MIN_SIDE {
            return None;
        }
        let p = lo + (f + jitter).clamp(0.0, 1.0) * len;
        let p = (p / 0.05).round() * 0.05;
        Some(p.clamp(lo + MIN_SIDE, hi - MIN_SIDE))
    };
    let split_x = |p: f64| {
        (
            Rect::new(rect.x0, rect.z0, p, rect.z1),
            Rect::new(p, rect.z0, rect.x1, rect.z1),
        )
    };
    let split_z = |p: f64| {
        (
            Rect::new(rect.x0, rect.z0, rect.x1, p),
            Rect::new(rect.x0, p, rect.x1, rect.z1),
        )
    };
    let (a, b) = if rect.w() >= rect.d() {
        cut(rect.x0, rect.x1)
            .map(split_x)
            .or_else(|| cut(rect.z0, rect.z1).map(split_z))?
    } else {
        cut(rect.z0, rect.z1)
            .map(split_z)
            .or_else(|| cut(rect.x0, rect.x1).map(split_x))?
    };
    let mut out = subdivide(a, &areas[..k], rng)?;
    out.extend(subdivide(b, &areas[k..], rng)?);
    Some(out)
}

/// A shared wall segment between rooms `a` and `b` of a level.
#[derive(Debug, Clone, Copy)]
struct Shared {
    a: usize,
    b: usize,
    /// Side of `a` the segment lies on (b's is the opposite).
    side_a: Side,
    /// Position of the boundary (x for MinX/MaxX sides, z otherwise).
    at: f64,
    /// Extent along the boundary.
    u0: f64,
    u1: f64,
}

fn opposite(s: Side) -> Side {
    match s {
        Side::MinX => Side::MaxX,
        Side::MaxX => Side::MinX,
        Side::MinZ => Side::MaxZ,
        Side::MaxZ => Side::MinZ,
    }
}

fn shared_walls(rooms: &[RoomPlan]) -> Vec<Shared> {
    let mut out = Vec::new();
    for a in 0..rooms.len() {
        for b in 0..rooms.len() {
            if a == b {
                continue;
            }
            let (ra, rb) = (rooms[a].rect, rooms[b].rect);
            if (ra.x1 - rb.x0).abs() < 1e-6 {
                let (u0, u1) = (ra.z0.max(rb.z0), ra.z1.min(rb.z1));
                if u1 > u0 {
                    out.push(Shared {
                        a,
                        b,
                        side_a: Side::MaxX,
                        at: ra.x1,
                        u0,
                        u1,
                    });
                }
            }
            if (ra.z1 - rb.z0).abs() < 1e-6 {
                let (u0, u1) = (ra.x0.max(rb.x0), ra.x1.min(rb.x1));
                if u1 > u0 {
                    out.push(Shared {
                        a,
                        b,
                        side_a: Side::MaxZ,
                        at: ra.z1,
                        u0,
                        u1,
                    });
                }
            }
        }
    }
    out
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Rounds to centimetres so that written files stay short and exact.
fn cm(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}

fn model_index(id: &str) -> usize {
    catalog()
        .models
        .iter()
        .position(|m| m.id == id)
        .unwrap_or_else(|| panic!("catalog has no model {id}")) // the catalog is static
}

/// Places an opening object (door, arch, window) centred on a wall line.
fn opening_object(
    model: usize,
    side: Side,
    at: f64,
    u: f64,
    y: f64,
    swing_positive: bool,
    rooms: Vec<usize>,
) -> PlacedObject {
    let (pos, turns) = if side.along_x() {
        ([u, y, at], if swing_positive { 0 } else { 2 })
    } else {
        ([at, y, u], if swing_positive { 1 } else { 3 })
    };
    PlacedObject {
        model,
        pos,
        quarter_turns: turns,
        mirrored: false,
        rooms,
        colors: Vec::new(),
    }
}

/// Level rooms from rectangles and types.
fn rooms_from(rects: &[Rect], types: &[RoomType]) -> Vec<RoomPlan> {
    rects
        .iter()
        .zip(types)
        .map(|(r, t)| RoomPlan {
            rect: *r,
            raw_type: t.raw,
            class: t.class,
            wall_height: if t.class == RoomClass::Outdoor {
                RAILING_HEIGHT
            } else {
                WALL_HEIGHT
            },
            hide_ceiling: t.class == RoomClass::Outdoor,
            openings: Vec::new(),
            floor_holes: Vec::new(),
            ceiling_holes: Vec::new(),
        })
        .collect()
}

/// Lays out the rooms of all levels: returns levels with rooms, openings, doors, windows and
/// stairs placed (no furniture yet), or `None` when this draw does not fit.
pub fn layout(
    rng: &mut Rng,
    programmes: &[Vec<RoomType>],
    closed_door_prob: f64,
    scale: f64,
) -> Option<Vec<LevelPlan>> {
    let multi_level = programmes.len() >= 2;
    let strip_w = if programmes.len() > 2 {
        STRIP_W3
    } else {
        STRIP_W
    };
    let areas: Vec<Vec<f64>> = programmes
        .iter()
        .map(|p| {
            p.iter()
                .map(|t| rng.range_f64(t.area.0, t.area.1) * scale)
                .collect()
        })
        .collect();
    let total = areas
        .iter()
        .map(|a| a.iter().sum::<f64>())
        .fold(0.0, f64::max);
    let aspect = rng.range_f64(1.0, 1.6);
    let mut w = (total * aspect).sqrt();
    let mut d = total / w;
    if multi_level && d < 7.6 {
        d = 7.6;
        w = (total / d).max(MIN_SIDE);
    }
    let (w, d) = (cm(w.max(MIN_SIDE)), cm(d.max(MIN_SIDE)));
    let x_start = if multi_level { strip_w } else { 0.0 };
    let region = Rect::new(x_start, 0.0, x_start + w, d);
    let footprint = Rect::new(0.0, 0.0, x_start + w, d);
    let mut levels = Vec::new();
    for (li, programme) in programmes.iter().enumerate() {
        let rects = subdivide(region, &areas[li], rng)?;
        let mut rooms = rooms_from(&rects, programme);
        if multi_level {
            rooms.push(rooms_from(&[Rect::new(0.0, 0.0, strip_w, d)], &[STAIR_HALL]).remove(0));
        }
        levels.push(LevelPlan {
            base_y: li as f64 * LEVEL_HEIGHT,
            rooms,
            objects: Vec::new(),
            ground: (li == 0).then(|| footprint.inflate(2.0)),
        });
    }
    for level in &mut levels {
        connect_rooms(rng, level, closed_door_prob, multi_level)?;
    }
    if multi_level {
        place_stairs(&mut levels, d);
    }
    front_door(rng, &mut levels[0], &footprint);
    for level in &mut levels {
        windows(rng, level, &footprint);
    }
    Some(levels)
}

fn connect_rooms(
    rng: &mut Rng,
    level: &mut LevelPlan,
    closed_door_prob: f64,
    has_stair_hall: bool,
) -> Option<()> {
    let n = level.rooms.len();
    let stair_hall = if has_stair_hall { Some(n - 1) } else { None };
    let mut walls: Vec<Shared> = shared_walls(&level.rooms)
        .into_iter()
        .filter(|s| s.u1 - s.u0 >= 1.0 + 2.0 * OPENING_MARGIN)
        .collect();
    rng.shuffle(&mut walls);
    // Footprints of the open doors placed so far (frame and swung leaf).
    let mut swings: Vec<Rect> = Vec::new();
    let mut parent: Vec<usize> = (0..n).collect();
    let mut chosen: Vec<Shared> = Vec::new();
    let mut extra: Vec<Shared> = Vec::new();
    for s in walls {
        let (ra, rb) = (find(&mut parent, s.a), find(&mut parent, s.b));
        if ra != rb {
            parent[ra] = rb;
            chosen.push(s);
        } else {
            extra.push(s);
        }
    }
    if chosen.len() + 1 != n {
        return None; // not connected: another draw
    }
    let is_wet = |c: RoomClass| c == RoomClass::Bathroom;
    for s in extra {
        let pair_done = chosen
            .iter()
            .any(|c| (c.a == s.a && c.b == s.b) || (c.a == s.b && c.b == s.a));
        if pair_done || is_wet(level.rooms[s.a].class) || is_wet(level.rooms[s.b].class) {
            continue;
        }
        if rng.chance(0.3) {
            chosen.push(s);
        }
    }
    let mut degree = vec![0usize; n];
    for s in &chosen {
        degree[s.a] += 1;
        degree[s.b] += 1;
    }
    let open_plan = |c: RoomClass| {
        matches!(
            c,
            RoomClass::LivingRoom | RoomClass::DiningRoom | RoomClass::Kitchen | RoomClass::Hallway
        )
    };
    for s in chosen {
        let (ca, cb) = (level.rooms[s.a].class, level.rooms[s.b].class);
        let len = s.u1 - s.u0;
        let arch = open_plan(ca) && open_plan(cb) && len >= 2.0 && rng.chance(0.5);
        let (width, kind, model) = if arch {
            let w = *rng.pick(
                &ARCH_WIDTHS
                    .iter()
                    .filter(|w| **w + 2.0 * OPENING_MARGIN <= len)
                    .copied()
                    .collect::<Vec<_>>(),
            )?;
            (
                w,
                OpeningKind::Arch,
                model_index(&format!("g_arch_{}", (w * 100.0).round() as u32)),
            )
        } else {
            let w = *rng.pick(&DOOR_WIDTHS)?;
            // A room reached through this door alone may be shut (never the stair hall).
            let leaf = |r: usize| {
                degree[r] == 1
                    && Some(r) != stair_hall
                    && !matches!(
                        level.rooms[r].class,
                        RoomClass::LivingRoom | RoomClass::Hallway
                    )
            };
            let open = !((leaf(s.a) || leaf(s.b)) && rng.chance(closed_door_prob));
            let state = if open { "open" } else { "closed" };
            (
                w,
                OpeningKind::Door { open },
                model_index(&format!("g_door_{state}_{}", (w * 100.0).round() as u32)),
            )
        };
        let lo = s.u0 + OPENING_MARGIN + width / 2.0;
        let hi = s.u1 - OPENING_MARGIN - width / 2.0;
        let u = cm(rng.range_f64(lo, hi.max(lo)));
        let top = if arch { ARCH_HEIGHT } else { DOOR_HEIGHT };
        let (u0, u1) = (u - width / 2.0, u + width / 2.0);
        level.rooms[s.a].openings.push(Opening {
            side: s.side_a,
            u0,
            u1,
            y0: 0.0,
            y1: top,
            kind,
        });
        level.rooms[s.b].openings.push(Opening {
            side: opposite(s.side_a),
            u0,
            u1,
            y0: 0.0,
            y1: top,
            kind,
        });
        let swing_positive = rng.chance(0.5);
        let place = |positive: bool| {
            opening_object(
                model,
                s.side_a,
                s.at,
                u,
                level.base_y,
                positive,
                vec![s.a, s.b],
            )
        };
        let mut object = place(swing_positive);
        if matches!(kind, OpeningKind::Door { open: true }) {
            // Two open leaves must never box in a corner between them: swing the other way
            // when the preferred side comes within an agent's width of another open leaf.
            let clashes = |o: &PlacedObject| {
                let f = o.footprint();
                swings.iter().any(|w: &Rect| w.overlaps(&f, LEAF_GAP))
            };
            if clashes(&object) {
                let other = place(!swing_positive);
                if !clashes(&other) {
                    object = other;
                }
            }
            swings.push(object.footprint());
        }
        level.objects.push(object);
    }
    Some(())
}

/// Smallest gap between the swept boxes of two open door leaves (an agent's width and a margin).
const LEAF_GAP: f64 = 0.35;

/// The world position of a side of `r` (x or z), moved `inset` into the room.
fn side_line(r: &Rect, side: Side, inset: f64) -> f64 {
    match side {
        Side::MinX => r.x0 + inset,
        Side::MaxX => r.x1 - inset,
        Side::MinZ => r.z0 + inset,
        Side::MaxZ => r.z1 - inset,
    }
}

fn exterior_sides(r: &Rect, footprint: &Rect) -> Vec<(Side, f64, f64)> {
    let mut out = Vec::new();
    if (r.x0 - footprint.x0).abs() < 1e-6 {
        out.push((Side::MinX, r.z0, r.z1));
    }
    if (r.x1 - footprint.x1).abs() < 1e-6 {
        out.push((Side::MaxX, r.z0, r.z1));
    }
    if (r.z0 - footprint.z0).abs() < 1e-6 {
        out.push((Side::MinZ, r.x0, r.x1));
    }
    if (r.z1 - footprint.z1).abs() < 1e-6 {
        out.push((Side::MaxZ, r.x0, r.x1));
    }
    out
}

/// Finds a free interval of `width` on a wall, away from other openings and the wall's ends.
fn free_spot(
    rng: &mut Rng,
    room: &RoomPlan,
    side: Side,
    u0: f64,
    u1: f64,
    width: f64,
) -> Option<f64> {
    for _ in 0..8 {
        let lo = u0 + OPENING_MARGIN + 0.1 + width / 2.0;
        let hi = u1 - OPENING_MARGIN - 0.1 - width / 2.0;
        if hi < lo {
            return None;
        }
        let u = cm(rng.range_f64(lo, hi));
        let clear = room
            .openings
            .iter()
            .filter(|o| o.side == side)
            .all(|o| u + width / 2.0 + 0.3 < o.u0 || u - width / 2.0 - 0.3 > o.u1);
        if clear {
            return Some(u);
        }
    }
    None
}

/// The closed front door: on an outside wall of a living room, hallway or kitchen, the wall
/// drawn at random among all of theirs (so houses face every way), the next one tried when
/// the drawn wall has no free spot.
fn front_door(rng: &mut Rng, level: &mut LevelPlan, footprint: &Rect) {
    let mut walls: Vec<(usize, Side, f64, f64)> = (0..level.rooms.len())
        .filter(|&i| {
            matches!(
                level.rooms[i].class,
                RoomClass::LivingRoom | RoomClass::Hallway | RoomClass::Kitchen
            )
        })
        .flat_map(|i| {
            exterior_sides(&level.rooms[i].rect, footprint)
                .into_iter()
                .map(move |(side, u0, u1)| (i, side, u0, u1))
        })
        .collect();
    rng.shuffle(&mut walls);
    for (i, side, u0, u1) in walls {
        let room = &level.rooms[i];
        let width = 1.0;
        let Some(u) = free_spot(rng, room, side, u0, u1, width) else {
            continue;
        };
        let at = side_line(&room.rect, side, WALL_T / 2.0);
        level.rooms[i].openings.push(Opening {
            side,
            u0: u - width / 2.0,
            u1: u + width / 2.0,
            y0: 0.0,
            y1: DOOR_HEIGHT,
            kind: OpeningKind::Door { open: false },
        });
        let model = model_index("g_door_closed_100");
        level.objects.push(opening_object(
            model,
            side,
            at,
            u,
            level.base_y,
            true,
            vec![i],
        ));
        return;
    }
}

fn windows(rng: &mut Rng, level: &mut LevelPlan, footprint: &Rect) {
    for i in 0..level.rooms.len() {
        let class = level.rooms[i].class;
        if class == RoomClass::Outdoor {
            continue;
        }
        let mut placed = 0;
        for (side, u0, u1) in exterior_sides(&level.rooms[i].rect, footprint) {
            if placed >= 2 || !rng.chance(0.75) {
                continue;
            }
            let (w, h, sill) = if class == RoomClass::Bathroom {
                let (w, h) = WINDOW_SIZES[3];
                (w, h, 1.4)
            } else {
                let (w, h) = WINDOW_SIZES[rng.below(3)];
                (w, h, 0.9)
            };
            let Some(u) = free_spot(rng, &level.rooms[i], side, u0, u1, w) else {
                continue;
            };
            level.rooms[i].openings.push(Opening {
                side,
                u0: u - w / 2.0,
                u1: u + w / 2.0,
                y0: sill,
                y1: sill + h,
                kind: OpeningKind::Window,
            });
            let id = format!(
                "g_window_{}x{}",
                (w * 100.0).round() as u32,
                (h * 100.0).round() as u32
            );
            let at = side_line(&level.rooms[i].rect, side, WALL_T / 2.0);
            let base = level.base_y + sill;
            level.objects.push(opening_object(
                model_index(&id),
                side,
                at,
                u,
                base,
                true,
                vec![i],
            ));
            placed += 1;
        }
    }
}

/// Puts a flight of stairs between each pair of consecutive levels in their stair halls and
/// cuts the matching holes in the lower ceiling and the upper floor: from level 0 along the
/// west wall rising towards +Z, from level 1 (three-level houses) in the lane beside it rising
/// towards −Z, alternating from there.
fn place_stairs(levels: &mut [LevelPlan], depth: f64) {
    let len = STAIR_STEPS as f64 * STAIR_RUN;
    let z_bottom = LANDING;
    let z_top = z_bottom + len;
    debug_assert!(z_top + LANDING <= depth + 1e-9);
    for lower in 0..levels.len().saturating_sub(1) {
        let lane_a = lower % 2 == 0;
        let x0 = if lane_a { WALL_T } else { LANE_B_X };
        let x = x0 + 0.02 + STAIR_WIDTH / 2.0;
        let hall0 = levels[lower].rooms.len() - 1;
        let hall1 = levels[lower + 1].rooms.len() - 1;
        // The model rises towards its -Z: turn it half-way so it rises towards +Z.
        levels[lower].objects.push(PlacedObject {
            model: model_index("g_stairs_0"),
            pos: [cm(x), levels[lower].base_y, cm((z_bottom + z_top) / 2.0)],
            quarter_turns: if lane_a { 2 } else { 0 },
            mirrored: false,
            rooms: vec![hall0],
            colors: Vec::new(),
        });
        let hole = Rect::new(x0, z_bottom, x0 + 0.04 + STAIR_WIDTH, z_top);
        levels[lower].rooms[hall0].ceiling_holes.push(hole);
        levels[lower + 1].rooms[hall1].floor_holes.push(hole);
    }
}

/// Where furniture must not go in a room: in front of its doors and arches, and on the stairs
/// and their landings.
pub fn keep_outs(level: &LevelPlan, room: usize) -> Vec<Rect> {
    let r = &level.rooms[room];
    let mut out = Vec::new();
    for o in r.openings.iter().filter(|o| o.kind != OpeningKind::Window) {
        let depth = 1.2;
        let (a, b) = (o.u0 - 0.25, o.u1 + 0.25);
        out.push(match o.side {
            Side::MinX => Rect::new(r.rect.x0, a, r.rect.x0 + depth, b),
            Side::MaxX => Rect::new(r.rect.x1 - depth, a, r.rect.x1, b),
            Side::MinZ => Rect::new(a, r.rect.z0, b, r.rect.z0 + depth),
            Side::MaxZ => Rect::new(a, r.rect.z1 - depth, b, r.rect.z1),
        });
    }
    for h in r.floor_holes.iter().chain(&r.ceiling_holes) {
        out.push(Rect::new(h.x0, h.z0 - LANDING, h.x1 + 0.3, h.z1 + LANDING));
    }
    out
}
