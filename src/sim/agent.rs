//! The agent's body and dynamics: a cylinder with MINOS's continuous physics (symplectic
//! Euler with friction F = −k·m·v/dt, clamped speeds) or discrete moves (gridworld, Habitat).

use serde::{Deserialize, Serialize};

use crate::body::{AgentBody, AgentPreset};

/// How actions move the agent.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum Motion {
    /// Forces and friction (MINOS's continuous agent).
    Continuous {
        /// Acceleration of a full-strength move (m/s²).
        step_acceleration: f32,
        /// Speed limit (m/s).
        max_speed: f32,
        /// Linear friction coefficient k (F = −k·m·v/dt).
        linear_friction: f32,
        /// Angular acceleration of a full-strength turn (rad/s²).
        turn_acceleration: f32,
        /// Angular speed limit (rad/s).
        max_angular_speed: f32,
        /// Angular friction coefficient.
        angular_friction: f32,
    },
    /// Fixed steps: each action moves or turns by a fixed amount (times its strength).
    Discrete {
        /// Distance of a move (m).
        step: f32,
        /// Angle of a turn (degrees).
        turn_deg: f32,
    },
}

/// The single actions an agent chooses among (random and oracle agents, Gym action spaces).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ActionSet {
    /// The motion model's own: forward and turns for discrete agents; forward, backward,
    /// strafes and turns for continuous ones.
    #[default]
    Motion,
    /// Forward, turn left and turn right only: the agent of the MINOS paper's experiments.
    ForwardTurn,
}

impl ActionSet {
    fn is_motion(&self) -> bool {
        *self == ActionSet::Motion
    }
}

/// The agent's body, motion model and timing.
///
/// In files (the run manifest) the body's fields are written flat: `radius`, `height`,
/// `eye_height`, `mass`, `max_climb`, `dt`, `look_step_deg`, `motion`, and `actions` when it
/// is not [`ActionSet::Motion`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(from = "AgentFields", into = "AgentFields")]
pub struct AgentConfig {
    /// The body: the same [`AgentBody`] navigation grids are baked for.
    pub body: AgentBody,
    /// Eye height above the floor (m).
    pub eye_height: f32,
    /// Mass (kg).
    pub mass: f32,
    /// Simulated time per step (s).
    pub dt: f32,
    /// Tilt change of a full-strength look action (degrees).
    pub look_step_deg: f32,
    /// Motion model.
    pub motion: Motion,
    /// The actions agents choose among.
    pub actions: ActionSet,
}

/// [`AgentConfig`] as stored: flat fields in this order.
#[derive(Serialize, Deserialize)]
struct AgentFields {
    radius: f32,
    height: f32,
    eye_height: f32,
    mass: f32,
    max_climb: f32,
    dt: f32,
    look_step_deg: f32,
    motion: Motion,
    #[serde(default, skip_serializing_if = "ActionSet::is_motion")]
    actions: ActionSet,
}

impl From<AgentConfig> for AgentFields {
    fn from(a: AgentConfig) -> Self {
        AgentFields {
            radius: a.body.radius,
            height: a.body.height,
            eye_height: a.eye_height,
            mass: a.mass,
            max_climb: a.body.max_climb,
            dt: a.dt,
            look_step_deg: a.look_step_deg,
            motion: a.motion,
            actions: a.actions,
        }
    }
}

impl From<AgentFields> for AgentConfig {
    fn from(f: AgentFields) -> Self {
        AgentConfig {
            body: AgentBody {
                radius: f.radius,
                height: f.height,
                max_climb: f.max_climb,
            },
            eye_height: f.eye_height,
            mass: f.mass,
            dt: f.dt,
            look_step_deg: f.look_step_deg,
            motion: f.motion,
            actions: f.actions,
        }
    }
}

impl AgentConfig {
    /// MINOS's continuous agent: MINOS's body ([`AgentBody::MINOS`]), eye 1.09, mass 32,
    /// acceleration 20 m/s², speed 2 m/s, friction 0.5, turn acceleration 4π rad/s², angular
    /// speed 4π (enforced), angular friction 1, dt 0.1 s.
    pub fn minos_continuous() -> Self {
        AgentConfig {
            body: AgentBody::MINOS,
            eye_height: 1.09,
            mass: 32.0,
            dt: 0.1,
            look_step_deg: 10.0,
            motion: Motion::Continuous {
                step_acceleration: 20.0,
                max_speed: 2.0,
                linear_friction: 0.5,
                turn_acceleration: 4.0 * std::f32::consts::PI,
                max_angular_speed: 4.0 * std::f32::consts::PI,
                angular_friction: 1.0,
            },
            actions: ActionSet::Motion,
        }
    }

    /// The MINOS paper's agent: MINOS's continuous agent ([`AgentConfig::minos_continuous`]:
    /// body, 1.09 m eye, forces and friction) choosing only among forward, turn left and
    /// turn right ([`ActionSet::ForwardTurn`]).
    pub fn minos_paper() -> Self {
        AgentConfig {
            actions: ActionSet::ForwardTurn,
            ..Self::minos_continuous()
        }
    }

    /// MINOS's gridworld agent: 0.4 m steps, 90° turns.
    pub fn minos_gridworld() -> Self {
        AgentConfig {
            motion: Motion::Discrete {
                step: 0.4,
                turn_deg: 90.0,
            },
            ..Self::minos_continuous()
        }
    }

    /// Habitat's discrete agent: Habitat's body ([`AgentBody::HABITAT`], 1.5 m), eye 1.25 m,
    /// 0.25 m steps, 10° turns.
    pub fn habitat() -> Self {
        AgentConfig {
            body: AgentBody::HABITAT,
            eye_height: 1.25,
            motion: Motion::Discrete {
                step: 0.25,
                turn_deg: 10.0,
            },
            ..Self::minos_continuous()
        }
    }

    /// The agent of preset `preset`.
    pub fn preset(preset: AgentPreset) -> Self {
        match preset {
            AgentPreset::Habitat => Self::habitat(),
            AgentPreset::Minos => Self::minos_continuous(),
            AgentPreset::MinosGridworld => Self::minos_gridworld(),
            AgentPreset::MinosPaper => Self::minos_paper(),
        }
    }

    /// The names of the single actions agents choose among ([`AgentConfig::actions`]), in a
    /// fixed order (see [`Actions::single`]).
    pub fn action_names(&self) -> &'static [&'static str] {
        match (self.actions, self.motion) {
            (ActionSet::ForwardTurn, _) | (ActionSet::Motion, Motion::Discrete { .. }) => {
                &["forward", "turn_left", "turn_right"]
            }
            (ActionSet::Motion, Motion::Continuous { .. }) => &[
                "forward",
                "backward",
                "strafe_left",
                "strafe_right",
                "turn_left",
                "turn_right",
            ],
        }
    }
}

/// What the agent does in one step; strengths in [0, 1], several may combine.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Actions {
    /// Move forwards.
    pub forward: f32,
    /// Move backwards.
    pub backward: f32,
    /// Strafe left.
    pub strafe_left: f32,
    /// Strafe right.
    pub strafe_right: f32,
    /// Turn left (counter-clockwise).
    pub turn_left: f32,
    /// Turn right.
    pub turn_right: f32,
    /// Look up.
    pub look_up: f32,
    /// Look down.
    pub look_down: f32,
}

impl Actions {
    /// Nothing (idle).
    pub const IDLE: Actions = Actions {
        forward: 0.0,
        backward: 0.0,
        strafe_left: 0.0,
        strafe_right: 0.0,
        turn_left: 0.0,
        turn_right: 0.0,
        look_up: 0.0,
        look_down: 0.0,
    };

    /// Names of the single actions, in a fixed order.
    pub const NAMES: [&'static str; 9] = [
        "forward",
        "backward",
        "strafe_left",
        "strafe_right",
        "turn_left",
        "turn_right",
        "look_up",
        "look_down",
        "idle",
    ];

    /// The strength of the single action `name` (`forward` … `look_down`, as
    /// [`Actions::NAMES`] spells them; not `idle`), `None` for another name: the one place
    /// action names meet fields, for every reader of named strengths.
    pub fn strength_mut(&mut self, name: &str) -> Option<&mut f32> {
        Some(match name {
            "forward" => &mut self.forward,
            "backward" => &mut self.backward,
            "strafe_left" => &mut self.strafe_left,
            "strafe_right" => &mut self.strafe_right,
            "turn_left" => &mut self.turn_left,
            "turn_right" => &mut self.turn_right,
            "look_up" => &mut self.look_up,
            "look_down" => &mut self.look_down,
            _ => return None,
        })
    }

    /// One action at full strength, by name (`idle` for nothing).
    pub fn single(name: &str) -> Option<Actions> {
        let mut a = Actions::IDLE;
        if name != "idle" {
            *a.strength_mut(name)? = 1.0;
        }
        Some(a)
    }

    /// The eight strengths in the order of [`Actions::NAMES`] (forward … look_down).
    pub fn strengths(&self) -> [f32; 8] {
        [
            self.forward,
            self.backward,
            self.strafe_left,
            self.strafe_right,
            self.turn_left,
            self.turn_right,
            self.look_up,
            self.look_down,
        ]
    }

    /// The name of these actions when they are one single action at full strength (or
    /// `idle`, nothing), as [`Actions::single`] spells it; `None` for any other mix.
    pub fn single_name(&self) -> Option<&'static str> {
        Actions::NAMES
            .iter()
            .copied()
            .find(|n| Actions::single(n).is_some_and(|s| s == *self))
    }

    /// Strengths clamped to [0, 1] (NaN → 0).
    pub fn clamped(self) -> Actions {
        let c = |v: f32| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        Actions {
            forward: c(self.forward),
            backward: c(self.backward),
            strafe_left: c(self.strafe_left),
            strafe_right: c(self.strafe_right),
            turn_left: c(self.turn_left),
            turn_right: c(self.turn_right),
            look_up: c(self.look_up),
            look_down: c(self.look_down),
        }
    }
}

/// The agent's state.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct AgentState {
    /// Position of the base (x, floor height, z).
    pub position: [f32; 3],
    /// Yaw (rad, CCW about +Y, 0 faces −Z).
    pub yaw: f32,
    /// Tilt (rad, positive up), within ±π/2.
    pub tilt: f32,
    /// Horizontal velocity (x, z) in m/s.
    pub velocity: [f32; 2],
    /// Angular velocity about +Y (rad/s).
    pub angular_velocity: f32,
}

/// The desired displacement (world x, z) and rotation of one step, before collisions.
pub fn intended_motion(
    cfg: &AgentConfig,
    state: &mut AgentState,
    actions: Actions,
) -> ([f32; 2], f32) {
    let a = actions.clamped();
    let fwd = a.forward - a.backward;
    let side = a.strafe_right - a.strafe_left;
    let turn = a.turn_left - a.turn_right;
    let (sin, cos) = state.yaw.sin_cos();
    // Agent frame: forward = (−sin, −cos), right = (cos, −sin) in (x, z).
    let dir = |f: f32, s: f32| [-sin * f + cos * s, -cos * f - sin * s];
    let look = (a.look_up - a.look_down) * cfg.look_step_deg.to_radians();
    state.tilt =
        (state.tilt + look).clamp(-std::f32::consts::FRAC_PI_2, std::f32::consts::FRAC_PI_2);
    match cfg.motion {
        Motion::Discrete { step, turn_deg } => {
            state.velocity = [0.0, 0.0];
            state.angular_velocity = 0.0;
            let d = dir(fwd, side);
            ([d[0] * step, d[1] * step], turn * turn_deg.to_radians())
        }
        Motion::Continuous {
            step_acceleration,
            max_speed,
            linear_friction,
            turn_acceleration,
            max_angular_speed,
            angular_friction,
        } => {
            let acc = dir(fwd, side);
            let k = linear_friction.clamp(0.0, 1.0);
            let mut v = [
                (1.0 - k) * state.velocity[0] + acc[0] * step_acceleration * cfg.dt,
                (1.0 - k) * state.velocity[1] + acc[1] * step_acceleration * cfg.dt,
            ];
            let speed = (v[0] * v[0] + v[1] * v[1]).sqrt();
            if speed > max_speed {
                v = [v[0] * max_speed / speed, v[1] * max_speed / speed];
            }
            let ka = angular_friction.clamp(0.0, 1.0);
            let w = ((1.0 - ka) * state.angular_velocity + turn * turn_acceleration * cfg.dt)
                .clamp(-max_angular_speed, max_angular_speed);
            state.velocity = v;
            state.angular_velocity = w;
            ([v[0] * cfg.dt, v[1] * cfg.dt], w * cfg.dt)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_action_name_reaches_its_own_strength() {
        for (i, name) in Actions::NAMES[..8].iter().enumerate() {
            let mut a = Actions::IDLE;
            *a.strength_mut(name).expect("a single action") = 0.5;
            let mut want = [0.0; 8];
            want[i] = 0.5;
            assert_eq!(a.strengths(), want, "{name}");
            assert_eq!(Actions::single(name).map(|s| s.strengths()[i]), Some(1.0));
            assert_eq!(
                Actions::single(name).and_then(|s| s.single_name()),
                Some(*name)
            );
        }
        assert_eq!(Actions::NAMES[8], "idle");
        let mut idle = Actions::IDLE;
        assert_eq!(idle.strength_mut("idle"), None);
        assert_eq!(idle.strength_mut("jump"), None);
        assert_eq!(Actions::single("idle"), Some(Actions::IDLE));
        assert_eq!(Actions::single("jump"), None);
    }
}
