//! Writing a split as Habitat-Lab lays it out ([`export_habitat`]; layout in the module docs).

use crate::file_error::FileError;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::import::basename;
use super::*;
use crate::atomic::write_atomic;
use crate::episode::interchange::yaw_to_quaternion;
use crate::episode::{Episode, Goal};
use crate::invalid::Invalid;

/// How a minos scene id becomes Habitat's `scene_id`: `prefix + scene + suffix`.
///
/// Habitat resolves `scene_id` against its `scenes_dir`, so the prefix is typically a folder
/// such as `data/scene_datasets/minos/` and the suffix the scene file's extension (`.glb`).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SceneIdStyle {
    /// Written before the scene id.
    pub prefix: String,
    /// Written after the scene id (a file extension such as `.glb`; no path separator).
    pub suffix: String,
}

impl SceneIdStyle {
    /// The `scene_id` written for minos scene `scene`.
    pub fn scene_id(&self, scene: &str) -> String {
        format!("{}{scene}{}", self.prefix, self.suffix)
    }

    /// Why the suffix cannot be used, if so: a suffix with a path separator would move the
    /// scene into another folder and change the goal keys' basename.
    pub fn check(&self) -> Result<(), Invalid> {
        if self.suffix.contains(['/', '\\', '\0']) {
            Err(format!(
                "scene suffix `{}` must not contain a path separator",
                self.suffix
            )
            .into())
        } else {
            Ok(())
        }
    }
}

/// Habitat's ObjectNav goal key of an episode: `os.path.basename(scene_id) + "_" +
/// object_category` (habitat-lab's `ObjectGoalNavEpisode.goals_key`; the basename keeps the
/// extension).
pub fn goals_key(scene_id: &str, category: &str) -> String {
    format!("{}_{category}", basename(scene_id))
}

/// The category maps Habitat's ObjectNav loader reads (`category_to_task_category_id`,
/// `category_to_scene_annotation_category_id`): the same numbering twice.
#[derive(Serialize, Clone)]
struct CategoryMaps<'a> {
    category_to_task_category_id: BTreeMap<&'a str, u32>,
    category_to_scene_annotation_category_id: BTreeMap<&'a str, u32>,
}

#[derive(Serialize)]
struct SplitFile<'a> {
    episodes: [(); 0],
    #[serde(flatten)]
    maps: Option<CategoryMaps<'a>>,
}

#[derive(Serialize)]
struct ContentFile<'a> {
    episodes: Vec<EpisodeOut<'a>>,
    #[serde(flatten)]
    maps: Option<CategoryMaps<'a>>,
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    goals_by_category: BTreeMap<String, Vec<ObjectGoalOut<'a>>>,
}

#[derive(Serialize)]
struct EpisodeOut<'a> {
    episode_id: &'a str,
    scene_id: String,
    start_position: [f64; 3],
    start_rotation: [f64; 4],
    info: InfoOut<'a>,
    goals: Vec<PointGoalOut>,
    #[serde(skip_serializing_if = "Option::is_none")]
    object_category: Option<&'a str>,
}

#[derive(Serialize)]
struct InfoOut<'a> {
    geodesic_distance: f64,
    euclidean_distance: f64,
    difficulty: &'static str,
    /// Habitat's ObjectNav loader replaces `episode_id` by the list index; this keeps ours.
    minos_episode_id: &'a str,
    task: &'static str,
    split: &'a str,
    seed: u64,
    path_num_doors: u32,
    path_num_rooms: u32,
    success_radius: f64,
    max_steps: u32,
    levels_crossed: u32,
}

#[derive(Serialize)]
struct PointGoalOut {
    position: [f64; 3],
    radius: f64,
}

#[derive(Serialize)]
struct ObjectGoalOut<'a> {
    object_id: &'a str,
    object_name: &'a str,
    object_name_id: u32,
    object_category: &'a str,
    room_id: Option<&'a str>,
    room_name: Option<&'a str>,
    position: [f64; 3],
    view_points: Vec<ViewPointOut>,
}

#[derive(Serialize)]
struct ViewPointOut {
    agent_state: AgentStateOut,
    iou: f64,
}

#[derive(Serialize)]
struct AgentStateOut {
    position: [f64; 3],
    rotation: [f64; 4],
}

fn f64s(p: [f32; 3]) -> [f64; 3] {
    p.map(f64::from)
}

/// The yaw at `from` that faces `to` (forward is −Z rotated by the yaw about +Y).
fn yaw_facing(from: [f32; 3], to: [f32; 3]) -> f32 {
    let dx = f64::from(to[0]) - f64::from(from[0]);
    let dz = f64::from(to[2]) - f64::from(from[2]);
    if dx == 0.0 && dz == 0.0 {
        0.0
    } else {
        // `0.0 - d` rather than `-d`: no negative zero, so straight +Z gives +π, not −π.
        (0.0 - dx).atan2(0.0 - dz) as f32
    }
}

/// Checks that a name can be used as one path component.
fn valid_component(name: &str) -> bool {
    !name.is_empty()
        && name != "."
        && name != ".."
        && !name.contains(['/', '\\', '\0'])
        && !name.starts_with('.')
}

fn gzip_json<T: Serialize>(path: &Path, value: &T) -> Result<(), HabitatError> {
    let io = |source| HabitatError::Io(FileError::new(path, source));
    let json = serde_json::to_vec(value).map_err(|e| io(std::io::Error::other(e)))?;
    write_atomic(path, |w| -> std::io::Result<()> {
        let mut gz = flate2::GzBuilder::new()
            .mtime(0)
            .write(w, flate2::Compression::default());
        gz.write_all(&json)?;
        gz.finish()?;
        Ok(())
    })
    .map_err(io)
}

/// Writes `episodes` as the Habitat split `split` under `dir` (see the module documentation
/// for the layout and fields), naming scenes as `names` says. Returns the files written: the
/// split file first, then one content file per scene in scene order.
pub fn export_habitat(
    dir: &Path,
    split: &str,
    names: &SceneIdStyle,
    episodes: &[Episode],
) -> Result<Vec<PathBuf>, HabitatError> {
    let split_dir = dir.join(split);
    let split_path = split_dir.join(format!("{split}.json.gz"));
    let shape = |message: String| HabitatError::Shape {
        path: split_path.display().to_string(),
        message,
    };
    if !valid_component(split) {
        return Err(shape(format!(
            "split name `{split}` cannot be a directory name"
        )));
    }
    names.check().map_err(|source| HabitatError::SceneIds {
        path: split_path.display().to_string(),
        source,
    })?;
    let mut by_scene: BTreeMap<&str, Vec<&Episode>> = BTreeMap::new();
    for e in episodes {
        by_scene.entry(e.scene_id.as_str()).or_default().push(e);
    }

    let mut categories: BTreeSet<&str> = BTreeSet::new();
    let mut contents = Vec::with_capacity(by_scene.len());
    for (scene, eps) in &by_scene {
        let path = split_dir.join("content").join(format!("{scene}.json.gz"));
        let fail = |e: &Episode, message: String| HabitatError::Export {
            path: path.display().to_string(),
            episode_id: e.episode_id.clone(),
            message,
        };
        if !valid_component(scene) {
            return Err(fail(
                eps[0],
                format!("scene id `{scene}` cannot be a file name"),
            ));
        }
        let finite = |e: &Episode, what: &str, p: [f32; 3]| {
            if p.iter().all(|c| c.is_finite()) {
                Ok(f64s(p))
            } else {
                Err(fail(e, format!("{what} {p:?} is not finite")))
            }
        };
        let scene_id = names.scene_id(scene);
        let mut file = ContentFile {
            episodes: Vec::with_capacity(eps.len()),
            maps: None,
            goals_by_category: BTreeMap::new(),
        };
        let mut seen: HashMap<String, BTreeSet<&str>> = HashMap::new();
        for e in eps {
            if !e.start_yaw.is_finite() {
                return Err(fail(e, format!("start yaw {} is not finite", e.start_yaw)));
            }
            let mut out = EpisodeOut {
                episode_id: &e.episode_id,
                scene_id: scene_id.clone(),
                start_position: finite(e, "start position", e.start_position)?,
                start_rotation: yaw_to_quaternion(e.start_yaw),
                info: InfoOut {
                    geodesic_distance: f64::from(e.geodesic_distance),
                    euclidean_distance: f64::from(e.euclidean_distance),
                    difficulty: e.difficulty.name(),
                    minos_episode_id: &e.episode_id,
                    task: e.task.name(),
                    split: &e.split,
                    seed: e.seed,
                    path_num_doors: e.path_num_doors,
                    path_num_rooms: e.path_num_rooms,
                    success_radius: f64::from(e.success_radius),
                    max_steps: e.max_steps,
                    levels_crossed: e.levels_crossed,
                },
                goals: Vec::new(),
                object_category: None,
            };
            let (label, targets, rooms) = match &e.goal {
                Goal::Point { position } => {
                    out.goals.push(PointGoalOut {
                        position: finite(e, "goal position", *position)?,
                        radius: f64::from(e.success_radius),
                    });
                    file.episodes.push(out);
                    continue;
                }
                Goal::Object { category, targets } => (category.as_str(), targets, false),
                Goal::Room { class, targets } => (class.as_str(), targets, true),
            };
            out.object_category = Some(label);
            categories.insert(label);
            let key = goals_key(&scene_id, label);
            let ids = seen.entry(key.clone()).or_default();
            let list = file.goals_by_category.entry(key).or_default();
            for t in targets {
                if !ids.insert(&t.id) {
                    continue;
                }
                let view_points = t
                    .view_points
                    .iter()
                    .map(|v| {
                        Ok(ViewPointOut {
                            agent_state: AgentStateOut {
                                position: finite(e, "view point", *v)?,
                                rotation: yaw_to_quaternion(yaw_facing(*v, t.position)),
                            },
                            iou: 1.0,
                        })
                    })
                    .collect::<Result<Vec<_>, HabitatError>>()?;
                list.push(ObjectGoalOut {
                    object_id: &t.id,
                    object_name: &t.id,
                    object_name_id: 0,
                    object_category: label,
                    room_id: match &t.room {
                        Some(r) => Some(r.id.as_str()),
                        None => rooms.then_some(t.id.as_str()),
                    },
                    room_name: match &t.room {
                        Some(r) => Some(r.class.as_str()),
                        None => rooms.then_some(label),
                    },
                    position: finite(e, "target position", t.position)?,
                    view_points,
                });
            }
            file.episodes.push(out);
        }
        number_goals(&mut file.goals_by_category);
        contents.push((path, file));
    }

    // The same category maps in the split file and in every content file, so a content file
    // loads alone as well as through the split file.
    let maps = (!categories.is_empty()).then(|| {
        let ids: BTreeMap<&str, u32> = categories
            .iter()
            .enumerate()
            .map(|(i, c)| (*c, i as u32))
            .collect();
        CategoryMaps {
            category_to_task_category_id: ids.clone(),
            category_to_scene_annotation_category_id: ids,
        }
    });
    let split_file = SplitFile {
        episodes: [],
        maps: maps.clone(),
    };
    gzip_json(&split_path, &split_file)?;
    let mut written = vec![split_path];
    for (path, mut file) in contents {
        file.maps.clone_from(&maps);
        gzip_json(&path, &file)?;
        written.push(path);
    }
    Ok(written)
}

/// Numbers a content file's goals: `object_name_id` is the goal's index among the file's
/// distinct `object_id`s in sorted order (minos ids are strings; Habitat wants an integer).
fn number_goals(goals: &mut BTreeMap<String, Vec<ObjectGoalOut<'_>>>) {
    let ids: BTreeSet<&str> = goals.values().flatten().map(|g| g.object_id).collect();
    let number: HashMap<&str, u32> = ids
        .into_iter()
        .enumerate()
        .map(|(i, id)| (id, i as u32))
        .collect();
    for g in goals.values_mut().flatten() {
        g.object_name_id = number.get(g.object_id).copied().unwrap_or(0);
    }
}
