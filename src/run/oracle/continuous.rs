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
//! starts with a search for the way out ([`super::pocket`]).

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};
use std::hash::BuildHasherDefault;

use glam::Vec3;

use crate::episode::Episode;
use crate::run::metrics::reached;
use crate::sim::{Actions, Simulator};
use crate::sim::{AgentState, Motion};

use super::pocket::way_out;
use super::{angle_between, backtrack, remaining, Aim, KeyHasher, Node};

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
        // In a pocket the goal's field does not reach (a driver other than the oracle led
        // the agent there): first the way out.
        let pocket = if now.is_finite() {
            None
        } else {
            Some(way_out(sim, Vec3::from_array(state.position))?)
        };
        let aims: Vec<Aim> = match &pocket {
            None => {
                if let Some(end) = greedy_step(sim, episode, &state, now, &dynamics, &mut out) {
                    state = end;
                    continue;
                }
                SEGMENTS
                    .iter()
                    .map(|seg| Aim::Below((now - seg).max(-1.0)))
                    .collect()
            }
            Some(way) => vec![Aim::OutOfPocket(way)],
        };
        let attempt = RESOLUTIONS.iter().find_map(|res| {
            aims.iter()
                .find_map(|&aim| search(sim, episode, state, aim, &dynamics, names, res))
        });
        let (actions, end) = match attempt {
            Some(found) => found,
            // In a pocket whose way out the search did not find (a long turn about), or on
            // the field with every action leading into one (momentum carries the body in
            // whatever it does: it left a pocket still moving back, or a learner ran it at
            // a gap the grid closes): through the pocket to a state that can stay out,
            // turning to head out on the way. Such an end can stay on the field, so this
            // cannot repeat without the searches between making progress; elsewhere a
            // failed search is the end of the plan.
            None if !now.is_finite() || leaves_field(sim, episode, &state, names) => {
                // In a pocket, the walk out found above; at the field's edge, a new one.
                let fresh;
                let here = match &pocket {
                    Some(way) => way,
                    None => {
                        fresh = way_out(sim, Vec3::from_array(state.position))?;
                        &fresh
                    }
                };
                RESOLUTIONS.iter().find_map(|res| {
                    search(
                        sim,
                        episode,
                        state,
                        Aim::Steady(here),
                        &dynamics,
                        names,
                        res,
                    )
                })?
            }
            None => return None,
        };
        if actions.is_empty() {
            return None;
        }
        out.extend(actions);
        state = end;
    }
    None
}

/// Whether every action of `names` takes the agent from `state` off the floor the goal's
/// field reaches.
fn leaves_field(
    sim: &Simulator,
    episode: &Episode,
    state: &AgentState,
    names: &[&'static str],
) -> bool {
    names
        .iter()
        .filter_map(|n| Actions::single(n))
        .all(|a| !remaining(sim, episode, &sim.transition(state, a).state).is_finite())
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
    // Turns needed before some move goes along `a` (none within a move of its end).
    let turns_along = |s: &AgentState, a: Vec3| -> f32 {
        if a.x * a.x + a.z * a.z <= d.max_move * d.max_move {
            return 0.0;
        }
        let want = (-a.x).atan2(-a.z);
        let off = offsets
            .iter()
            .map(|o| angle_between(s.yaw + o, want).abs())
            .fold(std::f32::consts::PI, f32::min);
        ((off - 0.5 * d.turn) / d.turn).ceil().max(0.0)
    };
    // Steps still needed: the distance left to the target over the longest move, plus the
    // turns needed before some move goes towards the next corner of the shortest path (the
    // field's anchor). Out of a pocket: the body's way out over the longest move (for a
    // steady end, plus the turns to head along it).
    let h = |s: &AgentState, dist: f32| -> f32 {
        let p = Vec3::from_array(s.position);
        let target = match aim {
            Aim::Below(target) => target,
            Aim::OutOfPocket(way) => return WEIGHT * (way.from(p) / d.max_move).floor(),
            Aim::Steady(way) => {
                let turns = turns_along(s, way.ahead(p, d.max_move) - p);
                return WEIGHT * ((way.from(p) / d.max_move).floor() + turns);
            }
        };
        let turns = grid
            .snap(p)
            .and_then(|sp| sim.goal_anchor(sp))
            .map_or(0.0, |anchor| {
                turns_along(s, grid.span_position(anchor as usize) - p)
            });
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
            Aim::Steady(_) => {
                dist.is_finite()
                    && actions.iter().any(|a| {
                        remaining(sim, episode, &sim.transition(&state, *a).state).is_finite()
                    })
            }
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
