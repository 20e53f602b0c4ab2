//! Interchange with Habitat-Lab's episode datasets (`PointNav-v1` / `ObjectNav-v1` layout):
//! [`export_habitat`] writes a split as Habitat lays it out, [`import_habitat`] reads one
//! Habitat episode file (ours, or real Habitat / SemExp files) back into [`Episode`]s.
//!
//! This module only translates files; it does not check that episodes are navigable in the
//! scene, and it never loads scenes.
//!
//! # Export layout
//!
//! ```text
//! DIR/<split>/<split>.json.gz            {"episodes": []} (+ category maps for ObjectNav)
//! DIR/<split>/content/<scene>.json.gz    {"episodes": [...]} (+ category maps, "goals_by_category")
//! ```
//!
//! Every episode given goes into the split named by the `split` argument (callers filter by
//! [`Episode::split`] first). Each episode becomes:
//!
//! - `episode_id` (string), `scene_id` = prefix + the scene id + suffix ([`SceneIdStyle`]).
//!   Habitat resolves `scene_id` against its `scenes_dir`, so users typically pass a prefix
//!   such as `data/scene_datasets/minos/` and the scene files' extension as suffix (`.glb`).
//! - `start_position` [x, y, z]; `start_rotation` [x, y, z, w] = [0, sin(yaw/2), 0, cos(yaw/2)].
//! - `info`: `geodesic_distance`, `euclidean_distance` (null when NaN), `difficulty`, and, as a
//!   minos extension that Habitat ignores (it keeps `info` as a free dictionary),
//!   `minos_episode_id` (the episode id again: Habitat's ObjectNav loader replaces
//!   `episode_id` by the episode's index in its file), `task`, `split`, `seed`,
//!   `path_num_doors`, `path_num_rooms`, `success_radius`, `max_steps`.
//! - PointGoal: `goals` = `[{"position", "radius"}]` with the success radius.
//! - ObjectGoal: `object_category` and an empty `goals` list; the targets go to the content
//!   file's top-level `goals_by_category[key]` as `{"object_id", "object_name",
//!   "object_name_id", "object_category", "room_id", "room_name", "position", "view_points":
//!   [{"agent_state": {"position", "rotation"}, "iou": 1.0}]}`, as Habitat's ObjectNav loader
//!   expects. The key is Habitat's ([`goals_key`]): the last path component of `scene_id`,
//!   extension included, `_`, the category. `object_name` is the id again; `object_name_id`
//!   numbers the file's distinct `object_id`s in sorted order from 0; `room_id` and
//!   `room_name` are the id and MINOS class of the room the object stands in (the room most of
//!   the spans it counts as reached from lie in; null when none is known, e.g. for imported
//!   episodes). A view point's
//!   rotation faces the target's position.
//! - RoomGoal (minos extension): exported like ObjectGoal with `object_category` = the room
//!   class and the rooms as goals (`object_id`, `object_name` and `room_id` = the room id,
//!   `room_name` = the class), marked by `info.task = "roomgoal"`. The view points are
//!   walkable points inside the room, facing its position (the walkable point nearest its
//!   centre). Habitat's ObjectNav loader reads it as an object-goal episode, and its
//!   `DistanceToGoal` measures to those view points.
//!
//! Habitat stores one goal list per scene and category, so when several episodes of the same
//! scene and category list different targets, the exported list is their union (first
//! occurrence of each id wins) and every episode reads the union back.
//!
//! When any episode has an object or room goal, the split file and every content file carry
//! `category_to_task_category_id` and `category_to_scene_annotation_category_id`: the sorted
//! category (and room class) names of the whole split numbered from 0, the same numbers in
//! both maps (minos has no scene annotation ids). Habitat's ObjectNav loader needs them in any
//! file it loads on its own.
//!
//! Habitat's two loaders read one task each: a content file mixing PointGoal with object or
//! room episodes loads in neither (the command line exports one task at a time).
//!
//! Output is deterministic: fixed key order, episodes in the order given (grouped by scene,
//! scenes sorted), f32 values written as their exact f64 value, gzip header mtime 0. Files are
//! written atomically. Non-finite positions are refused.
//!
//! # Import
//!
//! [`import_habitat`] reads one `.json.gz` or plain `.json` file (told apart by content) with a
//! top-level `episodes` list, in any of these shapes: the content files written here, Habitat
//! PointNav episodes (`goals: [{position, radius}]`), Habitat ObjectNav content files
//! (`object_category` + `goals_by_category`), and SemExp ObjectNav episodes (`object_category`,
//! integer `object_id`, `floor_id`, no goal positions). `start_rotation` may be [x, y, z, w]
//! (Habitat) or [w, x, y, z] (SemExp, numpy-quaternion order): see [`yaw_from_quaternion`].
//!
//! Fields a source lacks get these defaults:
//!
//! | field | default |
//! |---|---|
//! | `episode_id` | `info.minos_episode_id`, else `episode_id` when it contains `:` (a minos id), else `<scene>:habitat:<id>` |
//! | `scene_id` | last component of the file's `scene_id`, without a `.glb`/`.gltf`/`.ply`/`.obj`/`.json`/`.house`/`.navmesh` extension |
//! | `task` | `info.task`, else `objectgoal` when `object_category` is present, else `pointgoal` |
//! | targets | `goals_by_category["<basename(scene_id)>_<category>"]` (Habitat's key, extension kept), else `goals_by_category["<scene>_<category>"]` (the key without it), else the episode's `goals`, else one target with the episode's `object_id` and an unknown (NaN) position |
//! | `euclidean_distance` | `info.euclidean_distance`, else computed from the start to the goal (the nearest target with a known position), else NaN |
//! | `geodesic_distance` | `info.geodesic_distance`, else NaN |
//! | `difficulty` | `info.difficulty`, else from the geodesic distance (below 3 m easy, below 6 m medium, else hard; medium when unknown) |
//! | `success_radius` | `info.success_radius`, else the first goal's `radius` (PointGoal), else 0.2 m (PointGoal) / 0.1 m (object and room goals) |
//! | `max_steps` | `info.max_steps`, else 500 |
//! | `split`, `seed`, `path_num_doors`, `path_num_rooms` | `info.*`, else empty / 0 |
//!
//! PointNav episodes with several goals keep the first. Bad entries are errors naming the
//! file, the episode index and the field (`val.json.gz: episodes[12].start_position: expected
//! 3 numbers`).

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;
use serde_json::Value;

use super::interchange::{
    difficulty_for_geodesic, distance, read_text_bytes, yaw_from_y_w, yaw_to_quaternion,
    DEFAULT_MAX_STEPS,
};
use super::{Difficulty, Episode, Goal, GoalTarget, TargetRoom, Task};
use crate::atomic::write_atomic;
use crate::escape::escape_controls;

/// Success radius (m) of imported PointNav episodes without one (Habitat's PointNav default).
pub const DEFAULT_POINT_SUCCESS_RADIUS: f32 = 0.2;

/// Success radius (m) of imported object/room episodes without one (Habitat's ObjectNav
/// default success distance).
pub const DEFAULT_OBJECT_SUCCESS_RADIUS: f32 = 0.1;

/// Largest non-Y axis component (of the normalised quaternion) still read as a pure yaw.
const YAW_AXIS_TOLERANCE: f64 = 1e-3;

/// Scene file extensions stripped from a Habitat `scene_id` to get the minos scene id.
const SCENE_EXTENSIONS: [&str; 7] = ["glb", "gltf", "ply", "obj", "json", "house", "navmesh"];

/// Errors exporting or importing Habitat episode files.
#[derive(Debug, thiserror::Error)]
pub enum HabitatError {
    /// File system error.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The file is not JSON, or not an object with an `episodes` list.
    #[error("{path}: {}", escape_controls(.message))]
    Shape {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// A bad value in one record of the file.
    #[error(
        "{path}: {}: {}",
        escape_controls(&join(.record, .field)),
        escape_controls(.message)
    )]
    Entry {
        /// The file.
        path: String,
        /// The record (`episodes[12]`, `goals_by_category["x_chair"][0]`).
        record: String,
        /// The field in the record.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// An episode that cannot be exported.
    #[error(
        "{path}: episode `{}`: {}",
        escape_controls(.episode_id),
        escape_controls(.message)
    )]
    Export {
        /// The file it was bound for.
        path: String,
        /// The episode.
        episode_id: String,
        /// What is wrong.
        message: String,
    },
}

/// `record.field`, or `record[i]` for an element.
fn join(record: &str, field: &str) -> String {
    if field.starts_with('[') {
        format!("{record}{field}")
    } else {
        format!("{record}.{field}")
    }
}

/// The component order of a `start_rotation` quaternion.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QuaternionConvention {
    /// `[x, y, z, w]` (Habitat, Magnum).
    Xyzw,
    /// `[w, x, y, z]` (numpy-quaternion, SemExp).
    Wxyz,
}

/// The yaw of a quaternion known to be a rotation about +Y, whatever its component order: a
/// yaw quaternion has its x and z components ≈ 0 (within 1e-3 after normalisation), so if
/// `q` read as [x, y, z, w] has x ≈ z ≈ 0 it is that, else if read as [w, x, y, z] it has
/// x ≈ z ≈ 0 it is that; otherwise (or for a zero quaternion) `None`. The yaw is in
/// `(−π, π]`.
pub fn yaw_from_quaternion(q: [f64; 4]) -> Option<(f32, QuaternionConvention)> {
    let norm = q.iter().map(|c| c * c).sum::<f64>().sqrt();
    if !norm.is_finite() || norm < 1e-6 {
        return None;
    }
    let n = q.map(|c| c / norm);
    let small = |c: f64| c.abs() <= YAW_AXIS_TOLERANCE;
    if small(n[0]) && small(n[2]) {
        Some((yaw_from_y_w(n[1], n[3]), QuaternionConvention::Xyzw))
    } else if small(n[1]) && small(n[3]) {
        Some((yaw_from_y_w(n[2], n[0]), QuaternionConvention::Wxyz))
    } else {
        None
    }
}

// ---------------------------------------------------------------------------------------
// Export
// ---------------------------------------------------------------------------------------

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
    pub fn check(&self) -> Result<(), String> {
        if self.suffix.contains(['/', '\\', '\0']) {
            Err(format!(
                "scene suffix `{}` must not contain a path separator",
                self.suffix
            ))
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
    let io = |source| HabitatError::Io {
        path: path.display().to_string(),
        source,
    };
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
    names.check().map_err(shape)?;
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

// ---------------------------------------------------------------------------------------
// Import
// ---------------------------------------------------------------------------------------

/// Field access on one JSON record with errors naming the file, the record and the field.
struct Record<'a> {
    path: &'a str,
    name: String,
    value: &'a serde_json::Map<String, Value>,
}

impl<'a> Record<'a> {
    fn err(&self, field: &str, message: impl Into<String>) -> HabitatError {
        HabitatError::Entry {
            path: self.path.to_string(),
            record: self.name.clone(),
            field: field.to_string(),
            message: message.into(),
        }
    }

    /// The field's value; absent and `null` both give `None`.
    fn get(&self, field: &str) -> Option<&'a Value> {
        self.value.get(field).filter(|v| !v.is_null())
    }

    fn string(&self, field: &str) -> Result<Option<&'a str>, HabitatError> {
        match self.get(field) {
            None => Ok(None),
            Some(Value::String(s)) => Ok(Some(s)),
            Some(v) => Err(self.err(field, format!("expected a string, found {}", kind(v)))),
        }
    }

    fn required_string(&self, field: &str) -> Result<&'a str, HabitatError> {
        self.string(field)?
            .ok_or_else(|| self.err(field, "missing (expected a string)"))
    }

    /// A string or an integer, as text (ids).
    fn id(&self, field: &str) -> Result<Option<String>, HabitatError> {
        match self.get(field) {
            None => Ok(None),
            Some(Value::String(s)) => Ok(Some(s.clone())),
            Some(Value::Number(n)) if n.is_i64() || n.is_u64() => Ok(Some(n.to_string())),
            Some(v) => Err(self.err(
                field,
                format!("expected a string or an integer, found {}", kind(v)),
            )),
        }
    }

    fn number(&self, field: &str) -> Result<Option<f64>, HabitatError> {
        match self.get(field) {
            None => Ok(None),
            Some(v) => v
                .as_f64()
                .map(Some)
                .ok_or_else(|| self.err(field, format!("expected a number, found {}", kind(v)))),
        }
    }

    fn unsigned(&self, field: &str, max: u64) -> Result<Option<u64>, HabitatError> {
        match self.get(field) {
            None => Ok(None),
            Some(v) => v.as_u64().filter(|n| *n <= max).map(Some).ok_or_else(|| {
                self.err(
                    field,
                    format!("expected an integer from 0 to {max}, found {v}"),
                )
            }),
        }
    }

    fn numbers<const N: usize>(&self, field: &str) -> Result<Option<[f64; N]>, HabitatError> {
        let Some(v) = self.get(field) else {
            return Ok(None);
        };
        let bad = || self.err(field, format!("expected {N} numbers"));
        let a = v.as_array().filter(|a| a.len() == N).ok_or_else(bad)?;
        let mut out = [0.0; N];
        for (o, x) in out.iter_mut().zip(a) {
            *o = x.as_f64().ok_or_else(bad)?;
        }
        Ok(Some(out))
    }

    /// Three numbers that fit an `f32` (JSON numbers beyond ±3.4e38 would become infinite).
    fn position(&self, field: &str) -> Result<[f32; 3], HabitatError> {
        let p = self
            .numbers::<3>(field)?
            .map(|p| p.map(|c| c as f32))
            .ok_or_else(|| self.err(field, "missing (expected 3 numbers)"))?;
        if p.iter().all(|c| c.is_finite()) {
            Ok(p)
        } else {
            Err(self.err(field, format!("{p:?} is out of range for 32-bit floats")))
        }
    }

    fn array(&self, field: &str) -> Result<&'a [Value], HabitatError> {
        match self.get(field) {
            None => Ok(&[]),
            Some(Value::Array(a)) => Ok(a),
            Some(v) => Err(self.err(field, format!("expected a list, found {}", kind(v)))),
        }
    }

    fn object(&self, field: &str) -> Result<Option<Record<'a>>, HabitatError> {
        match self.get(field) {
            None => Ok(None),
            Some(Value::Object(m)) => Ok(Some(Record {
                path: self.path,
                name: format!("{}.{field}", self.name),
                value: m,
            })),
            Some(v) => Err(self.err(field, format!("expected an object, found {}", kind(v)))),
        }
    }
}

/// Element `i` of the list named `list`, which must be an object.
fn element<'a>(
    path: &'a str,
    list: &str,
    i: usize,
    v: &'a Value,
) -> Result<Record<'a>, HabitatError> {
    match v {
        Value::Object(m) => Ok(Record {
            path,
            name: format!("{list}[{i}]"),
            value: m,
        }),
        other => Err(HabitatError::Entry {
            path: path.to_string(),
            record: list.to_string(),
            field: format!("[{i}]"),
            message: format!("expected an object, found {}", kind(other)),
        }),
    }
}

fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "a list",
        Value::Object(_) => "an object",
    }
}

/// The minos scene id of a Habitat `scene_id` path: its last component without a scene-file
/// extension.
fn scene_name(scene_id: &str) -> &str {
    let base = basename(scene_id);
    match base.rsplit_once('.') {
        Some((stem, ext))
            if !stem.is_empty()
                && SCENE_EXTENSIONS.contains(&ext.to_ascii_lowercase().as_str()) =>
        {
            stem
        }
        _ => base,
    }
}

fn basename(scene_id: &str) -> &str {
    scene_id.rsplit(['/', '\\']).next().unwrap_or(scene_id)
}

/// Reads the targets of one `goals_by_category` list (or an episode's object `goals`), the
/// list named `list` in errors.
fn read_targets(path: &str, list: &str, goals: &[Value]) -> Result<Vec<GoalTarget>, HabitatError> {
    let mut targets = Vec::with_capacity(goals.len());
    for (j, g) in goals.iter().enumerate() {
        let g = element(path, list, j, g)?;
        let id = g
            .id("object_id")?
            .ok_or_else(|| g.err("object_id", "missing (expected a string or an integer)"))?;
        let position = g.position("position")?;
        let mut view_points = Vec::new();
        let views_name = format!("{}.view_points", g.name);
        for (k, v) in g.array("view_points")?.iter().enumerate() {
            let v = element(path, &views_name, k, v)?;
            let state = v
                .object("agent_state")?
                .ok_or_else(|| v.err("agent_state", "missing (expected an object)"))?;
            view_points.push(state.position("position")?);
        }
        let room = match (g.string("room_id")?, g.string("room_name")?) {
            (Some(id), Some(class)) => Some(TargetRoom {
                id: id.to_string(),
                class: class.to_string(),
            }),
            _ => None,
        };
        targets.push(GoalTarget {
            id,
            position,
            view_points,
            room,
        });
    }
    Ok(targets)
}

/// Reads the episodes of one Habitat episode file (`.json.gz` or plain `.json`); see the
/// module documentation for the shapes understood and the defaults.
pub fn import_habitat(path: &Path) -> Result<Vec<Episode>, HabitatError> {
    let p = path.display().to_string();
    let bytes = read_text_bytes(path).map_err(|source| HabitatError::Io {
        path: p.clone(),
        source,
    })?;
    let root: Value = serde_json::from_slice(&bytes).map_err(|e| HabitatError::Shape {
        path: p.clone(),
        message: format!("not JSON: {e}"),
    })?;
    drop(bytes);
    let shape = |message: &str| HabitatError::Shape {
        path: p.clone(),
        message: message.to_string(),
    };
    let root = root
        .as_object()
        .ok_or_else(|| shape("expected a JSON object with an `episodes` list"))?;
    let episodes = root
        .get("episodes")
        .and_then(Value::as_array)
        .ok_or_else(|| shape("expected a JSON object with an `episodes` list"))?;

    let mut goals_by_category: HashMap<&str, Vec<GoalTarget>> = HashMap::new();
    match root.get("goals_by_category") {
        None | Some(Value::Null) => {}
        Some(Value::Object(m)) => {
            for (key, list) in m {
                let name = format!("goals_by_category[{key:?}]");
                let Value::Array(list) = list else {
                    return Err(HabitatError::Entry {
                        path: p.clone(),
                        record: "goals_by_category".into(),
                        field: format!("[{key:?}]"),
                        message: format!("expected a list, found {}", kind(list)),
                    });
                };
                goals_by_category.insert(key.as_str(), read_targets(&p, &name, list)?);
            }
        }
        Some(v) => {
            return Err(HabitatError::Shape {
                path: p.clone(),
                message: format!("goals_by_category: expected an object, found {}", kind(v)),
            })
        }
    }

    let mut out = Vec::with_capacity(episodes.len());
    for (i, ep) in episodes.iter().enumerate() {
        let r = element(&p, "episodes", i, ep)?;
        let episode = read_episode(&r, &goals_by_category)?;
        // Positions are range-checked where read; this catches the rest (a radius or distance
        // beyond f32, a negative radius).
        episode
            .validate()
            .map_err(|(field, message)| r.err(field, message))?;
        out.push(episode);
    }
    Ok(out)
}

fn read_episode(
    r: &Record<'_>,
    goals_by_category: &HashMap<&str, Vec<GoalTarget>>,
) -> Result<Episode, HabitatError> {
    let raw_id = r
        .id("episode_id")?
        .ok_or_else(|| r.err("episode_id", "missing (expected a string or an integer)"))?;
    let raw_scene = r.required_string("scene_id")?;
    let scene = scene_name(raw_scene).to_string();
    let info = r.object("info")?;
    let minos_id = match &info {
        Some(i) => i.string("minos_episode_id")?,
        None => None,
    };
    let episode_id = match minos_id {
        Some(id) => id.to_string(),
        None if raw_id.contains(':') => raw_id,
        None => format!("{scene}:habitat:{raw_id}"),
    };
    let start_position = r.position("start_position")?;
    let q = r
        .numbers::<4>("start_rotation")?
        .ok_or_else(|| r.err("start_rotation", "missing (expected 4 numbers)"))?;
    let (start_yaw, _) = yaw_from_quaternion(q).ok_or_else(|| {
        r.err(
            "start_rotation",
            format!("{q:?} is not a rotation about +Y in [x, y, z, w] or [w, x, y, z] order"),
        )
    })?;

    let info_num = |f: &str| -> Result<Option<f64>, HabitatError> {
        info.as_ref().map_or(Ok(None), |i| i.number(f))
    };
    let info_uint = |f: &str, max: u64| -> Result<Option<u64>, HabitatError> {
        info.as_ref().map_or(Ok(None), |i| i.unsigned(f, max))
    };
    let info_str = |f: &str| -> Result<Option<&str>, HabitatError> {
        info.as_ref().map_or(Ok(None), |i| i.string(f))
    };
    let info_err = |f: &str, m: String| match &info {
        Some(i) => i.err(f, m),
        None => r.err(f, m),
    };

    let category = r.string("object_category")?;
    let task = match info_str("task")? {
        Some(t) => {
            Task::from_name(t).ok_or_else(|| info_err("task", format!("unknown task `{t}`")))?
        }
        None if category.is_some() => Task::ObjectGoal,
        None => Task::PointGoal,
    };

    let mut point_radius = None;
    let goal = match task {
        Task::PointGoal => {
            let goals = r.array("goals")?;
            let first = goals.first().ok_or_else(|| {
                r.err("goals", "expected at least one goal for a PointNav episode")
            })?;
            let g = element(r.path, &format!("{}.goals", r.name), 0, first)?;
            point_radius = g.number("radius")?;
            Goal::Point {
                position: g.position("position")?,
            }
        }
        Task::ObjectGoal | Task::RoomGoal => {
            let label = category.ok_or_else(|| {
                r.err(
                    "object_category",
                    "missing (expected a string for an object or room goal)",
                )
            })?;
            let key = goals_key(raw_scene, label);
            // Habitat's key keeps the scene file's extension; files whose keys dropped it
            // (a `scene_id` extended by hand) are read by the key without it.
            let stem_key = format!("{scene}_{label}");
            let targets = if let Some(t) = goals_by_category
                .get(key.as_str())
                .or_else(|| goals_by_category.get(stem_key.as_str()))
            {
                t.clone()
            } else if !r.array("goals")?.is_empty() {
                read_targets(r.path, &format!("{}.goals", r.name), r.array("goals")?)?
            } else if let Some(id) = r.id("object_id")? {
                vec![GoalTarget {
                    id,
                    position: [f32::NAN; 3],
                    view_points: Vec::new(),
                    room: None,
                }]
            } else {
                return Err(r.err(
                    "object_category",
                    format!(
                        "no goals: `goals_by_category` has no key {key:?}, and the episode has \
                         neither `goals` nor `object_id`"
                    ),
                ));
            };
            if task == Task::ObjectGoal {
                Goal::Object {
                    category: label.to_string(),
                    targets,
                }
            } else {
                Goal::Room {
                    class: label.to_string(),
                    targets,
                }
            }
        }
    };

    let euclidean_distance = match info_num("euclidean_distance")? {
        Some(d) => d as f32,
        None => match &goal {
            Goal::Point { position } => distance(start_position, *position),
            Goal::Object { targets, .. } | Goal::Room { targets, .. } => targets
                .iter()
                .map(|t| distance(start_position, t.position))
                .filter(|d| d.is_finite())
                .min_by(f32::total_cmp)
                .unwrap_or(f32::NAN),
        },
    };
    let geodesic_distance = info_num("geodesic_distance")?.map_or(f32::NAN, |d| d as f32);
    let difficulty = match info_str("difficulty")? {
        Some(d) => Difficulty::from_name(d)
            .ok_or_else(|| info_err("difficulty", format!("unknown difficulty `{d}`")))?,
        None => difficulty_for_geodesic(geodesic_distance),
    };
    let success_radius = match (info_num("success_radius")?, point_radius) {
        (Some(s), _) | (None, Some(s)) => s as f32,
        (None, None) if task == Task::PointGoal => DEFAULT_POINT_SUCCESS_RADIUS,
        (None, None) => DEFAULT_OBJECT_SUCCESS_RADIUS,
    };
    let u32max = u64::from(u32::MAX);
    Ok(Episode {
        episode_id,
        scene_id: scene,
        split: info_str("split")?.unwrap_or("").to_string(),
        task,
        seed: info_uint("seed", u64::MAX)?.unwrap_or(0),
        start_position,
        start_yaw,
        goal,
        euclidean_distance,
        geodesic_distance,
        path_num_doors: info_uint("path_num_doors", u32max)?.unwrap_or(0) as u32,
        path_num_rooms: info_uint("path_num_rooms", u32max)?.unwrap_or(0) as u32,
        difficulty,
        success_radius,
        max_steps: info_uint("max_steps", u32max)?.map_or(DEFAULT_MAX_STEPS, |n| n as u32),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode::format::tests::sample_episodes;
    use std::f32::consts::{PI, TAU};

    fn gz(bytes: &[u8]) -> Vec<u8> {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        e.write_all(bytes).unwrap();
        e.finish().unwrap()
    }

    fn read_json(path: &Path) -> Value {
        serde_json::from_slice(&read_text_bytes(path).unwrap()).unwrap()
    }

    fn yaw_diff(a: f32, b: f32) -> f32 {
        let d = (a - b).rem_euclid(TAU);
        d.min(TAU - d)
    }

    fn assert_close3(a: [f32; 3], b: [f32; 3], tol: f32) {
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() <= tol, "{a:?} vs {b:?}");
        }
    }

    fn prefixed(prefix: &str) -> SceneIdStyle {
        SceneIdStyle {
            prefix: prefix.into(),
            suffix: String::new(),
        }
    }

    /// Point and object episodes whose yaws span the whole circle, incl. values ≥ π.
    fn episodes_for_export() -> Vec<Episode> {
        let s = sample_episodes();
        let mut out = Vec::new();
        for (k, yaw) in [0.0f32, 1.0, 3.5, 6.0, -2.0, PI].into_iter().enumerate() {
            let mut e = s[k % 3].clone();
            e.episode_id = format!("{}:{}:{k:05}", e.scene_id, e.task.name());
            e.start_yaw = yaw;
            out.push(e);
        }
        out
    }

    #[test]
    fn export_then_import_gives_the_same_episodes() {
        let dir = tempfile::tempdir().unwrap();
        let eps = episodes_for_export();
        let files = export_habitat(
            dir.path(),
            "val",
            &prefixed("data/scene_datasets/minos/"),
            &eps,
        )
        .unwrap();
        let names: Vec<String> = files
            .iter()
            .map(|f| f.strip_prefix(dir.path()).unwrap().display().to_string())
            .collect();
        assert_eq!(
            names,
            [
                "val/val.json.gz",
                "val/content/house_a.json.gz",
                "val/content/house_b@dark.json.gz"
            ]
        );
        let mut back = import_habitat(&files[1]).unwrap();
        back.extend(import_habitat(&files[2]).unwrap());
        // Export groups by scene; compare in that order.
        let mut expected = eps.clone();
        expected.sort_by(|a, b| a.scene_id.cmp(&b.scene_id));
        assert_eq!(back.len(), expected.len());
        for (b, e) in back.iter().zip(&expected) {
            assert_eq!(b.episode_id, e.episode_id);
            assert_eq!(b.scene_id, e.scene_id);
            assert_eq!(b.task, e.task);
            assert_close3(b.start_position, e.start_position, 1e-5);
            assert!(
                yaw_diff(b.start_yaw, e.start_yaw) < 1e-4,
                "{} vs {}",
                b.start_yaw,
                e.start_yaw
            );
            assert!(b.start_yaw > -PI && b.start_yaw <= PI);
            assert_eq!(b.goal, e.goal);
            assert_eq!(b.euclidean_distance, e.euclidean_distance);
            assert_eq!(b.geodesic_distance, e.geodesic_distance);
            assert_eq!(
                (
                    b.split.as_str(),
                    b.seed,
                    b.difficulty,
                    b.success_radius,
                    b.max_steps
                ),
                (
                    e.split.as_str(),
                    e.seed,
                    e.difficulty,
                    e.success_radius,
                    e.max_steps
                )
            );
            assert_eq!(
                (b.path_num_doors, b.path_num_rooms),
                (e.path_num_doors, e.path_num_rooms)
            );
        }
    }

    #[test]
    fn export_layout_matches_habitat() {
        let dir = tempfile::tempdir().unwrap();
        let eps = episodes_for_export();
        let files = export_habitat(dir.path(), "train", &SceneIdStyle::default(), &eps).unwrap();
        let split = read_json(&files[0]);
        assert_eq!(split["episodes"], serde_json::json!([]));
        assert_eq!(
            split["category_to_task_category_id"],
            serde_json::json!({"chair": 0, "kitchen": 1})
        );
        assert_eq!(
            split["category_to_scene_annotation_category_id"],
            split["category_to_task_category_id"]
        );

        let content = read_json(&files[1]);
        let episodes = content["episodes"].as_array().unwrap();
        // Episode 0 (PointGoal, yaw 0) and 1 (ObjectGoal, yaw 1) are in house_a.
        let p = &episodes[0];
        assert_eq!(p["scene_id"], "house_a");
        assert_eq!(p["start_rotation"], serde_json::json!([0.0, 0.0, 0.0, 1.0]));
        assert_eq!(p["goals"][0]["radius"], f64::from(0.2f32));
        assert!(p.get("object_category").is_none());
        let o = &episodes[1];
        assert_eq!(o["object_category"], "chair");
        assert_eq!(o["goals"], serde_json::json!([]));
        let q = o["start_rotation"].as_array().unwrap();
        assert!((q[1].as_f64().unwrap() - 0.5f64.sin()).abs() < 1e-9);
        assert!((q[3].as_f64().unwrap() - 0.5f64.cos()).abs() < 1e-9);
        let goals = content["goals_by_category"]["house_a_chair"]
            .as_array()
            .unwrap();
        assert_eq!(goals.len(), 3);
        assert_eq!(goals[0]["object_id"], "0_12");
        assert_eq!(goals[0]["object_category"], "chair");
        let vp = &goals[0]["view_points"][0];
        assert_eq!(vp["iou"], 1.0);
        assert_eq!(
            vp["agent_state"]["position"],
            serde_json::json!([0.0, 0.05f32 as f64, 1.0])
        );
        // The view point at (0, _, 1) faces the target at (0.5, _, 1): +X, i.e. yaw −π/2.
        let rot = vp["agent_state"]["rotation"].as_array().unwrap();
        let rot: Vec<f64> = rot.iter().map(|v| v.as_f64().unwrap()).collect();
        let (yaw, conv) = yaw_from_quaternion([rot[0], rot[1], rot[2], rot[3]]).unwrap();
        assert_eq!(conv, QuaternionConvention::Xyzw);
        assert!((yaw + std::f32::consts::FRAC_PI_2).abs() < 1e-6);

        let room = read_json(&files[2]);
        assert_eq!(room["episodes"][0]["info"]["task"], "roomgoal");
        assert_eq!(room["episodes"][0]["object_category"], "kitchen");
        assert!(room["goals_by_category"]["house_b@dark_kitchen"].is_array());

        // Deterministic: a second export gives identical bytes; gzip mtime is 0.
        let dir2 = tempfile::tempdir().unwrap();
        let files2 = export_habitat(dir2.path(), "train", &SceneIdStyle::default(), &eps).unwrap();
        for (a, b) in files.iter().zip(&files2) {
            let (a, b) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
            assert_eq!(a, b);
            assert_eq!(&a[..2], &[0x1f, 0x8b]);
            assert_eq!(&a[4..8], &[0, 0, 0, 0]);
        }
    }

    #[test]
    fn union_of_targets_per_scene_and_category() {
        let dir = tempfile::tempdir().unwrap();
        let mut eps = sample_episodes();
        eps.truncate(2);
        let mut other = eps[1].clone();
        other.episode_id = "house_a:objectgoal:00009".into();
        if let Goal::Object { targets, .. } = &mut other.goal {
            targets.truncate(1);
            targets.push(GoalTarget {
                id: "0_99".into(),
                position: [9.0, 0.5, 9.0],
                view_points: vec![],
                room: None,
            });
        }
        eps.push(other);
        let files = export_habitat(dir.path(), "val", &SceneIdStyle::default(), &eps).unwrap();
        let back = import_habitat(&files[1]).unwrap();
        let ids = |e: &Episode| match &e.goal {
            Goal::Object { targets, .. } => targets.iter().map(|t| t.id.clone()).collect(),
            _ => Vec::new(),
        };
        let union = vec!["0_12", "0_13", "0_14", "0_99"];
        assert_eq!(ids(&back[1]), union);
        assert_eq!(ids(&back[2]), union);
    }

    #[test]
    fn a_scene_suffix_extends_scene_ids_and_goal_keys_alike() {
        let dir = tempfile::tempdir().unwrap();
        let eps = episodes_for_export();
        let style = SceneIdStyle {
            prefix: "data/scene_datasets/minos/".into(),
            suffix: ".glb".into(),
        };
        let files = export_habitat(dir.path(), "val", &style, &eps).unwrap();
        let content = read_json(&files[1]);
        let ep = &content["episodes"][1];
        assert_eq!(ep["scene_id"], "data/scene_datasets/minos/house_a.glb");
        assert_eq!(ep["info"]["minos_episode_id"], ep["episode_id"]);
        let keys: Vec<&String> = content["goals_by_category"]
            .as_object()
            .unwrap()
            .keys()
            .collect();
        assert_eq!(keys, ["house_a.glb_chair"]);
        // The category maps are in every content file, equal to the split file's.
        let split = read_json(&files[0]);
        for f in &files[1..] {
            let c = read_json(f);
            for map in [
                "category_to_task_category_id",
                "category_to_scene_annotation_category_id",
            ] {
                assert_eq!(c[map], split[map], "{map}");
            }
        }
        // Goals: name, number, room fields.
        let goals = content["goals_by_category"]["house_a.glb_chair"]
            .as_array()
            .unwrap();
        let numbers: Vec<u64> = goals
            .iter()
            .map(|g| g["object_name_id"].as_u64().unwrap())
            .collect();
        assert_eq!(numbers, [0, 1, 2]);
        assert_eq!(goals[1]["object_name"], "0_13");
        assert!(goals[1]["room_id"].is_null() && goals[1]["room_name"].is_null());
        let room = read_json(&files[2]);
        let g = &room["goals_by_category"]["house_b@dark.glb_kitchen"][0];
        assert_eq!(
            (&g["room_id"], &g["room_name"]),
            (&g["object_id"], &g["object_category"])
        );
        assert_eq!(g["room_name"], "kitchen");
        assert_eq!(g["view_points"].as_array().map(Vec::len), Some(3));
        // Everything reads back under the scene's own id.
        let mut back = import_habitat(&files[1]).unwrap();
        back.extend(import_habitat(&files[2]).unwrap());
        let mut expected = eps.clone();
        expected.sort_by(|a, b| a.scene_id.cmp(&b.scene_id));
        for (b, e) in back.iter().zip(&expected) {
            assert_eq!((&b.episode_id, &b.scene_id), (&e.episode_id, &e.scene_id));
            assert_eq!(b.goal, e.goal);
        }
        // A suffix with a path separator would change the key's basename: refused.
        let bad = SceneIdStyle {
            prefix: String::new(),
            suffix: "/x.glb".into(),
        };
        let err = export_habitat(dir.path(), "val", &bad, &eps).unwrap_err();
        assert!(err.to_string().contains("path separator"), "{err}");
    }

    #[test]
    fn habitat_numbered_ids_and_extensionless_keys_still_import() {
        let dir = tempfile::tempdir().unwrap();
        // As habitat-lab re-saves a file (`episode_id` = index), and an older minos file whose
        // scene_id was given an extension by hand (its key lacks it).
        let path = dir.path().join("old.json");
        let text = r#"{"episodes": [
            {"episode_id": "0", "scene_id": "minos/h1.glb", "start_position": [0, 0, 0],
             "start_rotation": [0, 0, 0, 1], "object_category": "bed", "goals": [],
             "info": {"minos_episode_id": "h1:objectgoal:00007"}},
            {"episode_id": "1", "scene_id": "minos/h1.glb", "start_position": [0, 0, 0],
             "start_rotation": [0, 0, 0, 1], "object_category": "bed", "goals": []}],
          "goals_by_category": {"h1_bed": [{"object_id": "0_3", "position": [1, 0, 1]}]}}"#;
        std::fs::write(&path, text).unwrap();
        let back = import_habitat(&path).unwrap();
        assert_eq!(back[0].episode_id, "h1:objectgoal:00007");
        assert_eq!(back[1].episode_id, "h1:habitat:1");
        assert_eq!(back[0].scene_id, "h1");
        match &back[1].goal {
            Goal::Object { targets, .. } => assert_eq!(targets[0].id, "0_3"),
            other => panic!("{other:?}"),
        }
        // Habitat's key (with the extension) wins over the key without it.
        let both = text.replace(
            r#""goals_by_category": {"#,
            r#""goals_by_category": {"h1.glb_bed": [{"object_id": "0_5", "position": [2, 0, 2]}], "#,
        );
        std::fs::write(&path, both).unwrap();
        match &import_habitat(&path).unwrap()[0].goal {
            Goal::Object { targets, .. } => assert_eq!(targets[0].id, "0_5"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn quaternion_conventions_are_detected() {
        let yaw = 2.2f32;
        let (s, c) = ((f64::from(yaw) / 2.0).sin(), (f64::from(yaw) / 2.0).cos());
        let (y1, c1) = yaw_from_quaternion([0.0, s, 0.0, c]).unwrap();
        assert_eq!(c1, QuaternionConvention::Xyzw);
        assert!((y1 - yaw).abs() < 1e-6);
        let (y2, c2) = yaw_from_quaternion([c, 0.0, s, 0.0]).unwrap();
        assert_eq!(c2, QuaternionConvention::Wxyz);
        assert!((y2 - yaw).abs() < 1e-6);
        // SemExp's first Collierville rotation, [w, x, y, z].
        let (y3, c3) =
            yaw_from_quaternion([-0.22018953669540486, 0.0, 0.9754571071707168, 0.0]).unwrap();
        assert_eq!(c3, QuaternionConvention::Wxyz);
        let q = yaw_to_quaternion(y3);
        // q equals ±(0, 0.975, 0, −0.220): the same rotation.
        assert!((q[1] * -0.22018953669540486 - q[3] * 0.9754571071707168).abs() < 1e-6);
        // Identity and half turn in [x, y, z, w].
        assert_eq!(yaw_from_quaternion([0.0, 0.0, 0.0, 1.0]).unwrap().0, 0.0);
        assert!((yaw_from_quaternion([0.0, 1.0, 0.0, 0.0]).unwrap().0 - PI).abs() < 1e-6);
        // Not a yaw in either order, and degenerate input.
        assert!(yaw_from_quaternion([0.5, 0.5, 0.5, 0.5]).is_none());
        assert!(yaw_from_quaternion([0.3, 0.0, 0.0, 0.954]).is_none());
        assert!(yaw_from_quaternion([0.0; 4]).is_none());
        assert!(yaw_from_quaternion([f64::NAN, 0.0, 0.0, 1.0]).is_none());
    }

    #[test]
    fn non_yaw_rotation_is_an_error_naming_the_episode() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tilted.json");
        let good = r#"{"episode_id": "a", "scene_id": "s.glb", "start_position": [0, 0, 0],
            "start_rotation": [0, 0, 0, 1], "goals": [{"position": [1, 0, 1]}]}"#;
        let bad = good.replace("[0, 0, 0, 1]", "[0.5, 0.5, 0.5, 0.5]");
        std::fs::write(&path, format!(r#"{{"episodes": [{good}, {bad}]}}"#)).unwrap();
        let err = import_habitat(&path).unwrap_err().to_string();
        assert!(
            err.contains("tilted.json: episodes[1].start_rotation: "),
            "{err}"
        );
        assert!(err.contains("not a rotation about +Y"), "{err}");
    }

    #[test]
    fn bad_entries_name_file_episode_and_field() {
        let dir = tempfile::tempdir().unwrap();
        let ok = r#"{"episode_id": 3, "scene_id": "x/s.glb", "start_position": [0, 0, 0],
            "start_rotation": [0, 0, 0, 1], "goals": [{"position": [3, 0, 4], "radius": 0.36}]}"#;
        let cases: Vec<(&str, String, &str)> = vec![
            (
                "start_position",
                ok.replace(
                    "\"start_position\": [0, 0, 0]",
                    "\"start_position\": [0, 0]",
                ),
                "episodes[12].start_position: expected 3 numbers",
            ),
            (
                "position",
                ok.replace("[3, 0, 4]", "[3, \"a\", 4]"),
                "episodes[12].goals[0].position: expected 3 numbers",
            ),
            (
                "goals",
                ok.replace("[{\"position\": [3, 0, 4], \"radius\": 0.36}]", "[]"),
                "episodes[12].goals: expected at least one goal",
            ),
            (
                "scene",
                ok.replace("\"x/s.glb\"", "7"),
                "episodes[12].scene_id: expected a string, found a number",
            ),
            (
                "difficulty",
                ok.replace(
                    "\"goals\"",
                    "\"info\": {\"difficulty\": \"extreme\"}, \"goals\"",
                ),
                "episodes[12].info.difficulty: unknown difficulty `extreme`",
            ),
            (
                // Text quoted from the file stays on one line.
                "newline",
                ok.replace(
                    "\"goals\"",
                    "\"info\": {\"difficulty\": \"ex\\ntreme\"}, \"goals\"",
                ),
                "episodes[12].info.difficulty: unknown difficulty `ex\\ntreme`",
            ),
            (
                "huge",
                ok.replace("[3, 0, 4]", "[3, 1e39, 4]"),
                "episodes[12].goals[0].position: [3.0, inf, 4.0] is out of range for 32-bit floats",
            ),
            (
                "radius",
                ok.replace("0.36", "-1"),
                "episodes[12].success_radius: -1 is not a finite radius",
            ),
            (
                "notobject",
                "[1, 2]".to_string(),
                "episodes[12]: expected an object, found a list",
            ),
            (
                "object",
                ok.replace("\"goals\"", "\"object_category\": \"bed\", \"goals_x\""),
                "episodes[12].object_category: no goals",
            ),
        ];
        for (name, bad, expected) in cases {
            let path = dir.path().join(format!("{name}.json.gz"));
            let mut list = vec![ok.to_string(); 12];
            list.push(bad);
            let text = format!("{{\"episodes\": [{}]}}", list.join(","));
            std::fs::write(&path, gz(text.as_bytes())).unwrap();
            let err = import_habitat(&path).unwrap_err().to_string();
            let want = format!("{}: {expected}", path.display());
            assert!(err.starts_with(&want), "{err}\n  wanted {want}");
        }
        // The good episode alone imports, with the documented defaults.
        let path = dir.path().join("ok.json");
        std::fs::write(&path, format!("{{\"episodes\": [{ok}]}}")).unwrap();
        let e = &import_habitat(&path).unwrap()[0];
        assert_eq!(e.episode_id, "s:habitat:3");
        assert_eq!(e.scene_id, "s");
        assert_eq!(e.euclidean_distance, 5.0);
        assert!(e.geodesic_distance.is_nan());
        assert_eq!(e.difficulty, Difficulty::Medium);
        assert_eq!(e.success_radius, 0.36);
        assert_eq!(e.max_steps, DEFAULT_MAX_STEPS);
        // Not an episodes file at all.
        std::fs::write(&path, "[1, 2]").unwrap();
        let err = import_habitat(&path).unwrap_err().to_string();
        assert!(err.contains("`episodes` list"), "{err}");
    }

    #[test]
    fn scene_names_drop_only_scene_extensions() {
        assert_eq!(
            scene_name("gibson_semantic//Collierville.glb"),
            "Collierville"
        );
        assert_eq!(
            scene_name("mp3d/17DRP5sb8fy/17DRP5sb8fy.glb"),
            "17DRP5sb8fy"
        );
        assert_eq!(scene_name("data/minos/house_b@dark"), "house_b@dark");
        assert_eq!(scene_name("my.scene"), "my.scene");
        assert_eq!(scene_name("my.scene.gltf"), "my.scene");
    }

    /// `MINOS_REAL_DATA` = the shared datasets folder; the test is skipped when unset.
    fn real_data() -> Option<PathBuf> {
        match std::env::var_os("MINOS_REAL_DATA") {
            Some(d) => Some(PathBuf::from(d).join("habitat_episodes/objectnav_gibson_v1.1_semexp")),
            None => {
                println!("skipped: MINOS_REAL_DATA is not set");
                None
            }
        }
    }

    #[test]
    fn real_semexp_and_habitat_files_import() {
        let Some(dir) = real_data() else { return };
        let count = |p: &Path| read_json(p)["episodes"].as_array().unwrap().len();

        let obj_path = dir.join("Collierville_episodes.json.gz");
        let obj = import_habitat(&obj_path).unwrap();
        assert_eq!(obj.len(), count(&obj_path));
        assert_eq!(obj.len(), 200);
        let e = &obj[0];
        assert_eq!(e.episode_id, "Collierville:habitat:0");
        assert_eq!(e.scene_id, "Collierville");
        assert_eq!(e.task, Task::ObjectGoal);
        assert_eq!(
            e.start_position,
            [
                -0.3094837963581085f64 as f32,
                0.026745080947875977f64 as f32,
                -3.483508586883545f64 as f32
            ]
        );
        // [w, x, y, z] = [−0.2202, 0, 0.9755, 0]: the yaw reproduces it up to sign.
        let q = yaw_to_quaternion(e.start_yaw);
        assert!((q[1] * -0.22018953669540486 - q[3] * 0.9754571071707168).abs() < 1e-6);
        match &e.goal {
            Goal::Object { category, targets } => {
                assert_eq!(category, "toilet");
                assert_eq!(targets.len(), 1);
                assert_eq!(targets[0].id, "4");
                assert!(targets[0].position[0].is_nan());
            }
            other => panic!("expected an object goal, got {other:?}"),
        }
        assert!(e.euclidean_distance.is_nan() && e.geodesic_distance.is_nan());
        assert_eq!(e.success_radius, DEFAULT_OBJECT_SUCCESS_RADIUS);
        let chairs = obj
            .iter()
            .filter(|e| matches!(&e.goal, Goal::Object { category, .. } if category == "chair"))
            .count();
        assert!(chairs > 0 && chairs < 200);

        let point_path = dir.join("Collierville.glb.json.gz");
        let point = import_habitat(&point_path).unwrap();
        assert_eq!((point.len(), count(&point_path)), (1, 1));
        let p = &point[0];
        assert_eq!(p.task, Task::PointGoal);
        assert_eq!(p.scene_id, "Collierville");
        assert_eq!(p.geodesic_distance, 4.395505905151367f64 as f32);
        assert_eq!(p.difficulty, Difficulty::Medium);
        assert_eq!(p.success_radius, 0.2);
        let goal = [
            0.5122390389442444f64 as f32,
            0.03894525766372681f64 as f32,
            1.1862249374389648f64 as f32,
        ];
        assert_eq!(p.goal, Goal::Point { position: goal });
        assert!((p.euclidean_distance - distance(p.start_position, goal)).abs() < 1e-6);
        assert!(
            (f64::from(p.start_yaw) - 2.0 * 0.02223112828807172f64.atan2(0.9997528579279178)).abs()
                < 1e-6
        );

        let empty = import_habitat(&dir.join("val.json.gz")).unwrap();
        assert!(empty.is_empty());
    }
}
