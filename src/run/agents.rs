//! Agents that drive a simulator: `random` (uniform over the action set), `minos-random`
//! (MINOS's random baseline: every button pressed with probability ½), `forward` (forward,
//! turning on collision), `oracle` (plans over reachable states, see `oracle.rs`), `replay`
//! (actions from a trajectory file) and `external` (a process speaking JSON lines, see
//! `external.rs`). An agent returns the actions of the next step or `stop`.

use crate::episode::Episode;
use crate::seed::{derive_seed, Rng};
use crate::sim::{Actions, Observation, Simulator};

/// Why an agent could not go on. Messages are one line and name the agent and the episode
/// or step concerned.
#[derive(Debug, thiserror::Error)]
pub enum AgentError {
    /// A replay has no decisions for the episode.
    #[error("the replay file has no episode `{0}`")]
    NoReplay(String),
    /// The oracle found no plan to the goal.
    #[error("episode {0}: no plan found")]
    NoPlan(String),
    /// The oracle's plan no longer matches the agent's state.
    #[error("episode {0}: lost the plan")]
    LostPlan(String),
    /// `decide` was called before `reset`.
    #[error("{0} used before reset")]
    NotReset(&'static str),
    /// The external agent's process could not be started or spoken to.
    #[error("external agent `{command}`")]
    External {
        /// Its command line.
        command: String,
        /// What went wrong.
        #[source]
        fault: ExternalFault,
    },
    /// A person's agent (`minos serve`): the page left, or what it must be shown could not
    /// be made.
    #[error("human: {what}")]
    Human {
        /// What happened (`the page left or was idle too long`, `map of <scene>`).
        what: String,
        /// The cause, when one failed.
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },
    /// The external agent's process closed its output.
    #[error("external agent `{0}` closed its output")]
    ExternalClosed(String),
    /// A reply of the external agent that is not a decision.
    #[error("{0}")]
    Reply(#[from] ReplyError),
}

/// How an external agent's process failed or broke the JSON-lines protocol.
#[derive(Debug, thiserror::Error)]
pub enum ExternalFault {
    /// `sh -c COMMAND` could not be started.
    #[error("cannot start it")]
    Spawn(#[source] std::io::Error),
    /// Its standard input or output could not be taken.
    #[error("no {0}")]
    NoPipe(&'static str),
    /// A message could not be written to it.
    #[error("write")]
    Write(#[source] std::io::Error),
    /// Its reply could not be read.
    #[error("read")]
    Read(#[source] std::io::Error),
    /// Its reply line is not JSON.
    #[error("reply `{}` is not JSON", crate::escape::escape_controls(.reply))]
    NotJson {
        /// The line, trimmed.
        reply: String,
        /// The parser's error.
        #[source]
        source: serde_json::Error,
    },
    /// Its reply is JSON but not a decision.
    #[error("step {step}")]
    Reply {
        /// The step it answered.
        step: u32,
        /// What is wrong with it.
        #[source]
        source: ReplyError,
    },
}

/// A reply of an external agent that is not a decision.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
/// Its message may quote the reply (an action name): control characters are escaped when
/// shown, so the error is one line whatever the reply holds.
#[error("{}", crate::escape::escape_controls(.0))]
pub struct ReplyError(pub String);

/// The name of [`Decision::Stop`] (trajectory tables, action sets, external agents' replies).
pub const STOP: &str = "stop";

/// What an agent does next.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Decision {
    /// Apply these actions for one step.
    Act(Actions),
    /// Declare the goal reached.
    Stop,
}

impl Decision {
    /// A name for the trajectory table: `stop`, `idle`, or the non-zero actions joined by `+`.
    pub fn name(&self) -> String {
        match self {
            Decision::Stop => STOP.into(),
            Decision::Act(a) => {
                let parts: Vec<&str> = a
                    .strengths()
                    .iter()
                    .zip(Actions::NAMES)
                    .filter(|(v, _)| **v > 0.0)
                    .map(|(_, n)| n)
                    .collect();
                if parts.is_empty() {
                    "idle".into()
                } else {
                    parts.join("+")
                }
            }
        }
    }

    /// The 8 action strengths (zeros for stop).
    pub fn strengths(&self) -> [f32; 8] {
        match self {
            Decision::Stop => [0.0; 8],
            Decision::Act(a) => a.strengths(),
        }
    }

    /// Rebuilds a decision from its name (`stop`, `idle`, `forward+turn_left`, …).
    pub fn from_name(name: &str) -> Option<Decision> {
        if name == STOP {
            return Some(Decision::Stop);
        }
        let mut a = Actions::IDLE;
        for part in name.split('+').filter(|&part| part != "idle") {
            *a.strength_mut(part)? += 1.0;
        }
        Some(Decision::Act(a))
    }
}

/// An agent.
pub trait Agent: Send {
    /// Prepares for an episode (the simulator has been reset to it).
    fn reset(&mut self, episode: &Episode, sim: &Simulator) -> Result<(), AgentError>;
    /// Shown each observation before the run writes it and asks [`Agent::decide`]: an agent
    /// that shows it somewhere (a person's page) does so here, so the run's writes happen
    /// while it decides. Nothing by default.
    fn present(&mut self, _obs: &Observation, _sim: &Simulator) -> Result<(), AgentError> {
        Ok(())
    }
    /// The next decision given the latest observation.
    fn decide(&mut self, obs: &Observation, sim: &Simulator) -> Result<Decision, AgentError>;
    /// Whether success needs an explicit `stop` from this agent.
    fn stops(&self) -> bool {
        false
    }
    /// Whether [`Agent::decide`] waits on someone outside this thread (a person, another
    /// process): the run then compresses and writes the observations on a thread of their
    /// own, during that wait, instead of before the next step. No by default.
    fn waits_elsewhere(&self) -> bool {
        false
    }
}

/// The single actions an agent of this simulator chooses among (the agent's
/// [`AgentConfig::action_names`](crate::sim::AgentConfig::action_names)).
pub fn action_set(sim: &Simulator) -> &'static [&'static str] {
    sim.agent().action_names()
}

/// Uniformly random actions, seeded per episode.
pub struct RandomAgent {
    seed: u64,
    rng: Rng,
}

impl RandomAgent {
    /// A random agent for the run's seed.
    pub fn new(seed: u64) -> Self {
        RandomAgent {
            seed,
            rng: Rng::new(seed),
        }
    }
}

impl Agent for RandomAgent {
    fn reset(&mut self, episode: &Episode, _sim: &Simulator) -> Result<(), AgentError> {
        self.rng = Rng::new(derive_seed(
            self.seed,
            &[&episode.episode_id, "random-agent"],
        ));
        Ok(())
    }
    fn decide(&mut self, _obs: &Observation, sim: &Simulator) -> Result<Decision, AgentError> {
        let set = action_set(sim);
        let name = set[self.rng.below(set.len())];
        Ok(Decision::Act(
            Actions::single(name).unwrap_or(Actions::IDLE),
        ))
    }
}

/// MINOS's random baseline (`RoomSimulator.get_random_action`, the agent behind the paper's
/// "random" rows): each action of the action set is pressed independently with probability
/// ½ at full strength, so a step may move forward and turn at once, opposite turns cancel and
/// one step in 2ⁿ (n actions) is idle. For the paper's forward / turn left / turn right agent
/// that is forward on half the steps against a third for [`RandomAgent`].
pub struct MinosRandomAgent {
    seed: u64,
    rng: Rng,
}

impl MinosRandomAgent {
    /// A MINOS random agent for the run's seed.
    pub fn new(seed: u64) -> Self {
        MinosRandomAgent {
            seed,
            rng: Rng::new(seed),
        }
    }
}

impl Agent for MinosRandomAgent {
    fn reset(&mut self, episode: &Episode, _sim: &Simulator) -> Result<(), AgentError> {
        self.rng = Rng::new(derive_seed(
            self.seed,
            &[&episode.episode_id, "minos-random-agent"],
        ));
        Ok(())
    }
    fn decide(&mut self, _obs: &Observation, sim: &Simulator) -> Result<Decision, AgentError> {
        Ok(Decision::Act(press_each_half(
            action_set(sim),
            &mut self.rng,
        )))
    }
}

/// The actions of `set` each pressed with probability ½ (one draw per action, in order).
fn press_each_half(set: &[&str], rng: &mut Rng) -> Actions {
    let mut pressed = Actions::IDLE;
    for name in set {
        let press = rng.below(2) == 1;
        if let (true, Some(one)) = (press, Actions::single(name)) {
            let [f, b, sl, sr, tl, tr, lu, ld] = one.strengths();
            pressed.forward += f;
            pressed.backward += b;
            pressed.strafe_left += sl;
            pressed.strafe_right += sr;
            pressed.turn_left += tl;
            pressed.turn_right += tr;
            pressed.look_up += lu;
            pressed.look_down += ld;
        }
    }
    pressed
}

/// Forward until a collision, then a few turns in a random direction.
pub struct ForwardAgent {
    seed: u64,
    rng: Rng,
    turning: u32,
    turn: &'static str,
}

impl ForwardAgent {
    /// A forward agent for the run's seed.
    pub fn new(seed: u64) -> Self {
        ForwardAgent {
            seed,
            rng: Rng::new(seed),
            turning: 0,
            turn: "turn_left",
        }
    }
}

impl Agent for ForwardAgent {
    fn reset(&mut self, episode: &Episode, _sim: &Simulator) -> Result<(), AgentError> {
        self.rng = Rng::new(derive_seed(
            self.seed,
            &[&episode.episode_id, "forward-agent"],
        ));
        self.turning = 0;
        Ok(())
    }
    fn decide(&mut self, obs: &Observation, _sim: &Simulator) -> Result<Decision, AgentError> {
        if obs.measurements.collision && self.turning == 0 {
            self.turning = 1 + self.rng.below(4) as u32;
            self.turn = if self.rng.chance(0.5) {
                "turn_left"
            } else {
                "turn_right"
            };
        }
        let name = if self.turning > 0 {
            self.turning -= 1;
            self.turn
        } else {
            "forward"
        };
        Ok(Decision::Act(
            Actions::single(name).unwrap_or(Actions::IDLE),
        ))
    }
}

/// Replays recorded decisions (from a trajectory table) per episode.
pub struct ReplayAgent {
    by_episode: std::collections::HashMap<String, Vec<Decision>>,
    current: Vec<Decision>,
    next: usize,
}

impl ReplayAgent {
    /// An agent replaying `(episode id, decisions in step order)`.
    pub fn new(by_episode: std::collections::HashMap<String, Vec<Decision>>) -> Self {
        ReplayAgent {
            by_episode,
            current: Vec::new(),
            next: 0,
        }
    }
}

impl Agent for ReplayAgent {
    fn reset(&mut self, episode: &Episode, _sim: &Simulator) -> Result<(), AgentError> {
        self.current = self
            .by_episode
            .get(&episode.episode_id)
            .cloned()
            .ok_or_else(|| AgentError::NoReplay(episode.episode_id.clone()))?;
        self.next = 0;
        Ok(())
    }
    fn decide(&mut self, _obs: &Observation, _sim: &Simulator) -> Result<Decision, AgentError> {
        let d = self
            .current
            .get(self.next)
            .copied()
            .unwrap_or(Decision::Stop);
        self.next += 1;
        Ok(d)
    }
    fn stops(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minos_random_presses_each_button_independently_with_probability_half() {
        let set = ["forward", "turn_left", "turn_right"];
        let mut rng = Rng::new(7);
        let n = 80_000;
        let mut combos = [0usize; 8];
        for _ in 0..n {
            let a = press_each_half(&set, &mut rng);
            for s in a.strengths() {
                assert!(s == 0.0 || s == 1.0, "{a:?}");
            }
            assert_eq!((a.backward, a.strafe_left, a.look_up), (0.0, 0.0, 0.0));
            let bit = |x: f32| usize::from(x == 1.0);
            combos[bit(a.forward) | bit(a.turn_left) << 1 | bit(a.turn_right) << 2] += 1;
        }
        // Eight equally likely combinations (idle, each button, each pair, all three): each
        // within 5 standard deviations of n/8.
        let sd = (n as f64 * (1.0 / 8.0) * (7.0 / 8.0)).sqrt();
        for (i, c) in combos.iter().enumerate() {
            let off = (*c as f64 - n as f64 / 8.0).abs();
            assert!(off < 5.0 * sd, "combination {i:03b}: {c} of {n}");
        }
    }
}
