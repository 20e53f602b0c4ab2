//! A reference path walked span by span into what an instruction can say about it: the start
//! room and the turn to make first, then, in order of distance along the path, the rooms
//! entered, the doorways passed through, the turns, the stairs and the landmarks passed.
//!
//! Rules (the grammar only says what is listed here, so every word is grounded):
//!
//! - **Rooms**: a room counts as entered once the path has stayed in it for [`ROOM_PERSIST`]
//!   (spans outside any room are ignored), so a doorway's jagged room border does not flicker;
//!   the goal's room counts when the path ends in it.
//! - **Doorways**: door and arch objects above a span the path steps on, first passage only.
//! - **Turns**: the signed angle between consecutive segments of the path (in XZ); corners
//!   less than [`CORNER_MERGE`] apart add up to one turn. Below [`TURN_MIN`] degrees nothing
//!   is said, below [`TURN_SHARP`] the turn is slight, from [`TURN_AROUND`] it is a turn
//!   around. The first turn is from the start yaw to the first segment (from 45°).
//! - **Stairs**: a change of level (by floor height: `sample::level_at_height`) between
//!   spans the path steps on; changes less than [`STAIRS_MERGE`] apart add up (net), and a
//!   net change of zero says nothing. The route's `levels` follow the stairs said.
//! - **Landmarks**: per room of the path, the closest distinctive object ([`SceneIndex`])
//!   whose box lies within [`LANDMARK_DISTANCE`] (XZ) of the path while the path is in that
//!   room, not the goal object; it is mentioned at the path's closest point, on the side it
//!   lies.
//! - **Door ordinals**: a turn followed within [`DOOR_TURN`] by a doorway is "through the
//!   door on your left/right"; doorways within [`DOOR_SIDE`] of the segment leading to the
//!   turn, on the same side, before it and in the same room, are counted: "the second door on
//!   your right".

use glam::{Vec2, Vec3};

use super::landmarks::SceneIndex;
use crate::episode::sample::level_at_height;
use crate::navmesh::los::walk_line;
use crate::navmesh::{NavGrid, NONE};

/// Distance (m) the path must stay in a room before the room counts as entered.
pub const ROOM_PERSIST: f32 = 0.5;
/// Corners of the path closer than this (m) add up to one turn.
pub const CORNER_MERGE: f32 = 1.0;
/// Smallest turn (degrees) that is said.
pub const TURN_MIN: f32 = 30.0;
/// Turns below this (degrees) are slight ("bear left").
pub const TURN_SHARP: f32 = 60.0;
/// Turns from this (degrees) are turns around.
pub const TURN_AROUND: f32 = 150.0;
/// Level changes closer than this (m) along the path are one flight of stairs.
pub const STAIRS_MERGE: f32 = 3.0;
/// Largest distance (m, XZ) between a landmark's box and the path where it is mentioned.
pub const LANDMARK_DISTANCE: f32 = 2.0;
/// Largest distance (m) along the path from a turn to the doorway it turns through.
pub const DOOR_TURN: f32 = 1.5;
/// Largest distance (m, XZ) of a doorway from the segment before a turn to be counted in
/// "the second door on your right".
pub const DOOR_SIDE: f32 = 1.5;

/// Left or right of the direction of travel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Side {
    /// To the left.
    Left,
    /// To the right.
    Right,
}

impl Side {
    /// `left` or `right`.
    pub fn word(self) -> &'static str {
        match self {
            Side::Left => "left",
            Side::Right => "right",
        }
    }
}

/// A change of direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Turn {
    /// Between [`TURN_MIN`] and [`TURN_SHARP`] degrees.
    Slight(Side),
    /// Between [`TURN_SHARP`] and [`TURN_AROUND`] degrees.
    Full(Side),
    /// From [`TURN_AROUND`] degrees.
    Around,
}

/// Something on the way, at a distance along the path.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// A turn at a corner of the path.
    Turn {
        /// Distance along the path (m).
        at: f32,
        /// Which way.
        turn: Turn,
    },
    /// A doorway passed through.
    Door {
        /// Distance along the path (m).
        at: f32,
        /// Object index.
        object: u32,
        /// An arch rather than a door.
        arch: bool,
        /// When a turn leads through it: the side, and the doorway's rank among those on
        /// that side since the segment before the turn began (1: the first).
        turn_rank: Option<(Side, u32)>,
    },
    /// A room entered.
    Enter {
        /// Distance along the path (m).
        at: f32,
        /// Room index.
        room: u32,
    },
    /// Stairs climbed or descended.
    Stairs {
        /// Distance along the path (m).
        at: f32,
        /// Up rather than down.
        up: bool,
        /// Levels climbed or descended.
        levels: u32,
    },
    /// A landmark passed.
    Landmark {
        /// Distance along the path (m) of the path's point closest to it.
        at: f32,
        /// Object index.
        object: u32,
        /// The side it lies on.
        side: Side,
        /// Its distance (m, XZ) from the path there.
        distance: f32,
    },
}

impl Event {
    /// Distance along the path (m).
    pub fn at(&self) -> f32 {
        match *self {
            Event::Turn { at, .. }
            | Event::Door { at, .. }
            | Event::Enter { at, .. }
            | Event::Stairs { at, .. }
            | Event::Landmark { at, .. } => at,
        }
    }
}

/// What a route passes, in order.
#[derive(Debug, Clone, PartialEq)]
pub struct RouteWalk {
    /// The reference path (start, corners, goal).
    pub points: Vec<Vec3>,
    /// Length of the reference path (m).
    pub length: f32,
    /// The start's room, if any.
    pub start_room: Option<u32>,
    /// The turn from the start yaw onto the first segment, if one is said.
    pub initial_turn: Option<Turn>,
    /// Events in order of distance along the path.
    pub events: Vec<Event>,
    /// Rooms passed in order (the start's first), consecutive repeats removed.
    pub rooms: Vec<u32>,
    /// Doorway objects passed through, in order.
    pub doors: Vec<u32>,
    /// Levels passed in order, consecutive repeats removed.
    pub levels: Vec<u32>,
    /// The room the path ends in (the last room entered), if any.
    pub goal_room: Option<u32>,
}

/// The signed turn (radians, left positive) from direction `a` to `b` (XZ, as (x, z)).
fn signed_turn(a: Vec2, b: Vec2) -> f32 {
    // Yaw is counter-clockwise about +Y: from −Z a left turn faces −X, where
    // a.x·b.y − a.y·b.x is negative.
    let cross = a.x * b.y - a.y * b.x;
    (-cross).atan2(a.dot(b))
}

/// The turn said for a signed angle (radians, left positive), if any.
fn classify(angle: f32, min_deg: f32) -> Option<Turn> {
    let deg = angle.abs().to_degrees();
    let side = if angle > 0.0 { Side::Left } else { Side::Right };
    if deg < min_deg {
        None
    } else if deg >= TURN_AROUND {
        Some(Turn::Around)
    } else if deg < TURN_SHARP {
        Some(Turn::Slight(side))
    } else {
        Some(Turn::Full(side))
    }
}

fn xz(v: Vec3) -> Vec2 {
    Vec2::new(v.x, v.z)
}

/// Distance (XZ) from point `p` to the box `[min, max]`.
fn box_distance(p: Vec2, min: [f32; 3], max: [f32; 3]) -> f32 {
    let dx = (min[0] - p.x).max(0.0).max(p.x - max[0]);
    let dz = (min[2] - p.y).max(0.0).max(p.y - max[2]);
    (dx * dx + dz * dz).sqrt()
}

/// The closest point to a box on segment `a`–`b` (XZ), as (parameter in [0, 1], distance),
/// by ternary search on the convex distance (exact to well below a centimetre).
fn closest_on_segment(a: Vec2, b: Vec2, min: [f32; 3], max: [f32; 3]) -> (f32, f32) {
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    for _ in 0..40 {
        let m1 = lo + (hi - lo) / 3.0;
        let m2 = hi - (hi - lo) / 3.0;
        if box_distance(a.lerp(b, m1), min, max) <= box_distance(a.lerp(b, m2), min, max) {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    let t = 0.5 * (lo + hi);
    (t, box_distance(a.lerp(b, t), min, max))
}

/// Walks the reference path `points` (start, corners, goal) whose corners lie on `spans`
/// (one span per point), starting at yaw `start_yaw`; `goal_object` is left out of the
/// landmarks.
pub fn walk_route(
    grid: &NavGrid,
    index: &SceneIndex,
    points: &[Vec3],
    spans: &[u32],
    start_yaw: f32,
    goal_object: Option<u32>,
) -> RouteWalk {
    let n = points.len();
    let mut cum = vec![0.0f32; n];
    for i in 1..n {
        cum[i] = cum[i - 1] + points[i - 1].distance(points[i]);
    }
    let length = cum.last().copied().unwrap_or(0.0);

    // Spans stepped on, with their distance along the path.
    let mut steps: Vec<(f32, u32)> = Vec::new();
    if spans.len() == 1 {
        steps.push((0.0, spans[0]));
    }
    for i in 0..spans.len().saturating_sub(1).min(n.saturating_sub(1)) {
        let (a, b) = (xz(points[i]), xz(points[i + 1]));
        let seg = b - a;
        let len2 = seg.length_squared().max(1e-12);
        let seg_len = points[i].distance(points[i + 1]);
        let mut visit = |s: u32| {
            let p = xz(grid.span_position(s as usize));
            let t = ((p - a).dot(seg) / len2).clamp(0.0, 1.0);
            steps.push((cum[i] + t * seg_len, s));
        };
        if !walk_line(grid, spans[i], spans[i + 1], &mut visit) {
            visit(spans[i + 1]);
        }
    }

    let mut events = Vec::new();
    // Rooms, with persistence.
    let mut rooms: Vec<u32> = Vec::new();
    let mut room_intervals: Vec<(f32, u32)> = Vec::new(); // (from, room)
    let mut pending: Option<(f32, u32)> = None;
    let mut doors: Vec<u32> = Vec::new();
    let mut level_changes: Vec<(f32, i64)> = Vec::new();
    let mut level_now: Option<u32> = None;
    for &(at, s) in &steps {
        let span = &grid.spans[s as usize];
        let level = level_at_height(grid, span.y);
        if let Some(last) = level_now {
            if last != level {
                level_changes.push((at, i64::from(level) - i64::from(last)));
            }
        }
        level_now = Some(level);
        let start = grid.span_objects.partition_point(|&(t, _)| t < s);
        for &(t, o) in &grid.span_objects[start..] {
            if t != s {
                break;
            }
            if let Some(obj) = grid.objects.get(o as usize) {
                if (obj.door || obj.arch) && !doors.contains(&o) {
                    doors.push(o);
                    events.push(Event::Door {
                        at,
                        object: o,
                        arch: obj.arch && !obj.door,
                        turn_rank: None,
                    });
                }
            }
        }
        let room = span.room;
        if room == NONE || (room as usize) >= grid.rooms.len() {
            continue;
        }
        if rooms.is_empty() {
            rooms.push(room);
            room_intervals.push((0.0, room));
            continue;
        }
        if rooms.last() == Some(&room) {
            pending = None;
            continue;
        }
        match pending {
            Some((from, r)) if r == room => {
                if at - from >= ROOM_PERSIST {
                    rooms.push(room);
                    room_intervals.push((from, room));
                    events.push(Event::Enter { at: from, room });
                    pending = None;
                }
            }
            _ => pending = Some((at, room)),
        }
    }
    // A room the path ends in counts even if entered less than ROOM_PERSIST before the end.
    if let (Some((from, r)), Some(&(_, last))) = (pending, steps.last()) {
        if grid.spans[last as usize].room == r {
            rooms.push(r);
            room_intervals.push((from, r));
            events.push(Event::Enter { at: from, room: r });
        }
    }
    let room_at = |at: f32| -> Option<u32> {
        room_intervals
            .iter()
            .take_while(|(from, _)| *from <= at)
            .last()
            .map(|&(_, r)| r)
    };

    // Stairs: level changes grouped, net; the levels passed follow them.
    let first_level = steps
        .first()
        .map(|&(_, s)| level_at_height(grid, grid.spans[s as usize].y));
    let mut levels: Vec<u32> = first_level.into_iter().collect();
    let mut k = 0;
    while k < level_changes.len() {
        let (at, mut net) = level_changes[k];
        let mut j = k + 1;
        while j < level_changes.len() && level_changes[j].0 - level_changes[j - 1].0 < STAIRS_MERGE
        {
            net += level_changes[j].1;
            j += 1;
        }
        if net != 0 {
            if let Some(&last) = levels.last() {
                levels.push((i64::from(last) + net).max(0) as u32);
            }
            events.push(Event::Stairs {
                at,
                up: net > 0,
                levels: net.unsigned_abs() as u32,
            });
        }
        k = j;
    }

    // Turns at corners, merged when close.
    let dirs: Vec<Option<Vec2>> = (0..n.saturating_sub(1))
        .map(|i| {
            let d = xz(points[i + 1]) - xz(points[i]);
            (d.length() > 1e-4).then(|| d.normalize())
        })
        .collect();
    let mut i = 1;
    while i + 1 < n {
        let (Some(a), Some(mut b)) = (dirs[i - 1], dirs[i]) else {
            i += 1;
            continue;
        };
        let mut angle = signed_turn(a, b);
        let at = cum[i];
        let mut j = i + 1;
        while j + 1 < n && cum[j] - cum[j - 1] < CORNER_MERGE {
            if let Some(c) = dirs[j] {
                angle += signed_turn(b, c);
                b = c;
            }
            j += 1;
        }
        if let Some(turn) = classify(angle, TURN_MIN) {
            events.push(Event::Turn { at, turn });
        }
        i = j;
    }
    let initial_turn = match dirs.iter().flatten().next() {
        Some(&d) => {
            let (s, c) = start_yaw.sin_cos();
            classify(signed_turn(Vec2::new(-s, -c), d), 45.0)
        }
        None => None,
    };

    // Landmarks: per room of the path, the closest distinctive object near it.
    for &room in &rooms {
        let mut best: Option<(f32, f32, u32, Side)> = None;
        for &o in index.distinctive.get(room as usize).into_iter().flatten() {
            if Some(o) == goal_object {
                continue;
            }
            let obj = &grid.objects[o as usize];
            for i in 0..n.saturating_sub(1) {
                let (a, b) = (xz(points[i]), xz(points[i + 1]));
                let (t, d) = closest_on_segment(a, b, obj.min, obj.max);
                if d > LANDMARK_DISTANCE {
                    continue;
                }
                let p = points[i].lerp(points[i + 1], t);
                // On the floor the path walks there: the box spans the path's head height.
                if obj.min[1] > p.y + 2.0 || obj.max[1] < p.y - 0.2 {
                    continue;
                }
                let at = cum[i] + t * (cum[i + 1] - cum[i]);
                if room_at(at) != Some(room) {
                    continue;
                }
                if best.is_some_and(|(bd, ..)| bd <= d) {
                    continue;
                }
                let centre = Vec2::new(
                    0.5 * (obj.min[0] + obj.max[0]),
                    0.5 * (obj.min[2] + obj.max[2]),
                );
                let dir = dirs[i].unwrap_or(Vec2::new(0.0, -1.0));
                let to = centre - xz(p);
                let side = if signed_turn(dir, to) > 0.0 {
                    Side::Left
                } else {
                    Side::Right
                };
                best = Some((d, at, o, side));
            }
        }
        if let Some((distance, at, object, side)) = best {
            events.push(Event::Landmark {
                at,
                object,
                side,
                distance,
            });
        }
    }

    events.sort_by(|a, b| a.at().total_cmp(&b.at()));
    rank_turn_doors(grid, index, points, &cum, &dirs, &mut events);
    RouteWalk {
        points: points.to_vec(),
        length,
        start_room: rooms.first().copied(),
        initial_turn,
        goal_room: rooms.last().copied(),
        events,
        rooms,
        doors,
        levels,
    }
}

/// Marks doorways a turn leads through with their side and rank (see the module rules).
fn rank_turn_doors(
    grid: &NavGrid,
    index: &SceneIndex,
    points: &[Vec3],
    cum: &[f32],
    dirs: &[Option<Vec2>],
    events: &mut [Event],
) {
    for k in 0..events.len() {
        let Event::Turn { at, turn } = events[k] else {
            continue;
        };
        let side = match turn {
            Turn::Full(side) | Turn::Slight(side) => side,
            Turn::Around => continue,
        };
        // The doorway right after the turn, with no room entered in between.
        let Some(d) = events[k + 1..]
            .iter()
            .take_while(|e| e.at() - at <= DOOR_TURN)
            .position(|e| matches!(e, Event::Door { .. }))
            .map(|p| k + 1 + p)
        else {
            continue;
        };
        let Event::Door {
            object: through, ..
        } = events[d]
        else {
            continue;
        };
        // The segment leading into the turn.
        let Some(seg) = cum
            .iter()
            .position(|&c| (c - at).abs() < 1e-4)
            .and_then(|i| i.checked_sub(1))
        else {
            continue;
        };
        let (Some(dir), a, b) = (dirs[seg], xz(points[seg]), xz(points[seg + 1])) else {
            continue;
        };
        let mut rank = 1;
        for &o in &index.doors {
            if o == through {
                continue;
            }
            let obj = &grid.objects[o as usize];
            let (t, dist) = closest_on_segment(a, b, obj.min, obj.max);
            if dist > DOOR_SIDE || t >= 0.999 {
                continue;
            }
            let p = a.lerp(b, t);
            let centre = Vec2::new(
                0.5 * (obj.min[0] + obj.max[0]),
                0.5 * (obj.min[2] + obj.max[2]),
            );
            let to = centre - p;
            // Beside the segment (not ahead of its end) and on the turn's side.
            if (centre - b).dot(dir) >= 0.0 {
                continue;
            }
            let on_left = signed_turn(dir, to) > 0.0;
            if on_left == (side == Side::Left) {
                rank += 1;
            }
        }
        if let Event::Door { turn_rank, .. } = &mut events[d] {
            *turn_rank = Some((side, rank));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn turns_are_signed_as_the_yaw_convention_says() {
        // Facing −Z, a turn to face −X is a left turn (yaw grows counter-clockwise).
        let north = Vec2::new(0.0, -1.0);
        let west = Vec2::new(-1.0, 0.0);
        let east = Vec2::new(1.0, 0.0);
        assert!((signed_turn(north, west) - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        assert!((signed_turn(north, east) + std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        assert_eq!(
            classify(signed_turn(north, west), TURN_MIN),
            Some(Turn::Full(Side::Left))
        );
        assert_eq!(
            classify(signed_turn(north, Vec2::new(0.6, -0.8)), TURN_MIN),
            Some(Turn::Slight(Side::Right))
        );
        assert_eq!(
            classify(signed_turn(north, Vec2::new(0.0, 1.0)), 30.0),
            Some(Turn::Around)
        );
        assert_eq!(classify(0.2, TURN_MIN), None);
        // The start yaw's forward is (−sin yaw, −cos yaw): yaw π/2 faces −X.
        let yaw = std::f32::consts::FRAC_PI_2;
        let f = Vec2::new(-yaw.sin(), -yaw.cos());
        assert!((f - west).length() < 1e-6);
    }

    #[test]
    fn closest_point_of_a_segment_to_a_box() {
        let (t, d) = closest_on_segment(
            Vec2::new(0.0, 0.0),
            Vec2::new(10.0, 0.0),
            [4.0, 0.0, 1.0],
            [5.0, 1.0, 2.0],
        );
        assert!((d - 1.0).abs() < 1e-4, "{d}");
        assert!((0.4 - 1e-3..=0.5 + 1e-3).contains(&t), "{t}");
    }
}
