//! Reading one Habitat episode file (ours, or real Habitat / SemExp files) into [`Episode`]s ([`import_habitat`]).

use crate::file_error::FileError;
use std::collections::HashMap;
use std::path::Path;

use serde_json::Value;

use super::*;
use crate::episode::interchange::{
    difficulty_for_geodesic, distance, read_text_bytes, DEFAULT_MAX_STEPS,
};
use crate::episode::{Difficulty, Episode, Goal, GoalTarget, TargetRoom, Task};

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
pub(super) fn scene_name(scene_id: &str) -> &str {
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

pub(super) fn basename(scene_id: &str) -> &str {
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
    let bytes = read_text_bytes(path)
        .map_err(|source| HabitatError::Io(FileError::new(p.clone(), source)))?;
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
        Some(t) => t
            .parse::<Task>()
            .map_err(|e| info_err("task", e.to_string()))?,
        None if category.is_some() => Task::ObjectGoal,
        None => Task::PointGoal,
    };

    let mut point_radius = None;
    let goal = match task {
        Task::PointGoal | Task::Vln => {
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
        Some(d) => d
            .parse::<Difficulty>()
            .map_err(|e| info_err("difficulty", e.to_string()))?,
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
        levels_crossed: info_uint("levels_crossed", u32max)?.unwrap_or(0) as u32,
        route: None,
    })
}
