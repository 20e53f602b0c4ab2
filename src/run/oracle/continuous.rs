//! The oracle's planner for continuous agents (MINOS's forces and friction): momentum carries
//! the agent on after a move, so a plan is a sequence of exact simulated states, never a
//! lattice walk.
//!
//! Most of a plan is *greedy steps*: turn towards the next corner of the goal field's
//! shortest path (the turns it takes at the agent's fixed turn rate), then move forward,
//! simulated with the simulator's own motion and collisions. One is kept only when none of
//! its moves collides and it lowers the remaining geodesic distance by at least a quarter of
//! the longest move (or reaches the goal). Where no greedy step is safe (a corner the drift
//! would cut, a narrow door), a hybrid A* plans a short segment: it keeps the exact states
//! but counts two states as one when they fall in the same cell of a coarse grid over
//! position, heading (one cell per turn step), velocity and angular velocity, so the
//! continuum of reachable states does not explode; a collision costs half a step extra. When
//! that fails, finer cells and a larger budget are tried before giving up.
//!
//! Searches keep to floor the goal's distance field reaches. A body slimmer than the grid's
//! erosion can squeeze through a gap the grid closes, into a pocket the field does not
//! reach; when another driver (a learner in DAgger) has led the agent into one, the plan
//! starts with a search for the way out, guided by a walk out over a fine lattice of the
//! positions where the body fits.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};
use std::hash::{BuildHasherDefault, Hasher};

use glam::Vec3;

use crate::episode::Episode;
use crate::run::metrics::reached;
use crate::sim::{Actions, Simulator};
use crate::sim::{AgentState, Motion};

use super::{angle_between, backtrack, remaining, Node};

/// Weight of the heuristic (weighted A*): high, since the states of one cost form wide
/// plateaus (every cell reachable in so many steps) that a low weight explores in full.
const WEIGHT: f32 = 2.0;
/// Extra cost of a move that collides, in steps.
const COLLISION_COST: f32 = 0.5;

/// How finely the hybrid A* tells states apart, and how many it may expand.
#[derive(Debug, Clone, Copy)]
struct Resolution {
    /// Position cell (m).
    position: f32,
    /// Velocity cell (m/s per component).
    velocity: f32,
    /// Expansions allowed for one segment.
    expansions: usize,
}

/// Tried in order for each segment the greedy steps cannot make.
const RESOLUTIONS: [Resolution; 2] = [
    Resolution {
        position: 0.05,
        velocity: 0.5,
        expansions: 3_000,
    },
    Resolution {
        position: 0.02,
        velocity: 0.2,
        expansions: 30_000,
    },
];

/// Progress (m of remaining geodesic distance) the segments of a hybrid A* aim for, tried in
/// order.
const SEGMENTS: [f32; 3] = [0.5, 1.5, 0.25];

/// Where a hybrid A* segment ends.
#[derive(Debug, Clone, Copy)]
enum Aim<'a> {
    /// At a state whose remaining distance is at most this (m), or at the goal.
    Below(f32),
    /// At any state the goal's field reaches, from a pocket it does not reach, guided along
    /// the body's way out ([`way_out`]).
    OutOfPocket(&'a WayOut),
}

/// Spacing (m) of the lattice [`way_out`] walks: fine enough that a gap the body passes
/// with a few centimetres to spare has a lattice line through it.
const POCKET_CELL: f32 = 0.02;
/// How far (m) from the agent [`way_out`] looks.
const POCKET_REACH: f32 = 2.0;

/// The way out of a pocket: lattice points from the agent to the first the goal's field
/// reaches, with the length of the walk left from each.
#[derive(Debug)]
struct WayOut {
    points: Vec<Vec3>,
    left: Vec<f32>,
}

impl WayOut {
    /// The length (m) of a way from `p` out of the pocket: to a point of the walk, then
    /// along it.
    fn from(&self, p: Vec3) -> f32 {
        let flat = |a: Vec3| Vec3::new(a.x - p.x, 0.0, a.z - p.z).length();
        self.points
            .iter()
            .zip(&self.left)
            .map(|(q, l)| flat(*q) + l)
            .fold(f32::INFINITY, f32::min)
    }
}

/// The body's own way out of a pocket of floor the goal's field does not reach (the grid is
/// eroded and rasterised more coarsely than the body is shaped, so the body squeezes through
/// gaps the grid closes): a shortest 8-connected walk over a [`POCKET_CELL`] lattice around
/// `from`, through positions where the body overlaps nothing, to the first position the
/// field reaches; `None` when there is none within [`POCKET_REACH`].
fn way_out(sim: &Simulator, from: Vec3) -> Option<WayOut> {
    let collision = &sim.assets().collision;
    let r = (POCKET_REACH / POCKET_CELL) as i32;
    let at = |c: (i32, i32)| {
        Vec3::new(
            from.x + c.0 as f32 * POCKET_CELL,
            from.y,
            from.z + c.1 as f32 * POCKET_CELL,
        )
    };
    // Each cell's cost in hundredths of a cell (100 straight, 141 diagonal) and the cell
    // it was reached from.
    type Cell = (i32, i32);
    let mut cost: HashMap<Cell, (u32, Cell), BuildHasherDefault<KeyHasher>> = HashMap::default();
    let mut open = BinaryHeap::new();
    cost.insert((0, 0), (0, (0, 0)));
    open.push(Reverse((0u32, (0i32, 0i32))));
    while let Some(Reverse((c, cell))) = open.pop() {
        if cost.get(&cell).is_some_and(|&(b, _)| b < c) {
            continue;
        }
        if sim.goal_field_distance(at(cell)).is_some() {
            let mut points = vec![at(cell)];
            let mut cur = cell;
            while cur != (0, 0) {
                cur = cost[&cur].1;
                points.push(at(cur));
            }
            points.reverse();
            let mut left = vec![0.0; points.len()];
            for i in (0..points.len().saturating_sub(1)).rev() {
                left[i] = left[i + 1] + points[i].distance(points[i + 1]);
            }
            return Some(WayOut { points, left });
        }
        for (dx, dz) in [
            (1, 0),
            (-1, 0),
            (0, 1),
            (0, -1),
            (1, 1),
            (1, -1),
            (-1, 1),
            (-1, -1),
        ] {
            let next = (cell.0 + dx, cell.1 + dz);
            if next.0.abs() > r || next.1.abs() > r {
                continue;
            }
            let nc = c + if dx != 0 && dz != 0 { 141 } else { 100 };
            if cost.get(&next).is_some_and(|&(b, _)| b <= nc) || collision.blocked(at(next)) {
                continue;
            }
            cost.insert(next, (nc, cell));
            open.push(Reverse((nc, next)));
        }
    }
    None
}

/// What planning needs of the agent's dynamics.
#[derive(Debug, Clone, Copy)]
struct Dynamics {
    /// Longest move of one step (m).
    max_move: f32,
    /// Turn of one turn action from rest (rad).
    turn: f32,
    /// Headings one full turn holds (`TAU / turn`, rounded up).
    headings: i32,
    /// Fraction of the velocity that carries over to the next step.
    keep_velocity: f32,
    /// Fraction of the angular velocity that carries over.
    keep_angular: f32,
}

impl Dynamics {
    fn of(sim: &Simulator) -> Option<Dynamics> {
        let dt = sim.agent().dt;
        let Motion::Continuous {
            max_speed,
            linear_friction,
            turn_acceleration,
            max_angular_speed,
            angular_friction,
            ..
        } = sim.agent().motion
        else {
            return None;
        };
        let max_move = max_speed * dt;
        let turn = (turn_acceleration * dt).min(max_angular_speed) * dt;
        if !(max_move > 0.0 && turn > 0.0 && dt > 0.0) {
            return None;
        }
        Some(Dynamics {
            max_move,
            turn,
            headings: (std::f32::consts::TAU / turn - 1e-3).ceil().max(1.0) as i32,
            keep_velocity: 1.0 - linear_friction.clamp(0.0, 1.0),
            keep_angular: 1.0 - angular_friction.clamp(0.0, 1.0),
        })
    }
}

/// Plans from `start` to the goal with greedy steps and hybrid A* segments; `None` when no
/// plan was found.
pub(super) fn plan(
    sim: &Simulator,
    episode: &Episode,
    start: AgentState,
) -> Option<Vec<&'static str>> {
    let dynamics = Dynamics::of(sim)?;
    let names = sim.agent().action_names();
    let mut out = Vec::new();
    let mut state = start;
    for _ in 0..10_000 {
        if reached(sim, episode, &state) {
            return Some(out);
        }
        let now = remaining(sim, episode, &state);
        let pocket;
        let aims: Vec<Aim> = if now.is_finite() {
            if let Some(end) = greedy_step(sim, episode, &state, now, &dynamics, &mut out) {
                state = end;
                continue;
            }
            SEGMENTS
                .iter()
                .map(|seg| Aim::Below((now - seg).max(-1.0)))
                .collect()
        } else {
            // In a pocket the goal's field does not reach (a driver other than the oracle
            // led the agent there): first the way out.
            pocket = way_out(sim, Vec3::from_array(state.position))?;
            vec![Aim::OutOfPocket(&pocket)]
        };
        let attempt = RESOLUTIONS.iter().find_map(|res| {
            aims.iter()
                .find_map(|&aim| search(sim, episode, state, aim, &dynamics, names, res))
        });
        let (actions, end) = attempt?;
        if actions.is_empty() {
            return None;
        }
        out.extend(actions);
        state = end;
    }
    None
}

/// One greedy step: turn towards the next corner of the goal field's path (keeping the
/// heading when it is within one turn of it, else the closest heading, else the other one
/// beside the corner) and move forward. Returns the end state and appends the actions when
/// no move collides and the remaining distance `now` drops by a quarter of the longest
/// move, or the goal is reached on the way (the actions then end there).
fn greedy_step(
    sim: &Simulator,
    episode: &Episode,
    state: &AgentState,
    now: f32,
    d: &Dynamics,
    out: &mut Vec<&'static str>,
) -> Option<AgentState> {
    let forward = Actions::single("forward")?;
    let candidates = super::turn_candidates(sim, state, d.max_move, d.turn)?;
    // First without touching anything; else (a start against furniture, a wall the drift
    // reaches) the first that still makes progress sliding along what it touches.
    [false, true]
        .into_iter()
        .find_map(|touch| macro_step(sim, episode, state, now, d, forward, &candidates, touch))
        .map(|(taken, end)| {
            out.extend(taken);
            end
        })
}

/// Simulates the turns of each candidate (`k` turns left, or `-k` right) then a forward
/// move; the first whose moves collide with nothing (or, with `touch`, whatever they touch)
/// and that makes progress, with its actions.
#[allow(clippy::too_many_arguments)]
fn macro_step(
    sim: &Simulator,
    episode: &Episode,
    state: &AgentState,
    now: f32,
    d: &Dynamics,
    forward: Actions,
    candidates: &[i32],
    touch: bool,
) -> Option<(Vec<&'static str>, AgentState)> {
    'candidates: for &k in candidates {
        let (name, count) = if k >= 0 {
            ("turn_left", k)
        } else {
            ("turn_right", -k)
        };
        let a = Actions::single(name)?;
        let mut s = *state;
        let mut taken: Vec<&'static str> = Vec::new();
        for _ in 0..count {
            let t = sim.transition(&s, a);
            if t.collided && !touch {
                continue 'candidates;
            }
            s = t.state;
            taken.push(name);
            if reached(sim, episode, &s) {
                return Some((taken, s));
            }
        }
        let t = sim.transition(&s, forward);
        if t.collided && !touch {
            continue;
        }
        let ok = reached(sim, episode, &t.state)
            || remaining(sim, episode, &t.state) <= now - 0.25 * d.max_move;
        if ok {
            taken.push("forward");
            return Some((taken, t.state));
        }
    }
    None
}

/// A state's cell in the hybrid A*: position (with the floor's height), heading relative to
/// the segment's start (one cell per turn step), and the velocities that carry over.
type Key = [i32; 7];

fn key(s: &AgentState, start_yaw: f32, d: &Dynamics, res: &Resolution) -> Key {
    let q = |v: f32, step: f32| (v / step).round() as i32;
    let heading = q(angle_between(start_yaw, s.yaw), d.turn).rem_euclid(d.headings);
    let carried = |v: f32| if d.keep_velocity > 0.0 { v } else { 0.0 };
    let spin = if d.keep_angular > 0.0 {
        q(s.angular_velocity, 0.5)
    } else {
        0
    };
    [
        q(s.position[0], res.position),
        q(s.position[2], res.position),
        q(s.position[1], 0.05),
        heading,
        q(carried(s.velocity[0]), res.velocity),
        q(carried(s.velocity[1]), res.velocity),
        spin,
    ]
}

/// FxHash's mixing: the keys are small integers, and SipHash's strength buys nothing here.
#[derive(Default)]
struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        let mut chunks = bytes.chunks_exact(8);
        for c in &mut chunks {
            let mut word = [0u8; 8];
            word.copy_from_slice(c);
            self.write_u64(u64::from_le_bytes(word));
        }
        for &b in chunks.remainder() {
            self.write_u64(u64::from(b));
        }
    }
    fn write_u32(&mut self, v: u32) {
        self.write_u64(u64::from(v));
    }
    fn write_i32(&mut self, v: i32) {
        self.write_u64(u64::from(v as u32));
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64);
    }
}

/// Hybrid A* from `start` to a state where `aim` ends it; returns the actions and the end
/// state.
fn search(
    sim: &Simulator,
    episode: &Episode,
    start: AgentState,
    aim: Aim,
    d: &Dynamics,
    names: &'static [&'static str],
    res: &Resolution,
) -> Option<(Vec<&'static str>, AgentState)> {
    let grid = &sim.assets().grid;
    let actions: Vec<Actions> = names.iter().filter_map(|n| Actions::single(n)).collect();
    if actions.len() != names.len() {
        return None;
    }
    // The directions the moves of the action set go, relative to the heading: forward,
    // backward (half a turn), strafes (a quarter turn either way).
    let offsets: Vec<f32> = names
        .iter()
        .filter_map(|n| match *n {
            "forward" => Some(0.0),
            "backward" => Some(std::f32::consts::PI),
            "strafe_left" => Some(std::f32::consts::FRAC_PI_2),
            "strafe_right" => Some(-std::f32::consts::FRAC_PI_2),
            _ => None,
        })
        .collect();
    // Steps still needed: the distance left to the target over the longest move, plus the
    // turns needed before some move goes towards the next corner of the shortest path (the
    // field's anchor). Out of a pocket: the body's way out over the longest move.
    let h = |s: &AgentState, dist: f32| -> f32 {
        let p = Vec3::from_array(s.position);
        let target = match aim {
            Aim::Below(target) => target,
            Aim::OutOfPocket(way) => return WEIGHT * (way.from(p) / d.max_move).floor(),
        };
        let mut turns = 0.0;
        if let Some(anchor) = grid.snap(p).and_then(|sp| sim.goal_anchor(sp)) {
            let a = grid.span_position(anchor as usize) - p;
            if a.x * a.x + a.z * a.z > d.max_move * d.max_move {
                let want = (-a.x).atan2(-a.z);
                let off = offsets
                    .iter()
                    .map(|o| angle_between(s.yaw + o, want).abs())
                    .fold(std::f32::consts::PI, f32::min);
                turns = ((off - 0.5 * d.turn) / d.turn).ceil().max(0.0);
            }
        }
        WEIGHT * (((dist - target).max(0.0) / d.max_move).floor() + turns)
    };
    let start_yaw = start.yaw;
    let mut states: Vec<Node> = vec![(start, 0, None)];
    let mut best: HashMap<Key, u32, BuildHasherDefault<KeyHasher>> = HashMap::default();
    best.insert(key(&start, start_yaw, d, res), 0);
    let mut open = BinaryHeap::new();
    let d0 = remaining(sim, episode, &start);
    open.push(Reverse(((h(&start, d0) * 2000.0) as u64, 0u32, 0u32)));
    let step_cost = 2u32;
    let collision_cost = (2.0 * COLLISION_COST).round() as u32;
    let mut expansions = 0;
    while let Some(Reverse((_, _, id))) = open.pop() {
        let (state, cost, _) = states[id as usize];
        if best.get(&key(&state, start_yaw, d, res)) != Some(&cost) {
            continue; // a cheaper way to this cell was found after this entry was queued
        }
        let dist = remaining(sim, episode, &state);
        let arrived = match aim {
            Aim::Below(target) => dist <= target || reached(sim, episode, &state),
            Aim::OutOfPocket(_) => dist.is_finite(),
        };
        if id != 0 && arrived {
            return Some((backtrack(&states, id, names), state));
        }
        expansions += 1;
        if expansions > res.expansions {
            return None;
        }
        for (ai, a) in actions.iter().enumerate() {
            let t = sim.transition(&state, *a);
            let k = key(&t.state, start_yaw, d, res);
            let ng = cost + step_cost + if t.collided { collision_cost } else { 0 };
            if best.get(&k).is_some_and(|&b| b <= ng) {
                continue;
            }
            let nd = remaining(sim, episode, &t.state);
            if !nd.is_finite() && matches!(aim, Aim::Below(_)) {
                continue; // into a pocket the field does not reach
            }
            best.insert(k, ng);
            states.push((t.state, ng, Some((id, ai as u8))));
            let f = ng as f32 * 0.5 + h(&t.state, nd);
            // Ties go to the deeper state, then to the first created: deterministic.
            open.push(Reverse((
                (f * 2000.0) as u64,
                u32::MAX - ng,
                (states.len() - 1) as u32,
            )));
        }
    }
    None
}
