//! Procedural houses written in real dataset formats (`minos generate`).
//!
//! SUNCG is no longer distributed, so minos makes its own houses and writes them exactly as
//! SUNCG laid them out; they are also the built-in demo data. A house is first planned in
//! memory ([`plan_house`]: rooms, doors, windows, stairs, furniture) and then written
//! ([`generate`]). Everything random derives from `(seed, house id)`, so the same
//! configuration gives byte-identical files whatever the thread count.

pub mod catalog;
mod furnish;
pub mod layout;
pub mod mp3d_writer;
mod objwrite;
pub mod plan;
pub mod suncg_writer;
pub mod textures;

use std::path::Path;

use rayon::prelude::*;

use crate::progress::Progress;
use crate::seed::{derive_seed, Rng};

pub use plan::HousePlan;

/// Bumped when the generator's output for a given configuration changes; part of house ids.
pub const GENERATOR_VERSION: u32 = 2;

/// The on-disk format to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputFormat {
    /// SUNCG: `house/`, `room/`, `object/`, `metadata/`.
    Suncg,
    /// Matterport3D: `<id>/house_segmentations/<id>.house` and `.ply`.
    Mp3d,
}

/// What to generate.
#[derive(Debug, Clone, PartialEq)]
pub struct GenerateConfig {
    /// Number of houses.
    pub houses: usize,
    /// User seed.
    pub seed: u64,
    /// Inclusive range of rooms per house (stair halls included).
    pub rooms: (usize, usize),
    /// Inclusive range of levels per house (1 or 2).
    pub levels: (usize, usize),
    /// Probability that the only door of a dead-end room is closed.
    pub closed_door_prob: f64,
}

impl Default for GenerateConfig {
    fn default() -> Self {
        GenerateConfig {
            houses: 10,
            seed: 0,
            rooms: (3, 8),
            levels: (1, 2),
            closed_door_prob: 0.25,
        }
    }
}

/// Errors of `generate`.
#[derive(Debug, thiserror::Error)]
pub enum GenerateError {
    /// The configuration is not usable.
    #[error("invalid configuration: {0}")]
    Config(String),
    /// Writing failed.
    #[error("{path}: {source}")]
    Io {
        /// What was being written.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
}

impl GenerateConfig {
    /// Checks ranges: 1 ≤ rooms ≤ 24, levels in 1..=2, probability in [0, 1].
    pub fn validate(&self) -> Result<(), GenerateError> {
        let bad = |m: String| Err(GenerateError::Config(m));
        if self.rooms.0 < 1 || self.rooms.0 > self.rooms.1 || self.rooms.1 > 24 {
            return bad(format!(
                "rooms {}..{}: need 1 <= MIN <= MAX <= 24",
                self.rooms.0, self.rooms.1
            ));
        }
        if self.levels.0 < 1 || self.levels.0 > self.levels.1 || self.levels.1 > 2 {
            return bad(format!(
                "levels {}..{}: need 1 <= MIN <= MAX <= 2",
                self.levels.0, self.levels.1
            ));
        }
        if !(0.0..=1.0).contains(&self.closed_door_prob) {
            return bad(format!(
                "closed-door probability {} is not in [0, 1]",
                self.closed_door_prob
            ));
        }
        Ok(())
    }

    fn fingerprint(&self) -> String {
        format!(
            "v{GENERATOR_VERSION}:r{}-{}:l{}-{}:c{}",
            self.rooms.0, self.rooms.1, self.levels.0, self.levels.1, self.closed_door_prob
        )
    }
}

/// The id of house `index`: 32 hex digits fixed by the seed, the index and the configuration.
pub fn house_id(cfg: &GenerateConfig, index: usize) -> String {
    let fp = cfg.fingerprint();
    let i = index.to_string();
    let hi = derive_seed(cfg.seed, &["house-id-hi", &i, &fp]);
    let lo = derive_seed(cfg.seed, &["house-id-lo", &i, &fp]);
    format!("{hi:016x}{lo:016x}")
}

/// Plans house `index` in memory (deterministic in `(cfg, index)`).
pub fn plan_house(cfg: &GenerateConfig, index: usize) -> HousePlan {
    let id = house_id(cfg, index);
    let mut rng = Rng::new(derive_seed(cfg.seed, &[&id, "generate"]));
    for attempt in 0..16 {
        let mut nlevels = rng.range_usize(cfg.levels.0, cfg.levels.1);
        let n = rng.range_usize(cfg.rooms.0, cfg.rooms.1);
        // Two levels need a stair hall on each and at least one room on each.
        if nlevels == 2 && n < 4 {
            nlevels = 1;
        }
        let programmes = if nlevels == 1 {
            vec![layout::programme(&mut rng, n, false)]
        } else {
            let k0 = (n - 1) / 2;
            let k1 = n - 2 - k0;
            vec![
                layout::programme(&mut rng, k0, false),
                layout::programme(&mut rng, k1, true),
            ]
        };
        let scale = 1.0 + 0.12 * attempt as f64;
        if let Some(mut levels) = layout::layout(&mut rng, &programmes, cfg.closed_door_prob, scale)
        {
            for level in &mut levels {
                furnish::furnish_level(&mut rng, level);
            }
            return HousePlan { id, levels };
        }
    }
    // A single room always lays out.
    let programme = vec![layout::programme(&mut rng, 1, false)];
    let mut levels =
        layout::layout(&mut rng, &programme, cfg.closed_door_prob, 1.0).unwrap_or_default();
    for level in &mut levels {
        furnish::furnish_level(&mut rng, level);
    }
    HousePlan { id, levels }
}

/// What `generate` did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GenerateReport {
    /// Ids of the houses written now.
    pub written: Vec<String>,
    /// Ids of the houses already complete on disk (kept).
    pub skipped: Vec<String>,
}

/// Generates `cfg.houses` houses into `out` in `format`. Houses whose `house.json` already
/// exists are kept unless `force` (same configuration ⇒ same bytes, so resuming is safe).
pub fn generate(
    cfg: &GenerateConfig,
    format: OutputFormat,
    out: &Path,
    force: bool,
    progress: &dyn Progress,
) -> Result<GenerateReport, GenerateError> {
    cfg.validate()?;
    let io_err = |path: &Path| {
        let path = path.display().to_string();
        move |source| GenerateError::Io { path, source }
    };
    if format == OutputFormat::Suncg {
        suncg_writer::write_library(out).map_err(io_err(out))?;
    }
    progress.set_total(cfg.houses as u64);
    let results: Vec<Result<(String, bool), GenerateError>> = (0..cfg.houses)
        .into_par_iter()
        .map(|i| {
            let id = house_id(cfg, i);
            let done = match format {
                OutputFormat::Suncg => out.join("house").join(&id).join("house.json"),
                OutputFormat::Mp3d => mp3d_writer::house_path(out, &id),
            };
            let r = if !force && done.is_file() {
                Ok((id, false))
            } else {
                let plan = plan_house(cfg, i);
                match format {
                    OutputFormat::Suncg => suncg_writer::write_house(out, &plan)
                        .map_err(io_err(&out.join("house").join(&plan.id))),
                    OutputFormat::Mp3d => {
                        mp3d_writer::write_house(out, &plan).map_err(io_err(&out.join(&plan.id)))
                    }
                }
                .map(|()| (id, true))
            };
            progress.advance(1);
            r
        })
        .collect();
    let mut report = GenerateReport::default();
    for r in results {
        let (id, written) = r?;
        if written {
            report.written.push(id);
        } else {
            report.skipped.push(id);
        }
    }
    Ok(report)
}
