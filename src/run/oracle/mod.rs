//! The oracle: a shortest-path follower for the agent's real action set. At reset it searches
//! (A*) over the agent's reachable states — position, heading and, for the continuous agent,
//! velocities — by simulating each action with the simulator's own motion and collision model,
//! with the goal's geodesic distance field as heuristic. The plan ends where the success test
//! holds, followed by `stop`. Unlike a greedy follower it cannot get stuck at corners.
//!
//! For discrete agents most of a plan is straight walking towards the field's next corner, so
//! each step of the plan first tries a *greedy step*: turn to the lattice heading closest to
//! the next corner (or a neighbouring one) and move forward. It is kept only when the simulated
//! forward move collides with nothing and lowers the remaining geodesic distance by at least
//! half a step (or reaches the goal); otherwise a weighted A* segment plans from there. Every
//! kept step makes progress, so the plan terminates; should the mixed plan fail, the plan is
//! searched again with A* segments alone, so the oracle succeeds wherever the plain search
//! does.
//!
//! Searches keep to floor the goal's distance field reaches. From a pocket of floor the body
//! squeezed into but the field does not reach (another driver led the agent there), either
//! planner first searches for the way out along the body's own walk out (`pocket.rs`).
//!
//! Continuous agents (momentum: a state is a position, heading and velocities, and no two
//! reachable states are quite alike) plan in `continuous.rs`: greedy turn-then-forward steps
//! checked the same way, and a hybrid A* that merges the states of one coarse cell.
//!
//! A VLN episode is walked to the end of its reference path (within 0.5 m), not
//! only into its success radius.
//!
//! Every plan uses only the agent's action set
//! ([`AgentConfig::action_names`](crate::sim::AgentConfig::action_names)): the MINOS paper's
//! agent plans with forward and turns alone.

mod continuous;
mod pocket;

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};
use std::hash::Hasher;

use glam::Vec3;

use crate::episode::{Episode, Goal};
use crate::sim::{Actions, Observation, Simulator};
use crate::sim::{AgentState, Motion};

use super::agents::{action_set, Agent, AgentError, Decision};
use super::metrics::reached;

/// The radius (m) the oracle walks a VLN episode to: the reference path's end, not the edge
/// of the success radius (3 m in VLN-CE), so that it follows the whole reference path (nDTW)
/// and its stop is a success all the same.
const VLN_ARRIVAL: f32 = 0.5;

/// Largest number of states one plan may expand.
const MAX_EXPANSIONS: usize = 40_000;
/// Weight of the heuristic (weighted A*: plans within a small factor of the fewest steps).
const WEIGHT: f32 = 1.5;

/// The oracle agent.
#[derive(Default)]
pub struct OracleAgent {
    plan: Vec<&'static str>,
    next: usize,
    expected: Option<AgentState>,
    episode: Option<Episode>,
}

impl OracleAgent {
    /// A fresh oracle.
    pub fn new() -> Self {
        Self::default()
    }
}

fn key(s: &AgentState, continuous: bool) -> (i32, i32, i32, i32, i32, i32) {
    let q = |v: f32, step: f32| (v / step).round() as i32;
    let yaw = q(s.yaw.rem_euclid(std::f32::consts::TAU), 0.01) % q(std::f32::consts::TAU, 0.01);
    if continuous {
        (
            q(s.position[0], 0.02),
            q(s.position[2], 0.02),
            yaw,
            q(s.velocity[0], 0.1),
            q(s.velocity[1], 0.1),
            q(s.angular_velocity, 0.1),
        )
    } else {
        (
            q(s.position[0], 0.02),
            q(s.position[2], 0.02),
            yaw,
            q(s.position[1], 0.02),
            0,
            0,
        )
    }
}

/// A search node: state, cost from the start (steps here; half steps in the continuous
/// search), and (parent node, index of the action that reached it).
type Node = (AgentState, u32, Option<(u32, u8)>);

/// The actions from a search's start to node `id`, first to last: the names (`names`, indexed
/// as the nodes' action indices) of the actions along its parents.
fn backtrack(states: &[Node], id: u32, names: &[&'static str]) -> Vec<&'static str> {
    let mut out = Vec::new();
    let mut cur = id;
    while let Some((parent, a)) = states[cur as usize].2 {
        out.push(names[a as usize]);
        cur = parent;
    }
    out.reverse();
    out
}

/// Where a search segment ends.
#[derive(Debug, Clone, Copy)]
enum Aim<'a> {
    /// At a state whose remaining distance is at most this (m), or at the goal.
    Below(f32),
    /// At any state the goal's field reaches, from a pocket it does not reach, guided along
    /// the body's way out ([`pocket::way_out`]).
    OutOfPocket(&'a pocket::WayOut),
    /// As [`Aim::OutOfPocket`], at a state from which some action keeps the agent on the
    /// field: where momentum would carry it back into the pocket whatever it did next, no
    /// later search could start (the continuous planner's last resort).
    Steady(&'a pocket::WayOut),
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

/// Progress (m of geodesic distance) each planning segment must make.
const SEGMENT: f32 = 3.0;
/// Progress (m) of a planning segment between greedy steps.
const SHORT_SEGMENT: f32 = 0.5;

/// The geodesic distance that counts for planning: to the goal field, minus the success radius
/// of a point goal; infinite where the field does not reach, also for a point goal. (Not the
/// straight line to the goal there: a pocket of floor that the body can squeeze into but the
/// grid closes off would then look like a short cut across whatever wall parts it from the
/// goal, and a search would lead the agent in and find no way on.)
fn remaining(sim: &Simulator, episode: &Episode, s: &AgentState) -> f32 {
    let p = Vec3::from_array(s.position);
    let Some(d) = sim.goal_field_distance(p) else {
        return f32::INFINITY;
    };
    match &episode.goal {
        Goal::Point { .. } => d - episode.success_radius,
        _ => d,
    }
}

/// Plans with greedy steps where they are safe and A* segments elsewhere: for discrete
/// agents here (falling back to A* segments alone when that fails), for continuous agents in
/// [`continuous`].
fn plan(sim: &Simulator, episode: &Episode, start: AgentState) -> Option<Vec<&'static str>> {
    match sim.agent().motion {
        Motion::Discrete { .. } => {
            let (mut out, start) = out_of_pocket(sim, episode, start)?;
            let rest = plan_with(sim, episode, start, true)
                .or_else(|| plan_with(sim, episode, start, false))?;
            out.extend(rest);
            Some(out)
        }
        Motion::Continuous { .. } => continuous::plan(sim, episode, start),
    }
}

/// A discrete agent's way out of a pocket the goal's field does not reach (a driver other
/// than the oracle led it there): the actions to the first state the field reaches, and that
/// state; no actions and `start` itself on the field. Only a plan's start can be in a pocket
/// (greedy steps and searches keep to the field), so both passes of [`plan`] share it.
fn out_of_pocket(
    sim: &Simulator,
    episode: &Episode,
    start: AgentState,
) -> Option<(Vec<&'static str>, AgentState)> {
    if remaining(sim, episode, &start).is_finite() || reached(sim, episode, &start) {
        return Some((Vec::new(), start));
    }
    let way = pocket::way_out(sim, Vec3::from_array(start.position))?;
    search(sim, episode, start, Aim::OutOfPocket(&way)).filter(|(actions, _)| !actions.is_empty())
}

/// Plans in segments: a greedy step when `greedy` and one is safe, else a weighted A* over
/// simulated states until the remaining geodesic distance has dropped by [`SEGMENT`] (or the
/// goal is reached), so every search stays small.
fn plan_with(
    sim: &Simulator,
    episode: &Episode,
    start: AgentState,
    greedy: bool,
) -> Option<Vec<&'static str>> {
    let mut out = Vec::new();
    let mut state = start;
    for _ in 0..10_000 {
        if reached(sim, episode, &state) {
            return Some(out);
        }
        let now = remaining(sim, episode, &state);
        if !now.is_finite() {
            return None;
        }
        if greedy {
            if let Some(end) = greedy_step(sim, episode, &state, now, &mut out) {
                state = end;
                continue;
            }
        }
        // After a greedy step failed, plan just past the obstacle and go greedy again.
        let segments: &[f32] = if greedy {
            &[SHORT_SEGMENT, SEGMENT, 1.0, 0.3]
        } else {
            &[SEGMENT, 1.0, 0.3]
        };
        let attempt = segments
            .iter()
            .find_map(|seg| search(sim, episode, state, Aim::Below((now - seg).max(-1.0))));
        let (actions, end) = attempt?;
        if actions.is_empty() {
            return None;
        }
        out.extend(actions);
        state = end;
    }
    None
}

/// Signed angle (rad, in [−π, π)) to turn from yaw `from` to yaw `to`.
fn angle_between(from: f32, to: f32) -> f32 {
    (to - from + std::f32::consts::PI).rem_euclid(std::f32::consts::TAU) - std::f32::consts::PI
}

/// One greedy step of a discrete agent: turn towards the field's next corner (keeping the
/// heading when it is within one turn of it, else the lattice heading closest to it, else the
/// other heading beside it) and move forward. Returns the end
/// state and appends the actions when the forward move collides with nothing and lowers the
/// remaining distance `now` by at least half a step, or reaches the goal.
fn greedy_step(
    sim: &Simulator,
    episode: &Episode,
    state: &AgentState,
    now: f32,
    out: &mut Vec<&'static str>,
) -> Option<AgentState> {
    let Motion::Discrete { step, turn_deg } = sim.agent().motion else {
        return None;
    };
    let turn = turn_deg.to_radians();
    if !(step > 0.0 && turn > 0.0) {
        return None;
    }
    let forward = Actions::single("forward")?;
    for k in turn_candidates(sim, state, step, turn)? {
        let (name, count) = if k >= 0 {
            ("turn_left", k)
        } else {
            ("turn_right", -k)
        };
        let a = Actions::single(name)?;
        let mut s = *state;
        for _ in 0..count {
            s = sim.transition(&s, a).state;
        }
        let t = sim.transition(&s, forward);
        if t.collided {
            continue;
        }
        let ok = reached(sim, episode, &t.state)
            || remaining(sim, episode, &t.state) <= now - 0.5 * step;
        if ok {
            out.extend(std::iter::repeat_n(name, count as usize));
            out.push("forward");
            return Some(t.state);
        }
    }
    None
}

/// The turns to try towards the next corner of the goal field's path at least `reach` away
/// from `state`, as counts of turns of `turn` radians (`k` > 0 left, `-k` right): keep the
/// heading while it is within one turn of the corner (turning back and forth costs steps),
/// else the closest heading, else the other one beside the corner. `None` off the grid or at
/// the corner.
fn turn_candidates(sim: &Simulator, state: &AgentState, reach: f32, turn: f32) -> Option<Vec<i32>> {
    let grid = &sim.assets().grid;
    let p = Vec3::from_array(state.position);
    // Aim at the first corner of the anchor chain at least `reach` away.
    let mut corner = sim.goal_anchor(grid.snap(p)?)?;
    for _ in 0..4 {
        let c = grid.span_position(corner as usize);
        if (c.x - p.x).hypot(c.z - p.z) >= reach {
            break;
        }
        match sim.goal_anchor(corner) {
            Some(next) if next != corner => corner = next,
            _ => break,
        }
    }
    let c = grid.span_position(corner as usize);
    let (ax, az) = (c.x - p.x, c.z - p.z);
    if ax * ax + az * az < 1e-8 {
        return None;
    }
    let diff = angle_between(state.yaw, (-ax).atan2(-az)) / turn;
    let nearest = diff.round();
    let other = if diff >= nearest {
        nearest + 1.0
    } else {
        nearest - 1.0
    };
    let keep = if diff.abs() <= 1.0 { Some(0.0) } else { None };
    Some(
        keep.into_iter()
            .chain([nearest, other])
            .map(|k| k as i32)
            .collect(),
    )
}

/// Weighted A* from `start` to a state where `aim` ends it; returns the actions and the end
/// state.
fn search(
    sim: &Simulator,
    episode: &Episode,
    start: AgentState,
    aim: Aim,
) -> Option<(Vec<&'static str>, AgentState)> {
    let continuous = matches!(sim.agent().motion, Motion::Continuous { .. });
    let max_move = match sim.agent().motion {
        Motion::Discrete { step, .. } => step,
        Motion::Continuous { max_speed, .. } => max_speed * sim.agent().dt,
    };
    let turn_step = match sim.agent().motion {
        Motion::Discrete { turn_deg, .. } => turn_deg.to_radians(),
        Motion::Continuous {
            turn_acceleration,
            max_angular_speed,
            ..
        } => (turn_acceleration * sim.agent().dt).min(max_angular_speed) * sim.agent().dt,
    };
    let grid = &sim.assets().grid;
    // Steps still needed: the distance left to the target over the longest move, plus the
    // turns needed to face the next corner of the shortest path (the field's anchor). Out of
    // a pocket: the body's way out over the longest move.
    let h = |s: &AgentState, d: f32| -> f32 {
        let p = Vec3::from_array(s.position);
        let target = match aim {
            Aim::Below(target) => target,
            Aim::OutOfPocket(way) | Aim::Steady(way) => {
                return WEIGHT * (way.from(p) / max_move).floor()
            }
        };
        let mut turns = 0.0;
        if let Some(anchor) = grid.snap(p).and_then(|sp| sim.goal_anchor(sp)) {
            let a = grid.span_position(anchor as usize) - p;
            if a.x * a.x + a.z * a.z > max_move * max_move {
                let want = (-a.x).atan2(-a.z);
                let diff = (want - s.yaw + std::f32::consts::PI).rem_euclid(std::f32::consts::TAU)
                    - std::f32::consts::PI;
                turns = ((diff.abs() - 0.5 * turn_step) / turn_step).ceil().max(0.0);
            }
        }
        WEIGHT * (((d - target).max(0.0) / max_move).floor() + turns)
    };
    let done = |s: &AgentState, d: f32| match aim {
        Aim::Below(target) => d <= target || reached(sim, episode, s),
        // A discrete agent can always turn on the spot: on the field is steady.
        Aim::OutOfPocket(_) | Aim::Steady(_) => d.is_finite(),
    };
    let actions = action_set(sim);
    let mut states: Vec<Node> = vec![(start, 0, None)];
    let mut best: HashMap<(i32, i32, i32, i32, i32, i32), u32> = HashMap::new();
    best.insert(key(&start, continuous), 0);
    let mut open = BinaryHeap::new();
    let d0 = remaining(sim, episode, &start);
    open.push(Reverse(((h(&start, d0) * 1000.0) as u64, 0u32, 0u32)));
    let mut expansions = 0;
    while let Some(Reverse((_, _, id))) = open.pop() {
        let (state, cost, _) = states[id as usize];
        if best.get(&key(&state, continuous)) != Some(&cost) {
            continue; // a cheaper way to this state was found after this entry was queued
        }
        if id != 0 && done(&state, remaining(sim, episode, &state)) {
            return Some((backtrack(&states, id, actions), state));
        }
        expansions += 1;
        if expansions > MAX_EXPANSIONS {
            return None;
        }
        for (ai, name) in actions.iter().enumerate() {
            let Some(a) = Actions::single(name) else {
                continue;
            };
            let t = sim.transition(&state, a);
            let k = key(&t.state, continuous);
            let ng = cost + 1;
            if best.get(&k).is_some_and(|&b| b <= ng) {
                continue;
            }
            let d = remaining(sim, episode, &t.state);
            if !d.is_finite() && matches!(aim, Aim::Below(_)) {
                continue; // into a pocket the field does not reach
            }
            best.insert(k, ng);
            states.push((t.state, ng, Some((id, ai as u8))));
            let f = ng as f32 + h(&t.state, d);
            // Ties go to the deeper state, then to the first created: deterministic.
            open.push(Reverse((
                (f * 1000.0) as u64,
                u32::MAX - ng,
                (states.len() - 1) as u32,
            )));
        }
    }
    None
}

impl Agent for OracleAgent {
    fn reset(&mut self, episode: &Episode, sim: &Simulator) -> Result<(), AgentError> {
        // A VLN episode is walked to its reference path's end (where the plan is possible),
        // not to the edge of its success radius.
        let to_the_end = episode.route.is_some() && episode.success_radius > VLN_ARRIVAL;
        let planned = to_the_end
            .then(|| Episode {
                success_radius: VLN_ARRIVAL,
                ..episode.clone()
            })
            .and_then(|e| Some((plan(sim, &e, sim.state())?, e)));
        let (steps, planned) = match planned {
            Some(p) => p,
            None => (
                plan(sim, episode, sim.state())
                    .ok_or_else(|| AgentError::NoPlan(episode.episode_id.clone()))?,
                episode.clone(),
            ),
        };
        self.episode = Some(planned);
        self.next = 0;
        self.plan = steps;
        self.expected = None;
        Ok(())
    }

    fn decide(&mut self, _obs: &Observation, sim: &Simulator) -> Result<Decision, AgentError> {
        let episode = self
            .episode
            .as_ref()
            .ok_or(AgentError::NotReset("oracle"))?;
        // Re-plan if the world did not do what the plan expected (it is deterministic, so this
        // only happens when the plan came from another state).
        if self.expected.is_some_and(|e| e != sim.state()) {
            self.plan = plan(sim, episode, sim.state())
                .ok_or_else(|| AgentError::LostPlan(episode.episode_id.clone()))?;
            self.next = 0;
        }
        let Some(name) = self.plan.get(self.next).copied() else {
            return Ok(Decision::Stop);
        };
        self.next += 1;
        let a = Actions::single(name).unwrap_or(Actions::IDLE);
        self.expected = Some(sim.transition(&sim.state(), a).state);
        Ok(Decision::Act(a))
    }

    fn stops(&self) -> bool {
        true
    }
}
