//! What a navigation grid is baked for: the agent's body and the grid resolution, and the
//! `bake --config` TOML that sets them.

use serde::{Deserialize, Serialize};

use crate::body::{AgentBody, AgentPreset};
use crate::invalid::{Invalid, SettingsCause, TomlError};

/// What the navigation grid is built for: the agent's body and the grid resolution.
///
/// In files (`.nav` headers, `bake --config` TOML) the body's fields are written flat, as
/// `agent_radius`, `agent_height` and `max_climb`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(from = "ParamsFields", into = "ParamsFields")]
pub struct NavParams {
    /// Cell edge in metres.
    pub cell_size: f32,
    /// The body the grid is walkable for.
    pub body: AgentBody,
    /// Steepest walkable floor (degrees).
    pub max_slope_deg: f32,
    /// MINOS's clearance margin (m) beyond the radius in which cells cost more.
    pub clearance_margin: f32,
    /// Cost multiplier of cells within `body.radius + clearance_margin` of an obstacle
    /// (MINOS used 10). 1 disables it and keeps geodesics exact.
    pub clearance_weight: f32,
}

/// [`NavParams`] as stored: flat fields in this order (the `.nav` header's encoding).
#[derive(Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct ParamsFields {
    cell_size: f32,
    agent_radius: f32,
    agent_height: f32,
    max_climb: f32,
    max_slope_deg: f32,
    clearance_margin: f32,
    clearance_weight: f32,
}

impl Default for ParamsFields {
    fn default() -> Self {
        NavParams::default().into()
    }
}

impl From<NavParams> for ParamsFields {
    fn from(p: NavParams) -> Self {
        ParamsFields {
            cell_size: p.cell_size,
            agent_radius: p.body.radius,
            agent_height: p.body.height,
            max_climb: p.body.max_climb,
            max_slope_deg: p.max_slope_deg,
            clearance_margin: p.clearance_margin,
            clearance_weight: p.clearance_weight,
        }
    }
}

impl From<ParamsFields> for NavParams {
    fn from(f: ParamsFields) -> Self {
        NavParams {
            cell_size: f.cell_size,
            body: AgentBody {
                radius: f.agent_radius,
                height: f.agent_height,
                max_climb: f.max_climb,
            },
            max_slope_deg: f.max_slope_deg,
            clearance_margin: f.clearance_margin,
            clearance_weight: f.clearance_weight,
        }
    }
}

impl Default for NavParams {
    /// The default agent preset's body ([`AgentPreset::Habitat`]), 5 cm cells, slope 45°,
    /// exact geodesics (no clearance weighting).
    fn default() -> Self {
        NavParams::for_body(AgentPreset::default().body())
    }
}

impl NavParams {
    /// A grid for `body` with the default resolution (5 cm cells), slope 45° and exact
    /// geodesics.
    pub fn for_body(body: AgentBody) -> Self {
        NavParams {
            cell_size: 0.05,
            body,
            max_slope_deg: 45.0,
            clearance_margin: 0.2,
            clearance_weight: 1.0,
        }
    }

    /// A grid for the body of agent preset `preset`.
    pub fn preset(preset: AgentPreset) -> Self {
        Self::for_body(preset.body())
    }

    /// Checks that every value is usable.
    pub fn validate(&self) -> Result<(), Invalid> {
        let positive = [
            ("cell_size", self.cell_size),
            ("agent_radius", self.body.radius),
            ("agent_height", self.body.height),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(Invalid::new(format!(
                    "{name} = {v}: must be a positive number"
                )));
            }
        }
        if !(self.body.max_climb.is_finite() && self.body.max_climb >= 0.0) {
            return Err(Invalid::new(format!(
                "max_climb = {}: must be >= 0",
                self.body.max_climb
            )));
        }
        if !(0.0..90.0).contains(&self.max_slope_deg) {
            return Err(Invalid::new(format!(
                "max_slope_deg = {}: must be in [0, 90)",
                self.max_slope_deg
            )));
        }
        if !(self.clearance_weight.is_finite() && self.clearance_weight >= 1.0) {
            return Err(Invalid::new(format!(
                "clearance_weight = {}: must be >= 1",
                self.clearance_weight
            )));
        }
        if !(self.clearance_margin.is_finite() && self.clearance_margin >= 0.0) {
            return Err(Invalid::new(format!(
                "clearance_margin = {}: must be >= 0",
                self.clearance_margin
            )));
        }
        if self.cell_size > 1.0 {
            return Err(Invalid::new(format!(
                "cell_size = {}: larger than 1 m",
                self.cell_size
            )));
        }
        Ok(())
    }
}

/// Parameters from a TOML file: an optional `preset = "habitat" | "minos" | "minos-gridworld" |
/// "minos-paper"` (the agent preset whose body the grid is for) and any stored field of [`NavParams`]
/// overriding it, e.g. `cell_size = 0.1` or `agent_height = 1.3`.
pub fn params_from_toml(text: &str, base: NavParams) -> Result<NavParams, SettingsCause> {
    let mut table: toml::Table = text.parse().map_err(|e| TomlError::in_text(e, text))?;
    let base = match table.remove("preset") {
        Some(toml::Value::String(name)) => NavParams {
            body: name.parse::<AgentPreset>()?.body(),
            ..base
        },
        Some(other) => return Err(format!("preset = {other}: expected a string").into()),
        None => base,
    };
    // Plain numbers always make a table; a failure would be a bug, said as such.
    let mut merged = toml::Table::try_from(base).map_err(SettingsCause::Defaults)?;
    for (k, v) in table {
        merged.insert(k, v);
    }
    let params: NavParams = toml::Value::Table(merged)
        .try_into()
        .map_err(TomlError::in_value)?;
    params.validate()?;
    Ok(params)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toml_config_overrides_a_preset() {
        let p = params_from_toml(
            "preset = \"habitat\"\ncell_size = 0.1\n",
            NavParams::preset(AgentPreset::Minos),
        )
        .unwrap();
        assert_eq!(p.body, AgentBody::HABITAT);
        assert_eq!(p.cell_size, 0.1);
        let p = params_from_toml(
            "preset = \"minos\"\nagent_height = 1.3\n",
            NavParams::default(),
        )
        .unwrap();
        assert_eq!(p.body.height, 1.3);
        assert_eq!(p.body.radius, AgentBody::MINOS.radius);
        let err = params_from_toml("cel_size = 0.1", NavParams::default()).unwrap_err();
        assert!(err.to_string().contains("cel_size"), "{err}");
        // Broken TOML: the line, quoted, and the parser's error kept (not its text).
        let err = params_from_toml("cell_size = 0.1\nagent_height =\n", NavParams::default())
            .unwrap_err();
        let SettingsCause::Toml(t) = &err else {
            panic!("not a TOML error: {err:?}");
        };
        assert_eq!(t.line, Some((2, "agent_height =".to_string())));
        assert!(err.to_string().starts_with("line 2: ") && !err.to_string().contains('\n'));
        assert!(params_from_toml("cell_size = -1.0", NavParams::default()).is_err());
    }

    #[test]
    fn stored_fields_keep_their_flat_order() {
        // The `.nav` header encodes NavParams with postcard: seven f32 in this order.
        let p = NavParams {
            cell_size: 1.0,
            body: AgentBody {
                radius: 2.0,
                height: 3.0,
                max_climb: 4.0,
            },
            max_slope_deg: 5.0,
            clearance_margin: 6.0,
            clearance_weight: 7.0,
        };
        let bytes = postcard::to_stdvec(&p).unwrap();
        let expected: Vec<u8> = (1..=7).flat_map(|v| (v as f32).to_le_bytes()).collect();
        assert_eq!(bytes, expected);
        assert_eq!(postcard::from_bytes::<NavParams>(&bytes).unwrap(), p);
    }
}
