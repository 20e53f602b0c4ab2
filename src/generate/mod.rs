//! Procedural houses written in real dataset formats (`minos generate`).
//!
//! SUNCG is no longer distributed, so minos makes its own houses and writes them exactly as
//! SUNCG laid them out; they are also the built-in demo data. A house is first planned in
//! memory ([`plan_house`]: rooms, doors, windows, stairs, furniture) and then written
//! ([`generate`]). Everything random derives from `(seed, house id)`, so the same
//! configuration gives byte-identical files whatever the thread count.

pub mod catalog;
mod furnish;
internal! {
    pub mod layout;
}
mod mp3d_mesh;
pub mod mp3d_writer;
mod objwrite;
pub mod plan;
pub mod scan;
pub mod suncg_writer;
internal! {
    pub mod textures;
}

use crate::file_error::FileError;
use plan::HousePlan;
use std::path::Path;

use rayon::prelude::*;

use crate::invalid::Invalid;
use crate::progress::Progress;
use crate::seed::{derive_seed, Rng};

/// Bumped when the generator's output for a given configuration changes; part of house ids.
pub const GENERATOR_VERSION: u32 = 3;

/// The on-disk format to write.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OutputFormat {
    /// SUNCG: `house/`, `room/`, `object/`, `metadata/`.
    Suncg,
    /// Matterport3D: `<id>/house_segmentations/<id>.house` and `.ply`.
    Mp3d,
    /// Matterport3D laid out as [`OutputFormat::Mp3d`], the mesh a dense, noisy scan with
    /// holes and clutter ([`scan`]); up to three levels.
    Mp3dScan(ScanOptions),
}

/// The formats houses are written in, by name: [`OutputFormat`] without a scan's options.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HouseFormat {
    /// [`OutputFormat::Suncg`].
    Suncg,
    /// [`OutputFormat::Mp3d`].
    Mp3d,
    /// [`OutputFormat::Mp3dScan`].
    Mp3dScan,
}

impl HouseFormat {
    /// The output format, with `scan`'s options for [`HouseFormat::Mp3dScan`].
    pub fn output(self, scan: ScanOptions) -> OutputFormat {
        match self {
            HouseFormat::Suncg => OutputFormat::Suncg,
            HouseFormat::Mp3d => OutputFormat::Mp3d,
            HouseFormat::Mp3dScan => OutputFormat::Mp3dScan(scan),
        }
    }
}

impl crate::vocab::Vocabulary for HouseFormat {
    const WHAT: &'static str = "house format";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: HouseFormat::Suncg,
            name: "suncg",
            aliases: &[],
            help: "SUNCG: house/<id>/house.json, room/, object/, metadata/",
        },
        crate::vocab::Term {
            value: HouseFormat::Mp3d,
            name: "mp3d",
            aliases: &[],
            help: "Matterport3D: <id>/house_segmentations/<id>.house and <id>.ply",
        },
        crate::vocab::Term {
            value: HouseFormat::Mp3dScan,
            name: "mp3d-scan",
            aliases: &[],
            help: "Matterport3D whose mesh is a dense, noisy scan with holes and clutter",
        },
    ];
}

crate::vocab::name_traits!(HouseFormat);

/// What a scan house looks like (see [`scan`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanOptions {
    /// Triangles per house to aim for (at most this many, within a few per cent).
    pub triangles: u64,
    /// Standard deviation of the vertex noise along surface normals (m).
    pub noise: f64,
}

impl Default for ScanOptions {
    fn default() -> Self {
        ScanOptions {
            triangles: scan::DEFAULT_TRIANGLES,
            noise: scan::DEFAULT_NOISE,
        }
    }
}

impl OutputFormat {
    /// Most levels a house of this format may have.
    pub fn max_levels(&self) -> usize {
        match self {
            OutputFormat::Mp3dScan(_) => 3,
            _ => 2,
        }
    }
}

/// How much furniture a generated room gets.
///
/// Measured with the `minos-paper` agent's grids (walkable floor inside rooms, furnished over
/// the `empty` variant): [`Furnishing::Standard`] 2-room houses keep ≈ 73 % of their floor
/// walkable, the real SUNCG and 3D-FRONT samples ≈ 51 %, [`Furnishing::Dense`] houses ≈ the
/// real ones (docs/RESULTS.md, "The random rows": not the furniture's density).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Furnishing {
    /// Each room class's recipe alone (a sofa, a coffee table, a TV stand, ...).
    #[default]
    Standard,
    /// The recipe, then extra pieces of the room's kinds of furniture against the walls and in
    /// the middle until the floor 0.2 m clear of any piece is down to 42 % of the room, every
    /// doorway still reachable.
    Dense,
}

impl crate::vocab::Vocabulary for Furnishing {
    const WHAT: &'static str = "furnishing";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: Furnishing::Standard,
            name: "standard",
            aliases: &[],
            help: "each room's recipe alone (about a quarter of the free floor taken)",
        },
        crate::vocab::Term {
            value: Furnishing::Dense,
            name: "dense",
            aliases: &[],
            help: "extra furniture until about half the floor is taken, as in real SUNCG and 3D-FRONT rooms",
        },
    ];
}

crate::vocab::name_traits!(Furnishing);

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
    /// How much furniture each room gets.
    pub furnishing: Furnishing,
}

impl Default for GenerateConfig {
    fn default() -> Self {
        GenerateConfig {
            houses: 10,
            seed: 0,
            rooms: (3, 8),
            levels: (1, 2),
            closed_door_prob: 0.25,
            furnishing: Furnishing::Standard,
        }
    }
}

/// Errors of `generate`.
#[derive(Debug, thiserror::Error)]
pub enum GenerateError {
    /// The configuration is not usable.
    #[error("invalid configuration: {0}")]
    Config(crate::invalid::Invalid),
    /// Writing failed.
    #[error(transparent)]
    Io(#[from] FileError),
}

impl GenerateConfig {
    /// Checks ranges: 1 ≤ rooms ≤ 24, levels in 1..=2, probability in [0, 1].
    pub fn validate(&self) -> Result<(), GenerateError> {
        self.validate_for(OutputFormat::Suncg)
    }

    /// Checks ranges for `format`: 1 ≤ rooms ≤ 24, levels in 1..=2 (1..=3 for scans),
    /// probability in [0, 1], and a scan's triangles and noise.
    pub fn validate_for(&self, format: OutputFormat) -> Result<(), GenerateError> {
        let bad = |m: String| Err(GenerateError::Config(Invalid::new(m)));
        let max_levels = format.max_levels();
        if self.rooms.0 < 1 || self.rooms.0 > self.rooms.1 || self.rooms.1 > 24 {
            return bad(format!(
                "rooms {}..{}: need 1 <= MIN <= MAX <= 24",
                self.rooms.0, self.rooms.1
            ));
        }
        if self.levels.0 < 1 || self.levels.0 > self.levels.1 || self.levels.1 > max_levels {
            return bad(format!(
                "levels {}..{}: need 1 <= MIN <= MAX <= {max_levels}",
                self.levels.0, self.levels.1
            ));
        }
        if let OutputFormat::Mp3dScan(o) = format {
            self.scan_params(o)
                .validate()
                .map_err(GenerateError::Config)?;
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
        // Standard furnishing adds nothing, so the ids of houses made before it existed hold.
        let furnishing = match self.furnishing {
            Furnishing::Standard => "",
            Furnishing::Dense => ":fdense",
        };
        format!(
            "v{GENERATOR_VERSION}:r{}-{}:l{}-{}:c{}{furnishing}",
            self.rooms.0, self.rooms.1, self.levels.0, self.levels.1, self.closed_door_prob
        )
    }
}

impl GenerateConfig {
    fn scan_params(&self, o: ScanOptions) -> scan::ScanParams {
        scan::ScanParams {
            triangles: o.triangles,
            noise: o.noise,
            seed: self.seed,
        }
    }
}

/// The id of house `index`: 32 hex digits fixed by the seed, the index and the configuration.
pub fn house_id(cfg: &GenerateConfig, index: usize) -> String {
    id_from(cfg, index, cfg.fingerprint())
}

/// The id of house `index` written in `format`: [`house_id`], except for scan houses, whose
/// ids also depend on the scan options.
pub fn house_id_for(cfg: &GenerateConfig, format: OutputFormat, index: usize) -> String {
    match format {
        OutputFormat::Mp3dScan(o) => id_from(
            cfg,
            index,
            format!("{}:scan{}:{}", cfg.fingerprint(), o.triangles, o.noise),
        ),
        _ => house_id(cfg, index),
    }
}

fn id_from(cfg: &GenerateConfig, index: usize, fp: String) -> String {
    let i = index.to_string();
    let hi = derive_seed(cfg.seed, &["house-id-hi", &i, &fp]);
    let lo = derive_seed(cfg.seed, &["house-id-lo", &i, &fp]);
    format!("{hi:016x}{lo:016x}")
}

/// Plans house `index` in memory (deterministic in `(cfg, index)`).
pub fn plan_house(cfg: &GenerateConfig, index: usize) -> HousePlan {
    plan_with_id(cfg, house_id(cfg, index))
}

/// Plans the house with id `id` (all randomness derives from `(cfg.seed, id)`). Three levels
/// (scan houses) need six rooms or more (one stair hall per level), two need four.
pub fn plan_with_id(cfg: &GenerateConfig, id: String) -> HousePlan {
    let mut rng = Rng::new(derive_seed(cfg.seed, &[&id, "generate"]));
    for attempt in 0..16 {
        let mut nlevels = rng.range_usize(cfg.levels.0, cfg.levels.1);
        let n = rng.range_usize(cfg.rooms.0, cfg.rooms.1);
        if nlevels == 3 && n < 6 {
            nlevels = 2;
        }
        // Two levels need a stair hall on each and at least one room on each.
        if nlevels == 2 && n < 4 {
            nlevels = 1;
        }
        let programmes = match nlevels {
            1 => vec![layout::programme(&mut rng, n, false)],
            2 => {
                let k0 = (n - 1) / 2;
                let k1 = n - 2 - k0;
                vec![
                    layout::programme(&mut rng, k0, false),
                    layout::programme(&mut rng, k1, true),
                ]
            }
            _ => {
                let k = n - 3;
                let k0 = k.div_ceil(3);
                let k1 = (k - k0).div_ceil(2);
                let k2 = k - k0 - k1;
                vec![
                    layout::programme(&mut rng, k0, false),
                    layout::programme(&mut rng, k1, true),
                    layout::programme(&mut rng, k2, true),
                ]
            }
        };
        let scale = 1.0 + 0.12 * attempt as f64;
        if let Some(mut levels) = layout::layout(&mut rng, &programmes, cfg.closed_door_prob, scale)
        {
            for level in &mut levels {
                furnish::furnish_level(&mut rng, level, cfg.furnishing);
            }
            return HousePlan { id, levels };
        }
    }
    // A single room always lays out.
    let programme = vec![layout::programme(&mut rng, 1, false)];
    let mut levels =
        layout::layout(&mut rng, &programme, cfg.closed_door_prob, 1.0).unwrap_or_default();
    for level in &mut levels {
        furnish::furnish_level(&mut rng, level, cfg.furnishing);
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
    cfg.validate_for(format)?;
    let io_err = |path: &Path| {
        let path = path.display().to_string();
        move |source| GenerateError::Io(FileError::new(path, source))
    };
    if format == OutputFormat::Suncg {
        suncg_writer::write_library(out).map_err(io_err(out))?;
    }
    progress.set_total(cfg.houses as u64);
    let results: Vec<Result<(String, bool), GenerateError>> = (0..cfg.houses)
        .into_par_iter()
        .map(|i| {
            let id = house_id_for(cfg, format, i);
            let done = match format {
                OutputFormat::Suncg => out.join("house").join(&id).join("house.json"),
                OutputFormat::Mp3d | OutputFormat::Mp3dScan(_) => mp3d_writer::house_path(out, &id),
            };
            let r = if !force && done.is_file() {
                Ok((id, false))
            } else {
                let plan = plan_with_id(cfg, id.clone());
                match format {
                    OutputFormat::Suncg => suncg_writer::write_house(out, &plan)
                        .map_err(io_err(&out.join("house").join(&plan.id))),
                    OutputFormat::Mp3d => {
                        mp3d_writer::write_house(out, &plan).map_err(io_err(&out.join(&plan.id)))
                    }
                    OutputFormat::Mp3dScan(o) => {
                        mp3d_writer::write_house_with(out, &plan, Some(&cfg.scan_params(o)))
                            .map_err(io_err(&out.join(&plan.id)))
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
