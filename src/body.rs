//! The agent's body, shared by navigation grids and the simulator: a navigation grid is baked
//! for one [`AgentBody`] and a simulator moves one, and the two must be the same body
//! ([`AgentBody::check_grid`]). Agent presets ([`AgentPreset`]) name bodies (and, in the
//! simulator, motion models) with one vocabulary across every command.

use std::fmt;

use serde::{Deserialize, Serialize};

/// The agent's cylinder: what walkable space, collisions and step climbing depend on.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AgentBody {
    /// Cylinder radius (m).
    pub radius: f32,
    /// Cylinder height (m): the headroom a walkable floor needs.
    pub height: f32,
    /// Highest step the body climbs (m).
    pub max_climb: f32,
}

impl AgentBody {
    /// MINOS's agent: radius 0.1 m, height 1.19 m (eye 1.09 m + radius), climb 0.2 m.
    pub const MINOS: AgentBody = AgentBody {
        radius: 0.1,
        height: 1.19,
        max_climb: 0.2,
    };

    /// Habitat's agent: radius 0.1 m, height 1.5 m, climb 0.2 m.
    pub const HABITAT: AgentBody = AgentBody {
        radius: 0.1,
        height: 1.5,
        max_climb: 0.2,
    };

    /// Whether `other` is the same body (to a micrometre, so a body that went through a
    /// text file still matches).
    pub fn same_as(&self, other: &AgentBody) -> bool {
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-6;
        close(self.radius, other.radius)
            && close(self.height, other.height)
            && close(self.max_climb, other.max_climb)
    }

    /// The preset whose body this is, if any (the first of [`AgentPreset::ALL`]).
    pub fn preset(&self) -> Option<AgentPreset> {
        AgentPreset::ALL
            .into_iter()
            .find(|p| p.body().same_as(self))
    }

    /// Checks that a grid baked for body `grid` serves an agent of this body.
    pub fn check_grid(&self, grid: &AgentBody) -> Result<(), BodyMismatch> {
        if self.same_as(grid) {
            Ok(())
        } else {
            Err(BodyMismatch {
                grid: *grid,
                agent: *self,
            })
        }
    }
}

impl fmt::Display for AgentBody {
    /// `radius 0.1 m, height 1.5 m, climb 0.2 m (habitat)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "radius {} m, height {} m, climb {} m",
            self.radius, self.height, self.max_climb
        )?;
        if let Some(p) = self.preset() {
            write!(f, " ({})", p.body_name())?;
        }
        Ok(())
    }
}

/// A navigation grid baked for another body than the agent's.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error(
    "the navigation grid was baked for body {grid}, the agent has body {agent}: rebake the \
     grids for the agent's body, or allow the mismatch"
)]
pub struct BodyMismatch {
    /// The body the grid was baked for.
    pub grid: AgentBody,
    /// The agent's body.
    pub agent: AgentBody,
}

/// The body a batch works for, and whether grids baked for another body are accepted
/// (`--allow-body-mismatch`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyRule {
    /// The agent's body.
    pub body: AgentBody,
    /// Accept grids baked for another body (with a warning).
    pub allow_mismatch: bool,
}

impl BodyRule {
    /// Grids must be baked for `body`.
    pub fn strict(body: AgentBody) -> Self {
        BodyRule {
            body,
            allow_mismatch: false,
        }
    }

    /// Checks a grid baked for body `grid`; a mismatch that is allowed is logged and passes.
    pub fn check(&self, grid: &AgentBody) -> Result<(), BodyMismatch> {
        match self.body.check_grid(grid) {
            Err(e) if self.allow_mismatch => {
                tracing::warn!("{}; the mismatch is allowed", crate::escape::error_line(&e));
                Ok(())
            }
            r => r,
        }
    }
}

/// Named agents: one vocabulary for `bake`, `episodes`, `render`, `run` and the library.
/// A preset fixes the body (and, for the simulator, the motion model).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum AgentPreset {
    /// Habitat's discrete agent (1.5 m body, 0.25 m steps, 10° turns): the default.
    #[default]
    Habitat,
    /// MINOS's continuous agent (1.19 m body, forces and friction).
    Minos,
    /// MINOS's gridworld agent (1.19 m body, 0.4 m steps, 90° turns).
    MinosGridworld,
    /// The MINOS paper's agent: MINOS's continuous agent choosing only among forward, turn
    /// left and turn right, with a grey 90° camera by default.
    MinosPaper,
}

impl AgentPreset {
    /// Every preset.
    pub const ALL: [AgentPreset; 4] = [
        AgentPreset::Habitat,
        AgentPreset::Minos,
        AgentPreset::MinosGridworld,
        AgentPreset::MinosPaper,
    ];

    /// The preset's name on the command line and in files.
    pub fn name(self) -> &'static str {
        crate::vocab::Vocabulary::term_name(self)
    }

    /// The success radius (m) of PointGoal episodes sampled for the preset: MINOS's 0.4 m
    /// for MINOS's agents, Habitat's 0.2 m for Habitat's.
    pub fn point_goal_radius(self) -> f32 {
        match self {
            AgentPreset::Habitat => 0.2,
            AgentPreset::Minos | AgentPreset::MinosGridworld | AgentPreset::MinosPaper => 0.4,
        }
    }

    /// The name of the preset's body (the two MINOS agents share one).
    fn body_name(self) -> &'static str {
        match self {
            AgentPreset::Habitat => "habitat",
            AgentPreset::Minos | AgentPreset::MinosGridworld | AgentPreset::MinosPaper => "minos",
        }
    }

    /// The preset's body.
    pub fn body(self) -> AgentBody {
        match self {
            AgentPreset::Habitat => AgentBody::HABITAT,
            AgentPreset::Minos | AgentPreset::MinosGridworld | AgentPreset::MinosPaper => {
                AgentBody::MINOS
            }
        }
    }
}

impl crate::vocab::Vocabulary for AgentPreset {
    const WHAT: &'static str = "agent preset";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: AgentPreset::Habitat,
            name: "habitat",
            aliases: &[],
            help: "Habitat's agent: 1.5 m body, 0.25 m steps, 10° turns",
        },
        crate::vocab::Term {
            value: AgentPreset::Minos,
            name: "minos",
            aliases: &["minos-continuous"],
            help: "MINOS's continuous agent: 1.19 m body, forces and friction",
        },
        crate::vocab::Term {
            value: AgentPreset::MinosGridworld,
            name: "minos-gridworld",
            aliases: &[],
            help: "MINOS's gridworld agent: 1.19 m body, 0.4 m steps, 90° turns",
        },
        crate::vocab::Term {
            value: AgentPreset::MinosPaper,
            name: "minos-paper",
            aliases: &[],
            help: "the MINOS paper's agent: continuous, forward and turns only, grey 90° camera",
        },
    ];
}

crate::vocab::name_traits!(AgentPreset);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_round_trip_by_name() {
        for p in AgentPreset::ALL {
            assert_eq!(p.name().parse::<AgentPreset>(), Ok(p));
        }
        assert_eq!("minos-continuous".parse(), Ok(AgentPreset::Minos));
        assert!("default".parse::<AgentPreset>().is_err());
    }

    #[test]
    fn a_mismatch_names_both_bodies_and_the_rebake() {
        let err = AgentBody::HABITAT
            .check_grid(&AgentBody::MINOS)
            .unwrap_err()
            .to_string();
        assert!(err.contains("height 1.19 m"), "{err}");
        assert!(err.contains("height 1.5 m"), "{err}");
        // The library names no command or flag: the front doors add their own hint.
        assert!(err.contains("rebake") && !err.contains("--"), "{err}");
        assert!(AgentBody::MINOS.check_grid(&AgentBody::MINOS).is_ok());
        let odd = AgentBody {
            height: 1.3,
            ..AgentBody::MINOS
        };
        let err = odd.check_grid(&AgentBody::MINOS).unwrap_err().to_string();
        assert!(err.contains("height 1.3 m"), "{err}");
        let allowed = BodyRule {
            allow_mismatch: true,
            ..BodyRule::strict(odd)
        };
        assert!(allowed.check(&AgentBody::MINOS).is_ok());
        assert!(BodyRule::strict(odd).check(&AgentBody::MINOS).is_err());
    }
}
