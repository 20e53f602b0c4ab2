//! The oracle: a shortest-path follower for the agent's real action set. At reset it searches
//! (A*) over the agent's reachable states — position, heading and, for the continuous agent,
//! velocities — by simulating each action with the simulator's own motion and collision model,
//! with the goal's geodesic distance field as heuristic. The plan ends where the success test
//! holds, followed by `stop`. Unlike a greedy follower it cannot get stuck at corners.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};

use glam::Vec3;

use crate::episode::{Episode, Goal};
use crate::sim::agent::{AgentState, Motion};
use crate::sim::{Actions, Observation, Simulator};

use super::agents::{action_set, Agent, Decision};

/// Largest number of states one plan may expand.
const MAX_EXPANSIONS: usize = 400_000;

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

/// True when the agent at `state` satisfies the episode's success test.
pub fn reached(sim: &Simulator, episode: &Episode, state: &AgentState) -> bool {
    let p = Vec3::from_array(state.position);
    match &episode.goal {
        Goal::Point { position } => p.distance(Vec3::from_array(*position)) <= episode.success_radius,
        Goal::Object { .. } | Goal::Room { .. } => sim.goal_field_distance(p).is_some_and(|d| {
            // On a goal span: the field is 0 there; allow the offset within the cell.
            d <= sim.assets().grid.cell() * 0.75
        }),
    }
}

fn key(s: &AgentState, continuous: bool) -> (i32, i32, i32, i32, i32, i32) {
    let q = |v: f32, step: f32| (v / step).round() as i32;
    let yaw = q(s.yaw.rem_euclid(std::f32::consts::TAU), 0.002) % q(std::f32::consts::TAU, 0.002);
    if continuous {
        (q(s.position[0], 0.01), q(s.position[2], 0.01), yaw, q(s.velocity[0], 0.05), q(s.velocity[1], 0.05), q(s.angular_velocity, 0.05))
    } else {
        (q(s.position[0], 0.01), q(s.position[2], 0.01), yaw, q(s.position[1], 0.01), 0, 0)
    }
}

/// A* over simulated states; returns the action names of a shortest plan.
fn plan(sim: &Simulator, episode: &Episode, start: AgentState) -> Option<Vec<&'static str>> {
    let continuous = matches!(sim.agent().motion, Motion::Continuous { .. });
    let max_move = match sim.agent().motion {
        Motion::Discrete { step, .. } => step,
        Motion::Continuous { max_speed, .. } => max_speed * sim.agent().dt,
    };
    let h = |s: &AgentState| -> f32 {
        let p = Vec3::from_array(s.position);
        let d = match &episode.goal {
            Goal::Point { position } => sim
                .goal_field_distance(p)
                .unwrap_or_else(|| p.distance(Vec3::from_array(*position)))
                - episode.success_radius,
            _ => sim.goal_field_distance(p).unwrap_or(f32::INFINITY),
        };
        (d.max(0.0) / max_move).floor()
    };
    let actions = action_set(sim);
    let mut states: Vec<(AgentState, u32, Option<(u32, u8)>)> = vec![(start, 0, None)];
    let mut best: HashMap<(i32, i32, i32, i32, i32, i32), u32> = HashMap::new();
    best.insert(key(&start, continuous), 0);
    let mut open = BinaryHeap::new();
    open.push(Reverse(((h(&start) * 1000.0) as u64, 0u32, 0u32)));
    let mut expansions = 0;
    while let Some(Reverse((_, g, id))) = open.pop() {
        let (state, cost, _) = states[id as usize];
        if cost != g {
            continue;
        }
        if reached(sim, episode, &state) {
            let mut out = Vec::new();
            let mut cur = id;
            while let Some((parent, a)) = states[cur as usize].2 {
                out.push(actions[a as usize]);
                cur = parent;
            }
            out.reverse();
            return Some(out);
        }
        expansions += 1;
        if expansions > MAX_EXPANSIONS {
            return None;
        }
        for (ai, name) in actions.iter().enumerate() {
            let Some(a) = Actions::single(name) else { continue };
            let t = sim.transition(&state, a);
            let k = key(&t.state, continuous);
            let ng = cost + 1;
            if best.get(&k).is_some_and(|&b| b <= ng) {
                continue;
            }
            let hv = h(&t.state);
            if !hv.is_finite() {
                continue;
            }
            best.insert(k, ng);
            states.push((t.state, ng, Some((id, ai as u8))));
            let f = ng as f32 + hv;
            // Ties go to the deeper state, then to the first created: deterministic.
            open.push(Reverse(((f * 1000.0) as u64, ng, (states.len() - 1) as u32)));
        }
    }
    None
}

impl Agent for OracleAgent {
    fn reset(&mut self, episode: &Episode, sim: &Simulator) -> Result<(), String> {
        self.episode = Some(episode.clone());
        self.next = 0;
        self.plan = plan(sim, episode, sim.state()).ok_or_else(|| format!("episode {}: no plan found", episode.episode_id))?;
        self.expected = None;
        Ok(())
    }

    fn decide(&mut self, _obs: &Observation, sim: &Simulator) -> Result<Decision, String> {
        let episode = self.episode.as_ref().ok_or("oracle used before reset")?;
        // Re-plan if the world did not do what the plan expected (it is deterministic, so this
        // only happens when the plan came from another state).
        if self.expected.is_some_and(|e| e != sim.state()) {
            self.plan = plan(sim, episode, sim.state()).ok_or_else(|| format!("episode {}: lost the plan", episode.episode_id))?;
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
