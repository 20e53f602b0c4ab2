//! VLN episodes in the formats VLN training code reads: VLN-CE (habitat-lab's `R2RVLN-v1`
//! dataset, `VLNDatasetV1`) and R2R's JSON for discrete-VLN tools.
//!
//! # VLN-CE
//!
//! ```text
//! DIR/<split>/<split>.json.gz   {"episodes": [...], "instruction_vocab": {...}}
//! ```
//!
//! One VLN-CE episode per instruction: a route with three instructions gives three episodes
//! sharing a `trajectory_id`, as VLN-CE's R2R files do. Each episode has
//!
//! - `episode_id` (integer, from 1 in file order), `trajectory_id` (integer, from 1: the
//!   minos episode's position among those exported), `scene_id` (prefix + scene + suffix, as
//!   the Habitat export: [`SceneIdStyle`]);
//! - `start_position` [x, y, z], `start_rotation` [x, y, z, w] = [0, sin(yaw/2), 0, cos(yaw/2)];
//! - `goals`: `[{"position": the route's end, "radius": the success radius}]`;
//! - `reference_path`: the route's points [[x, y, z], …] (start, corners, goal);
//! - `instruction`: `{"instruction_text", "instruction_tokens"}`, the tokens being indices into
//!   the file's vocabulary padded with 0 to 200 (`vln::tokens`);
//! - `info`: `geodesic_distance`, and as minos extensions `minos_episode_id`,
//!   `instruction_index`, `levels_crossed`, `difficulty`, `split`, `seed`, `rooms` (the room
//!   classes passed), `landmarks`, `goal_object`.
//!
//! `instruction_vocab` is `{"word_list": [...], "word2idx_dict": {...}, "itos": [...],
//! "stoi": {...}, "num_vocab": n, "UNK_INDEX": 1, "PAD_INDEX": 0}` over the split's
//! instructions (habitat-lab reads `word_list`).
//!
//! # R2R
//!
//! ```text
//! DIR/R2R_<split>.json   [{"path_id", "scan", "heading", "path", "instructions", "distance", …}]
//! ```
//!
//! One entry per route: `path_id` (integer, from 1), `scan` (the scene id), `heading` (the
//! start yaw as R2R measures it: radians clockwise from the Matterport3D +y axis, which is
//! minos's −Z, so `heading = (−yaw) mod 2π`), `path` (viewpoint ids `<path_id>_<k>` of the
//! reference path's points), `instructions`, `distance` (geodesic, m), and as minos
//! extensions `path_positions` (the points, y-up metres), `episode_id` and
//! `levels_crossed`. minos routes are continuous: there is no panorama graph behind the
//! viewpoint ids, so tools that look viewpoints up in Matterport3D's connectivity files need
//! the positions instead.
//!
//! Output is deterministic (fixed key order, gzip mtime 0) and written atomically; episodes
//! without a route are refused with their id.

use crate::file_error::FileError;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::tokens::Vocabulary;
use crate::atomic::write_atomic;
use crate::episode::habitat::SceneIdStyle;
use crate::episode::interchange::yaw_to_quaternion;
use crate::episode::{Episode, Goal};
use crate::invalid::Invalid;

/// Which VLN format to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VlnFormat {
    /// VLN-CE (habitat-lab's `R2RVLN-v1`).
    VlnCe,
    /// R2R's JSON.
    R2r,
}

/// The layouts `minos episodes --export` writes beside the episode file: Habitat-Lab's
/// (point, object and room goals) or one of the VLN formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EpisodeExport {
    /// Habitat-Lab's `DIR/<subset>/<subset>.json.gz` and `content/`.
    Habitat,
    /// A VLN format (VLN tasks only).
    Vln(VlnFormat),
}

impl crate::vocab::Vocabulary for EpisodeExport {
    const WHAT: &'static str = "format";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: EpisodeExport::Habitat,
            name: "habitat",
            aliases: &[],
            help: "Habitat-Lab's layout, DIR/<subset>/<subset>.json.gz and content/",
        },
        crate::vocab::Term {
            value: EpisodeExport::Vln(VlnFormat::VlnCe),
            name: "vlnce",
            aliases: &[],
            help: "VLN-CE, habitat-lab's R2RVLN-v1; VLN episodes only",
        },
        crate::vocab::Term {
            value: EpisodeExport::Vln(VlnFormat::R2r),
            name: "r2r",
            aliases: &[],
            help: "R2R's JSON; VLN episodes only",
        },
    ];
}

crate::vocab::name_traits!(EpisodeExport);

impl EpisodeExport {
    /// The exports a job asks for: Habitat-Lab's layout when `habitat`, then the VLN format
    /// `vln` (what [`crate::pipeline::episodes::check_options`] checks against the task).
    pub fn requested(habitat: bool, vln: Option<VlnFormat>) -> impl Iterator<Item = Self> {
        habitat
            .then_some(Self::Habitat)
            .into_iter()
            .chain(vln.map(Self::Vln))
    }
}

/// Errors writing a VLN export.
#[derive(Debug, thiserror::Error)]
pub enum VlnExportError {
    /// File system error.
    #[error(transparent)]
    Io(#[from] FileError),
    /// An episode that cannot be exported.
    #[error("{path}: episode {episode_id}")]
    Episode {
        /// The file being written.
        path: String,
        /// The episode.
        episode_id: String,
        /// What is wrong.
        #[source]
        problem: Invalid,
    },
}

#[derive(Serialize)]
struct CeFile<'a> {
    episodes: Vec<CeEpisode<'a>>,
    instruction_vocab: CeVocab<'a>,
}

#[derive(Serialize)]
struct CeVocab<'a> {
    word_list: &'a [String],
    word2idx_dict: BTreeMap<&'a str, u32>,
    itos: &'a [String],
    stoi: BTreeMap<&'a str, u32>,
    num_vocab: usize,
    #[serde(rename = "UNK_INDEX")]
    unk_index: u32,
    #[serde(rename = "PAD_INDEX")]
    pad_index: u32,
}

#[derive(Serialize)]
struct CeEpisode<'a> {
    episode_id: u64,
    trajectory_id: u64,
    scene_id: String,
    start_position: [f64; 3],
    start_rotation: [f64; 4],
    info: CeInfo<'a>,
    goals: [CeGoal; 1],
    reference_path: Vec<[f64; 3]>,
    instruction: CeInstruction<'a>,
}

#[derive(Serialize)]
struct CeInfo<'a> {
    geodesic_distance: f64,
    minos_episode_id: &'a str,
    instruction_index: usize,
    levels_crossed: u32,
    difficulty: &'static str,
    split: &'a str,
    seed: u64,
    rooms: Vec<&'a str>,
    landmarks: &'a [String],
    goal_object: Option<&'a str>,
}

#[derive(Serialize)]
struct CeGoal {
    position: [f64; 3],
    radius: f64,
}

#[derive(Serialize)]
struct CeInstruction<'a> {
    instruction_text: &'a str,
    instruction_tokens: Vec<u32>,
}

#[derive(Serialize)]
struct R2rEntry<'a> {
    path_id: u64,
    scan: &'a str,
    heading: f64,
    path: Vec<String>,
    instructions: &'a [String],
    distance: f64,
    path_positions: Vec<[f64; 3]>,
    episode_id: &'a str,
    levels_crossed: u32,
}

fn f64s(p: [f32; 3]) -> [f64; 3] {
    p.map(f64::from)
}

/// The route and goal point of a VLN episode, or why it cannot be exported.
fn parts(e: &Episode) -> Result<(&super::Route, [f32; 3]), Invalid> {
    let route = e
        .route
        .as_deref()
        .ok_or_else(|| Invalid::new("not a VLN episode with a route"))?;
    let Goal::Point { position } = &e.goal else {
        return Err("a VLN episode's goal must be a point".into());
    };
    let finite = |p: &[f32; 3]| p.iter().all(|c| c.is_finite());
    if !finite(position) || !finite(&e.start_position) || !e.start_yaw.is_finite() {
        return Err("start or goal is not finite".into());
    }
    if route.path.iter().any(|p| !finite(p)) {
        return Err("a reference path point is not finite".into());
    }
    Ok((route, *position))
}

fn write_file(path: &Path, bytes: &[u8], gzip: bool) -> Result<(), VlnExportError> {
    write_atomic(path, |w| -> std::io::Result<()> {
        if gzip {
            let mut gz = flate2::GzBuilder::new()
                .mtime(0)
                .write(w, flate2::Compression::default());
            gz.write_all(bytes)?;
            gz.finish()?;
        } else {
            w.write_all(bytes)?;
        }
        Ok(())
    })
    .map_err(|source| VlnExportError::Io(FileError::new(path, source)))
}

/// Checks that a split name can be a file name component.
fn check_split(split: &str, path: &Path) -> Result<(), VlnExportError> {
    if split.is_empty() || split.starts_with('.') || split.contains(['/', '\\', '\0']) {
        return Err(VlnExportError::Io(FileError {
            path: path.to_path_buf(),
            source: std::io::Error::other(format!("split name `{split}` cannot be a file name")),
        }));
    }
    Ok(())
}

/// Writes `episodes` (VLN episodes with routes) as the VLN-CE split `split` under `dir`;
/// returns the file written.
pub fn export_vlnce(
    dir: &Path,
    split: &str,
    names: &SceneIdStyle,
    episodes: &[Episode],
) -> Result<PathBuf, VlnExportError> {
    let path = dir.join(split).join(format!("{split}.json.gz"));
    check_split(split, &path)?;
    let fail = |e: &Episode, problem: Invalid| VlnExportError::Episode {
        path: path.display().to_string(),
        episode_id: e.episode_id.clone(),
        problem,
    };
    let mut routes = Vec::with_capacity(episodes.len());
    for e in episodes {
        routes.push(parts(e).map_err(|m| fail(e, m))?);
    }
    let vocab = Vocabulary::of(
        routes
            .iter()
            .flat_map(|(r, _)| r.instructions.iter().map(String::as_str)),
    );
    let mut out = Vec::new();
    for (t, (e, (route, goal))) in episodes.iter().zip(&routes).enumerate() {
        for (k, text) in route.instructions.iter().enumerate() {
            out.push(CeEpisode {
                episode_id: out.len() as u64 + 1,
                trajectory_id: t as u64 + 1,
                scene_id: names.scene_id(&e.scene_id),
                start_position: f64s(e.start_position),
                start_rotation: yaw_to_quaternion(e.start_yaw),
                info: CeInfo {
                    geodesic_distance: f64::from(e.geodesic_distance),
                    minos_episode_id: &e.episode_id,
                    instruction_index: k,
                    levels_crossed: e.levels_crossed,
                    difficulty: e.difficulty.name(),
                    split: &e.split,
                    seed: e.seed,
                    rooms: route.rooms.iter().map(|r| r.class.as_str()).collect(),
                    landmarks: &route.landmarks,
                    goal_object: route.goal_object.as_deref(),
                },
                goals: [CeGoal {
                    position: f64s(*goal),
                    radius: f64::from(e.success_radius),
                }],
                reference_path: route.path.iter().map(|p| f64s(*p)).collect(),
                instruction: CeInstruction {
                    instruction_text: text,
                    instruction_tokens: vocab.encode(text),
                },
            });
        }
    }
    let index: BTreeMap<&str, u32> = vocab
        .words
        .iter()
        .enumerate()
        .map(|(i, w)| (w.as_str(), i as u32))
        .collect();
    let file = CeFile {
        episodes: out,
        instruction_vocab: CeVocab {
            word_list: &vocab.words,
            word2idx_dict: index.clone(),
            itos: &vocab.words,
            stoi: index,
            num_vocab: vocab.words.len(),
            unk_index: 1,
            pad_index: 0,
        },
    };
    let json = serde_json::to_vec(&file).map_err(|e| {
        VlnExportError::Io(FileError {
            path: path.to_path_buf(),
            source: std::io::Error::other(e),
        })
    })?;
    write_file(&path, &json, true)?;
    Ok(path)
}

/// R2R's heading (radians clockwise from Matterport3D's +y, minos's −Z, in [0, 2π)) of a
/// minos yaw (counter-clockwise about +Y, 0 facing −Z).
pub fn r2r_heading(yaw: f32) -> f64 {
    (-f64::from(yaw)).rem_euclid(std::f64::consts::TAU)
}

/// Writes `episodes` (VLN episodes with routes) as R2R's `R2R_<split>.json` in `dir`;
/// returns the file written.
pub fn export_r2r(
    dir: &Path,
    split: &str,
    episodes: &[Episode],
) -> Result<PathBuf, VlnExportError> {
    let path = dir.join(format!("R2R_{split}.json"));
    check_split(split, &path)?;
    let mut out = Vec::with_capacity(episodes.len());
    for (i, e) in episodes.iter().enumerate() {
        let (route, _) = parts(e).map_err(|problem| VlnExportError::Episode {
            path: path.display().to_string(),
            episode_id: e.episode_id.clone(),
            problem,
        })?;
        let path_id = i as u64 + 1;
        out.push(R2rEntry {
            path_id,
            scan: &e.scene_id,
            heading: r2r_heading(e.start_yaw),
            path: (0..route.path.len())
                .map(|k| format!("{path_id}_{k}"))
                .collect(),
            instructions: &route.instructions,
            distance: f64::from(e.geodesic_distance),
            path_positions: route.path.iter().map(|p| f64s(*p)).collect(),
            episode_id: &e.episode_id,
            levels_crossed: e.levels_crossed,
        });
    }
    let json = serde_json::to_vec_pretty(&out).map_err(|e| {
        VlnExportError::Io(FileError {
            path: path.to_path_buf(),
            source: std::io::Error::other(e),
        })
    })?;
    write_file(&path, &json, false)?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_requested_exports_are_habitat_then_the_vln_format() {
        let all = |h, v| EpisodeExport::requested(h, v).collect::<Vec<_>>();
        assert_eq!(all(false, None), []);
        assert_eq!(all(true, None), [EpisodeExport::Habitat]);
        assert_eq!(
            all(false, Some(VlnFormat::R2r)),
            [EpisodeExport::Vln(VlnFormat::R2r)]
        );
        assert_eq!(
            all(true, Some(VlnFormat::VlnCe)),
            [EpisodeExport::Habitat, EpisodeExport::Vln(VlnFormat::VlnCe)]
        );
    }

    #[test]
    fn an_episode_without_a_route_is_refused_naming_it_and_nothing_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let point = crate::episode::format::tests::sample_episodes().remove(0);
        assert!(point.route.is_none());
        for result in [
            export_r2r(dir.path(), "val", std::slice::from_ref(&point)),
            export_vlnce(
                dir.path(),
                "val",
                &SceneIdStyle::default(),
                std::slice::from_ref(&point),
            ),
        ] {
            let e = result.unwrap_err();
            assert!(
                matches!(&e, VlnExportError::Episode { episode_id, .. } if *episode_id == point.episode_id),
                "{e:?}"
            );
            let cause = std::error::Error::source(&e).map(ToString::to_string);
            assert_eq!(cause.as_deref(), Some("not a VLN episode with a route"));
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn headings_turn_the_other_way_from_yaw() {
        assert_eq!(r2r_heading(0.0), 0.0);
        // Yaw π/2 faces −X: a quarter turn counter-clockwise, so three quarters clockwise.
        let h = r2r_heading(std::f32::consts::FRAC_PI_2);
        assert!((h - 1.5 * std::f64::consts::PI).abs() < 1e-6, "{h}");
        let h = r2r_heading(-std::f32::consts::FRAC_PI_2);
        assert!((h - 0.5 * std::f64::consts::PI).abs() < 1e-6, "{h}");
    }
}
