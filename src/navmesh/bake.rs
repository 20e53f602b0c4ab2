//! Baking many scenes: load each compiled scene (applying its variant, if the id names one),
//! build its grid, write `DATA/nav/<id>.nav`
//! and its previews, in parallel. A scene that fails is reported and the others finish;
//! grids newer than their scene and baked with the same parameters are kept.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::io::variant_store::{load_scene, newest_input};
use crate::progress::Progress;

use super::build::build;
use super::file::{nav_path, read_nav, write_nav};
use super::params::NavParams;
use super::preview::write_previews;

/// How one scene's bake went.
#[derive(Debug, Clone, PartialEq)]
pub enum BakeOutcome {
    /// Baked now: spans, walkable spans, islands.
    Baked {
        /// Walkable spans.
        walkable: usize,
        /// Islands.
        islands: usize,
    },
    /// Its grid was up to date.
    UpToDate,
    /// It failed, with a one-line reason.
    Failed(String),
}

/// Result of a batch bake: one outcome per scene id, in input order.
#[derive(Debug, Default)]
pub struct BakeReport {
    /// `(scene id, outcome)`.
    pub scenes: Vec<(String, BakeOutcome)>,
}

impl BakeReport {
    /// The failures.
    pub fn failures(&self) -> impl Iterator<Item = (&str, &str)> {
        self.scenes.iter().filter_map(|(id, o)| match o {
            BakeOutcome::Failed(e) => Some((id.as_str(), e.as_str())),
            _ => None,
        })
    }
}

/// Options of a batch bake.
#[derive(Debug, Clone)]
pub struct BakeConfig {
    /// DATA folder.
    pub data: PathBuf,
    /// Scene ids to bake (`<scene>@<variant>` for variants).
    pub ids: Vec<String>,
    /// Agent and grid parameters.
    pub params: NavParams,
    /// Rebake even when up to date.
    pub force: bool,
    /// Write PNG previews.
    pub previews: bool,
}

/// True when `out` exists and is at least as new as every input of `scene_ref`.
fn up_to_date(data: &Path, out: &Path, scene_ref: &str) -> bool {
    let built = std::fs::metadata(out).and_then(|m| m.modified()).ok();
    matches!((built, newest_input(data, scene_ref)), (Some(x), Some(y)) if x >= y)
}

fn bake_one(cfg: &BakeConfig, id: &str) -> BakeOutcome {
    let out = nav_path(&cfg.data, id);
    if !cfg.force && up_to_date(&cfg.data, &out, id) {
        if let Ok(g) = read_nav(&out) {
            if g.params == cfg.params {
                return BakeOutcome::UpToDate;
            }
        }
    }
    let result = (|| -> Result<BakeOutcome, String> {
        let (scene, _) = load_scene(&cfg.data, id).map_err(|e| e.to_string())?;
        let grid = build(&scene, &cfg.params).map_err(|e| e.to_string())?;
        write_nav(&out, &grid).map_err(|e| e.to_string())?;
        if cfg.previews {
            write_previews(&grid, &out).map_err(|e| format!("{}: preview: {e}", out.display()))?;
        }
        Ok(BakeOutcome::Baked {
            walkable: grid.walkable_count(),
            islands: grid.islands.len(),
        })
    })();
    result.unwrap_or_else(BakeOutcome::Failed)
}

/// Bakes every scene of `cfg.ids` in parallel.
pub fn bake_scenes(cfg: &BakeConfig, progress: &dyn Progress) -> BakeReport {
    progress.set_total(cfg.ids.len() as u64);
    let scenes = cfg
        .ids
        .par_iter()
        .map(|id| {
            let outcome = bake_one(cfg, id);
            progress.advance(1);
            (id.clone(), outcome)
        })
        .collect();
    BakeReport { scenes }
}

/// Parameters from a TOML file: an optional `preset = "minos" | "habitat" | "default"` and any
/// [`NavParams`] field overriding it, e.g. `cell_size = 0.1`.
pub fn params_from_toml(text: &str, base: NavParams) -> Result<NavParams, String> {
    let mut table: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| e.message().to_string())?;
    let base = match table.remove("preset") {
        Some(toml::Value::String(name)) => NavParams::preset(&name)
            .ok_or_else(|| format!("unknown preset `{name}` (default, minos, habitat)"))?,
        Some(other) => return Err(format!("preset = {other}: expected a string")),
        None => base,
    };
    let mut merged = toml::Table::try_from(base).map_err(|e| e.to_string())?;
    for (k, v) in table {
        merged.insert(k, v);
    }
    let params: NavParams = toml::Value::Table(merged)
        .try_into()
        .map_err(|e: toml::de::Error| e.message().to_string())?;
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
            NavParams::default(),
        )
        .unwrap();
        assert_eq!(p.agent_height, 1.5);
        assert_eq!(p.cell_size, 0.1);
        assert_eq!(p.agent_radius, 0.1);
        let err = params_from_toml("cel_size = 0.1", NavParams::default()).unwrap_err();
        assert!(err.contains("cel_size"), "{err}");
        assert!(params_from_toml("cell_size = -1.0", NavParams::default()).is_err());
    }
}
