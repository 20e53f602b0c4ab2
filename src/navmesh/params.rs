//! Agent and grid parameters of a navigation bake, with MINOS and Habitat presets.

use serde::{Deserialize, Serialize};

/// What the navigation grid is built for: the agent's cylinder and the grid resolution.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NavParams {
    /// Cell edge in metres.
    pub cell_size: f32,
    /// Agent cylinder radius (m).
    pub agent_radius: f32,
    /// Agent cylinder height (m): the headroom a walkable span needs.
    pub agent_height: f32,
    /// Highest step the agent climbs (m).
    pub max_climb: f32,
    /// Steepest walkable floor (degrees).
    pub max_slope_deg: f32,
    /// MINOS's clearance margin (m) beyond the radius in which cells cost more.
    pub clearance_margin: f32,
    /// Cost multiplier of cells within `agent_radius + clearance_margin` of an obstacle
    /// (MINOS used 10). 1 disables it and keeps geodesics exact.
    pub clearance_weight: f32,
}

impl Default for NavParams {
    /// minos defaults: 5 cm cells, MINOS's agent (radius 0.1 m, height 1.19 m = eye 1.09 +
    /// radius), climb 0.2 m, slope 45°, exact geodesics (no clearance weighting).
    fn default() -> Self {
        NavParams {
            cell_size: 0.05,
            agent_radius: 0.1,
            agent_height: 1.19,
            max_climb: 0.2,
            max_slope_deg: 45.0,
            clearance_margin: 0.2,
            clearance_weight: 1.0,
        }
    }
}

impl NavParams {
    /// MINOS parity: 10 cm cells, otherwise the defaults.
    pub fn minos() -> Self {
        NavParams {
            cell_size: 0.1,
            ..Self::default()
        }
    }

    /// Habitat's agent: radius 0.1 m, height 1.5 m, climb 0.2 m.
    pub fn habitat() -> Self {
        NavParams {
            agent_height: 1.5,
            ..Self::default()
        }
    }

    /// A preset by name: `default`, `minos` or `habitat`.
    pub fn preset(name: &str) -> Option<Self> {
        match name {
            "default" | "minos-fine" => Some(Self::default()),
            "minos" => Some(Self::minos()),
            "habitat" => Some(Self::habitat()),
            _ => None,
        }
    }

    /// Checks that every value is usable.
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("cell_size", self.cell_size),
            ("agent_radius", self.agent_radius),
            ("agent_height", self.agent_height),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name} = {v}: must be a positive number"));
            }
        }
        if !(self.max_climb.is_finite() && self.max_climb >= 0.0) {
            return Err(format!("max_climb = {}: must be >= 0", self.max_climb));
        }
        if !(0.0..90.0).contains(&self.max_slope_deg) {
            return Err(format!(
                "max_slope_deg = {}: must be in [0, 90)",
                self.max_slope_deg
            ));
        }
        if !(self.clearance_weight.is_finite() && self.clearance_weight >= 1.0) {
            return Err(format!(
                "clearance_weight = {}: must be >= 1",
                self.clearance_weight
            ));
        }
        if !(self.clearance_margin.is_finite() && self.clearance_margin >= 0.0) {
            return Err(format!(
                "clearance_margin = {}: must be >= 0",
                self.clearance_margin
            ));
        }
        if self.cell_size > 1.0 {
            return Err(format!("cell_size = {}: larger than 1 m", self.cell_size));
        }
        Ok(())
    }
}
