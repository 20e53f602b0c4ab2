//! The episode file: a Parquet table with one row per [`Episode`], written by
//! [`write_episodes`] and read back exactly by [`read_episodes`].
//!
//! The file is plain Parquet (zstd level 3, written atomically, identical bytes for identical
//! input), so pandas or pyarrow read it without minos. This module only converts between
//! episodes and rows; it does not generate, filter or validate episodes beyond what is needed
//! to rebuild them (a task name it does not know, a null where a value is required, or target
//! lists of unequal lengths are errors naming the file, the row and the column).
//!
//! # Columns
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `episode_id` | utf8 | stable id `<scene>:<task>:<index>` |
//! | `scene_id` | utf8 | scene id (`<scene>@<variant>` for variants) |
//! | `split` | utf8 | `train`, `val`, `test` or empty |
//! | `task` | utf8 | `pointgoal`, `objectgoal` or `roomgoal` |
//! | `seed` | uint64 | per-scene seed the episode was drawn with |
//! | `start_x`, `start_y`, `start_z` | float32 | start position (m; `y` = floor height) |
//! | `start_yaw` | float32 | start yaw (rad, counter-clockwise about +Y, 0 faces −Z) |
//! | `goal_x`, `goal_y`, `goal_z` | float32 | the goal point (PointGoal) or the first target's position (NaN when there is no target) |
//! | `goal_category` | utf8, nullable | object category (ObjectGoal only, else null) |
//! | `goal_room_class` | utf8, nullable | MINOS room class (RoomGoal only, else null) |
//! | `goal_ids` | list\<utf8\> | target ids (object instance or room ids); empty for PointGoal |
//! | `goal_positions` | list\<fixed_size_list\<float32, 3\>\> | one position per target; empty for PointGoal |
//! | `goal_view_points` | list\<list\<fixed_size_list\<float32, 3\>\>\> | per target, its view points (possibly none); empty for PointGoal |
//! | `goal_room_ids` | list\<utf8, nullable items\> | per target, the id of the room it is in (a room target: itself), null when unknown; empty for PointGoal. Optional when reading (older files lack it) |
//! | `goal_room_classes` | list\<utf8, nullable items\> | per target, that room's MINOS class; same optionality |
//! | `euclidean_distance` | float32 | straight-line start–goal distance (m) |
//! | `geodesic_distance` | float32 | shortest-path start–goal distance (m) |
//! | `path_num_doors` | uint32 | doors on the shortest path |
//! | `path_num_rooms` | uint32 | rooms on the shortest path (counting the start's) |
//! | `difficulty` | utf8 | `easy`, `medium` or `hard` |
//! | `success_radius` | float32 | success radius (m) |
//! | `max_steps` | uint32 | step limit |
//! | `levels_crossed` | uint32 | levels the shortest path climbs or descends (sum of level changes between its corners) |
//! | `route_path` | list\<fixed_size_list\<float32, 3\>\> | VLN: the reference path (start, corners, goal); empty for other tasks |
//! | `route_room_ids`, `route_room_classes` | list\<utf8\> | VLN: the rooms the path passes, in order, and their MINOS classes |
//! | `route_door_ids` | list\<utf8\> | VLN: the doorways passed through, in order |
//! | `route_levels` | list\<uint32\> | VLN: the levels passed, in order |
//! | `route_landmark_ids` | list\<utf8\> | VLN: the objects the instructions name as landmarks |
//! | `route_goal_object` | utf8, nullable | VLN: the object the stop description names (null when none, and for other tasks) |
//! | `instructions` | list\<utf8\> | VLN: the instructions in English; empty for other tasks |
//!
//! The columns from `levels_crossed` on are optional when reading (files written before them
//! read with 0 levels and no route).
//!
//! Only `goal_category`, `goal_room_class` and the items of `goal_room_ids` /
//! `goal_room_classes` hold nulls. The `goal_*` list columns have one entry per target, in the
//! same order.

use std::path::Path;
use std::sync::Arc;

use arrow::array::{
    Array, ArrayRef, FixedSizeListArray, FixedSizeListBuilder, Float32Array, Float32Builder,
    ListArray, ListBuilder, RecordBatch, StringArray, StringBuilder, UInt32Array, UInt64Array,
};
use arrow::datatypes::{Field, Schema};

use super::vln::Route;
use super::{Difficulty, Episode, Goal, GoalTarget, TargetRoom, Task};
use crate::invalid::Invalid;
use crate::parquet_io::{read_batches, write_batches, writer_properties, ParquetFileError};

/// The optional `goal_room_ids` / `goal_room_classes` columns of a batch.
struct TargetRooms<'a> {
    /// Both columns with their string values, when the file has them.
    columns: Option<[(&'a ListArray, &'a StringArray); 2]>,
}

impl<'a> TargetRooms<'a> {
    fn of(batch: &'a RecordBatch) -> Result<Self, BatchError> {
        let get = |name: &str| -> Result<Option<(&'a ListArray, &'a StringArray)>, BatchError> {
            let Some(c) = batch.column_by_name(name) else {
                return Ok(None);
            };
            let list = c
                .as_any()
                .downcast_ref::<ListArray>()
                .ok_or_else(|| BatchError::Format(format!("column `{name}` is not a list")))?;
            let values = list
                .values()
                .as_any()
                .downcast_ref::<StringArray>()
                .ok_or_else(|| BatchError::Format(format!("column `{name}` is not list<utf8>")))?;
            Ok(Some((list, values)))
        };
        Ok(TargetRooms {
            columns: match (get("goal_room_ids")?, get("goal_room_classes")?) {
                (Some(a), Some(b)) => Some([a, b]),
                _ => None,
            },
        })
    }

    /// The room of target `j` of row `i` (`None` when unknown or not recorded).
    fn get(&self, i: usize, j: usize) -> Result<Option<TargetRoom>, Invalid> {
        let Some(columns) = &self.columns else {
            return Ok(None);
        };
        let mut parts = [None, None];
        for (part, (list, values)) in parts.iter_mut().zip(columns) {
            if list.is_null(i) {
                return Err("null list".into());
            }
            let offsets = list.value_offsets();
            let k = offsets[i] as usize + j;
            if k >= offsets[i + 1] as usize || k >= values.len() {
                return Err("fewer rooms than targets".into());
            }
            *part = (!values.is_null(k)).then(|| values.value(k).to_string());
        }
        Ok(match parts {
            [Some(id), Some(class)] => Some(TargetRoom { id, class }),
            _ => None,
        })
    }
}

/// The optional VLN route columns (and `levels_crossed`) of a batch.
struct RouteColumns<'a> {
    levels_crossed: Option<&'a UInt32Array>,
    path: Option<(&'a ListArray, Points<'a>)>,
    strings: [Option<(&'a ListArray, &'a StringArray)>; 5],
    levels: Option<(&'a ListArray, &'a UInt32Array)>,
    goal_object: Option<&'a StringArray>,
}

/// The list<utf8> route columns, in the order of [`RouteColumns::strings`].
const ROUTE_STRINGS: [&str; 5] = [
    "route_room_ids",
    "route_room_classes",
    "route_door_ids",
    "route_landmark_ids",
    "instructions",
];

impl<'a> RouteColumns<'a> {
    fn of(batch: &'a RecordBatch) -> Result<Self, BatchError> {
        let list = |name: &str| -> Result<Option<&'a ListArray>, BatchError> {
            batch
                .column_by_name(name)
                .map(|c| {
                    c.as_any()
                        .downcast_ref::<ListArray>()
                        .ok_or_else(|| BatchError::Format(format!("column `{name}` is not a list")))
                })
                .transpose()
        };
        let mut strings = [None; 5];
        for (slot, name) in strings.iter_mut().zip(ROUTE_STRINGS) {
            if let Some(l) = list(name)? {
                let v = l
                    .values()
                    .as_any()
                    .downcast_ref::<StringArray>()
                    .ok_or_else(|| {
                        BatchError::Format(format!("column `{name}` is not list<utf8>"))
                    })?;
                *slot = Some((l, v));
            }
        }
        let path = match list("route_path")? {
            Some(l) => Some((
                l,
                Points::new(
                    l.values()
                        .as_any()
                        .downcast_ref::<FixedSizeListArray>()
                        .ok_or_else(|| {
                            BatchError::Format("column `route_path` does not hold points".into())
                        })?,
                    "route_path",
                )?,
            )),
            None => None,
        };
        let levels = match list("route_levels")? {
            Some(l) => Some((
                l,
                l.values()
                    .as_any()
                    .downcast_ref::<UInt32Array>()
                    .ok_or_else(|| {
                        BatchError::Format("column `route_levels` is not list<uint32>".into())
                    })?,
            )),
            None => None,
        };
        let levels_crossed = batch
            .column_by_name("levels_crossed")
            .map(|c| {
                c.as_any().downcast_ref::<UInt32Array>().ok_or_else(|| {
                    BatchError::Format("column `levels_crossed` is not uint32".into())
                })
            })
            .transpose()?;
        let goal_object = batch
            .column_by_name("route_goal_object")
            .map(|c| {
                c.as_any().downcast_ref::<StringArray>().ok_or_else(|| {
                    BatchError::Format("column `route_goal_object` is not utf8".into())
                })
            })
            .transpose()?;
        Ok(RouteColumns {
            levels_crossed,
            path,
            strings,
            levels,
            goal_object,
        })
    }

    /// Row `i`'s levels crossed (0 when the column is missing), as (column, message) on error.
    fn levels_crossed(&self, i: usize) -> Result<u32, (&'static str, String)> {
        match self.levels_crossed {
            None => Ok(0),
            Some(a) if a.is_null(i) => Err(("levels_crossed", "null value".into())),
            Some(a) => Ok(a.value(i)),
        }
    }

    /// Row `i`'s route; `None` when the file has no route columns or the row's path and
    /// instructions are both empty.
    fn route(&self, i: usize) -> Result<Option<Route>, (&'static str, String)> {
        let Some((paths, points)) = &self.path else {
            return Ok(None);
        };
        let range = |l: &ListArray, name: &'static str| {
            if l.is_null(i) {
                return Err((name, "null list".to_string()));
            }
            Ok(l.value_offsets()[i] as usize..l.value_offsets()[i + 1] as usize)
        };
        let path = range(paths, "route_path")?
            .map(|k| {
                points
                    .get(k)
                    .ok_or_else(|| ("route_path", "null point".to_string()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut texts: [Vec<String>; 5] = Default::default();
        for ((out, col), name) in texts.iter_mut().zip(&self.strings).zip(ROUTE_STRINGS) {
            if let Some((l, v)) = col {
                for k in range(l, name)? {
                    if v.is_null(k) {
                        return Err((name, "null item".into()));
                    }
                    out.push(v.value(k).to_string());
                }
            }
        }
        let [room_ids, room_classes, doors, landmarks, instructions] = texts;
        if path.is_empty() && instructions.is_empty() {
            return Ok(None);
        }
        if room_ids.len() != room_classes.len() {
            return Err((
                "route_room_classes",
                format!(
                    "{} room ids and {} classes: expected one class per room",
                    room_ids.len(),
                    room_classes.len()
                ),
            ));
        }
        let levels = match &self.levels {
            Some((l, v)) => range(l, "route_levels")?.map(|k| v.value(k)).collect(),
            None => Vec::new(),
        };
        Ok(Some(Route {
            path,
            rooms: room_ids
                .into_iter()
                .zip(room_classes)
                .map(|(id, class)| TargetRoom { id, class })
                .collect(),
            doors,
            levels,
            landmarks,
            goal_object: self
                .goal_object
                .filter(|g| !g.is_null(i))
                .map(|g| g.value(i).to_string()),
            instructions,
        }))
    }
}

/// Rows per record batch (and at most per row group) when writing.
const BATCH_ROWS: usize = 65_536;

/// Errors reading or writing an episode file.
#[derive(Debug, thiserror::Error)]
pub enum EpisodeFileError {
    /// The file could not be read or written, is not Parquet, or lacks a column.
    #[error(transparent)]
    File(#[from] ParquetFileError),
    /// A value that cannot be turned back into an episode.
    #[error(
        "{path}: row {row}: {column}: {}",
        crate::escape::escape_controls(.message)
    )]
    Value {
        /// The episode file.
        path: String,
        /// Zero-based row index in the file.
        row: usize,
        /// The column holding the bad value.
        column: &'static str,
        /// What is wrong.
        message: String,
    },
}

/// The goal's targets and their label, `None` for a point goal.
fn goal_targets(goal: &Goal) -> Option<&[GoalTarget]> {
    match goal {
        Goal::Point { .. } => None,
        Goal::Object { targets, .. } | Goal::Room { targets, .. } => Some(targets),
    }
}

/// The point written to `goal_x/y/z`.
fn goal_point(goal: &Goal) -> [f32; 3] {
    match goal {
        Goal::Point { position } => *position,
        Goal::Object { targets, .. } | Goal::Room { targets, .. } => {
            targets.first().map(|t| t.position).unwrap_or([f32::NAN; 3])
        }
    }
}

fn to_batch(eps: &[Episode]) -> Result<RecordBatch, arrow::error::ArrowError> {
    let strs = |f: &dyn Fn(&Episode) -> &str| -> ArrayRef {
        Arc::new(StringArray::from_iter_values(eps.iter().map(f)))
    };
    let f32s = |f: &dyn Fn(&Episode) -> f32| -> ArrayRef {
        Arc::new(Float32Array::from_iter_values(eps.iter().map(f)))
    };
    let u32s = |f: &dyn Fn(&Episode) -> u32| -> ArrayRef {
        Arc::new(UInt32Array::from_iter_values(eps.iter().map(f)))
    };
    let point = || FixedSizeListBuilder::new(Float32Builder::new(), 3);

    let mut ids = ListBuilder::new(StringBuilder::new());
    let mut positions = ListBuilder::new(point());
    let mut views = ListBuilder::new(ListBuilder::new(point()));
    let mut room_ids = ListBuilder::new(StringBuilder::new());
    let mut room_classes = ListBuilder::new(StringBuilder::new());
    for e in eps {
        for t in goal_targets(&e.goal).unwrap_or(&[]) {
            room_ids
                .values()
                .append_option(t.room.as_ref().map(|r| r.id.as_str()));
            room_classes
                .values()
                .append_option(t.room.as_ref().map(|r| r.class.as_str()));
            ids.values().append_value(&t.id);
            positions.values().values().append_slice(&t.position);
            positions.values().append(true);
            let per_target = views.values();
            for v in &t.view_points {
                per_target.values().values().append_slice(v);
                per_target.values().append(true);
            }
            per_target.append(true);
        }
        ids.append(true);
        positions.append(true);
        views.append(true);
        room_ids.append(true);
        room_classes.append(true);
    }

    // The VLN route columns (empty lists, and a null goal object, for other tasks).
    fn route(e: &Episode) -> Option<&Route> {
        e.route.as_deref()
    }
    let strings = |f: &dyn Fn(&Route) -> Vec<&str>| -> ArrayRef {
        let mut b = ListBuilder::new(StringBuilder::new());
        for e in eps {
            for v in route(e).map(f).unwrap_or_default() {
                b.values().append_value(v);
            }
            b.append(true);
        }
        Arc::new(b.finish())
    };
    let mut route_path = ListBuilder::new(point());
    let mut route_levels = ListBuilder::new(arrow::array::UInt32Builder::new());
    for e in eps {
        if let Some(r) = route(e) {
            for p in &r.path {
                route_path.values().values().append_slice(p);
                route_path.values().append(true);
            }
            route_levels.values().append_slice(&r.levels);
        }
        route_path.append(true);
        route_levels.append(true);
    }
    let mut columns: Vec<(&'static str, ArrayRef, bool)> = vec![
        ("episode_id", strs(&|e| &e.episode_id), false),
        ("scene_id", strs(&|e| &e.scene_id), false),
        ("split", strs(&|e| &e.split), false),
        ("task", strs(&|e| e.task.name()), false),
        (
            "seed",
            Arc::new(UInt64Array::from_iter_values(eps.iter().map(|e| e.seed))),
            false,
        ),
        ("start_x", f32s(&|e| e.start_position[0]), false),
        ("start_y", f32s(&|e| e.start_position[1]), false),
        ("start_z", f32s(&|e| e.start_position[2]), false),
        ("start_yaw", f32s(&|e| e.start_yaw), false),
        ("goal_x", f32s(&|e| goal_point(&e.goal)[0]), false),
        ("goal_y", f32s(&|e| goal_point(&e.goal)[1]), false),
        ("goal_z", f32s(&|e| goal_point(&e.goal)[2]), false),
        (
            "goal_category",
            Arc::new(
                eps.iter()
                    .map(|e| match &e.goal {
                        Goal::Object { category, .. } => Some(category.as_str()),
                        _ => None,
                    })
                    .collect::<StringArray>(),
            ),
            true,
        ),
        (
            "goal_room_class",
            Arc::new(
                eps.iter()
                    .map(|e| match &e.goal {
                        Goal::Room { class, .. } => Some(class.as_str()),
                        _ => None,
                    })
                    .collect::<StringArray>(),
            ),
            true,
        ),
        ("goal_ids", Arc::new(ids.finish()), false),
        ("goal_positions", Arc::new(positions.finish()), false),
        ("goal_view_points", Arc::new(views.finish()), false),
        ("goal_room_ids", Arc::new(room_ids.finish()), false),
        ("goal_room_classes", Arc::new(room_classes.finish()), false),
        ("euclidean_distance", f32s(&|e| e.euclidean_distance), false),
        ("geodesic_distance", f32s(&|e| e.geodesic_distance), false),
        ("path_num_doors", u32s(&|e| e.path_num_doors), false),
        ("path_num_rooms", u32s(&|e| e.path_num_rooms), false),
        ("difficulty", strs(&|e| e.difficulty.name()), false),
        ("success_radius", f32s(&|e| e.success_radius), false),
        ("max_steps", u32s(&|e| e.max_steps), false),
        ("levels_crossed", u32s(&|e| e.levels_crossed), false),
        ("route_path", Arc::new(route_path.finish()), false),
    ];
    columns.extend([
        (
            "route_room_ids",
            strings(&|r| r.rooms.iter().map(|x| x.id.as_str()).collect()),
            false,
        ),
        (
            "route_room_classes",
            strings(&|r| r.rooms.iter().map(|x| x.class.as_str()).collect()),
            false,
        ),
        (
            "route_door_ids",
            strings(&|r| r.doors.iter().map(String::as_str).collect()),
            false,
        ),
        (
            "route_levels",
            Arc::new(route_levels.finish()) as ArrayRef,
            false,
        ),
        (
            "route_landmark_ids",
            strings(&|r| r.landmarks.iter().map(String::as_str).collect()),
            false,
        ),
        (
            "route_goal_object",
            Arc::new(
                eps.iter()
                    .map(|e| route(e).and_then(|r| r.goal_object.as_deref()))
                    .collect::<StringArray>(),
            ),
            true,
        ),
        (
            "instructions",
            strings(&|r| r.instructions.iter().map(String::as_str).collect()),
            false,
        ),
    ]);
    let schema = Schema::new(
        columns
            .iter()
            .map(|(name, a, nullable)| Field::new(*name, a.data_type().clone(), *nullable))
            .collect::<Vec<_>>(),
    );
    RecordBatch::try_new(
        Arc::new(schema),
        columns.into_iter().map(|(_, a, _)| a).collect(),
    )
}

/// Writes `episodes` to `path` atomically, one row per episode in the order given (see the
/// module documentation for the columns). The same episodes always give the same bytes.
pub fn write_episodes(path: &Path, episodes: &[Episode]) -> Result<(), EpisodeFileError> {
    // The schema does not depend on the data: take it from an empty batch.
    let schema = to_batch(&[])
        .map_err(|e| ParquetFileError::format(path, e))?
        .schema();
    let props = writer_properties(3, Some(BATCH_ROWS), &schema);
    let batches = episodes.chunks(BATCH_ROWS).map(to_batch);
    write_batches(path, schema, props, batches).map_err(EpisodeFileError::from)
}

/// Reads every episode of an episode file, in file order. A panic inside the Parquet or Arrow
/// readers on a malformed file (arrow-ipc 58 panics on some schema metadata) is an error naming
/// the file.
pub fn read_episodes(path: &Path) -> Result<Vec<Episode>, EpisodeFileError> {
    crate::escape::catch_quietly(|| read_episodes_unguarded(path)).unwrap_or_else(|what| {
        Err(ParquetFileError::format(path, format!("the Parquet reader failed: {what}")).into())
    })
}

fn read_episodes_unguarded(path: &Path) -> Result<Vec<Episode>, EpisodeFileError> {
    let p = path.display().to_string();
    // The schema this module writes: files rewritten by pandas, polars or duckdb hold
    // variants of its types (plain lists for fixed-size points, int64 for a column a user set).
    let schema = to_batch(&[])
        .map_err(|e| ParquetFileError::format(path, e))?
        .schema();
    let reader = read_batches(path)?.conform_to(&schema);
    let mut episodes = Vec::new();
    for batch in reader {
        let batch = batch.map_err(|e| ParquetFileError::format(path, e))?;
        let first_row = episodes.len();
        read_batch(&batch, first_row, &mut episodes).map_err(|e| match e {
            BatchError::Format(message) => ParquetFileError::format(path, message).into(),
            BatchError::Value {
                row,
                column,
                message,
            } => EpisodeFileError::Value {
                path: p.clone(),
                row,
                column,
                message,
            },
        })?;
    }
    Ok(episodes)
}

enum BatchError {
    Format(String),
    Value {
        row: usize,
        column: &'static str,
        message: String,
    },
}

fn column<'a, T: arrow::array::Array + 'static>(
    batch: &'a RecordBatch,
    name: &str,
) -> Result<&'a T, BatchError> {
    crate::parquet_io::column(batch, name).map_err(|e| BatchError::Format(e.into()))
}

/// A `list<fixed_size_list<float32, 3>>`-shaped array's parts: the point list and its floats.
struct Points<'a> {
    list: &'a FixedSizeListArray,
    floats: &'a Float32Array,
}

impl<'a> Points<'a> {
    fn new(list: &'a FixedSizeListArray, name: &str) -> Result<Self, BatchError> {
        let floats = list
            .values()
            .as_any()
            .downcast_ref::<Float32Array>()
            .filter(|_| list.value_length() == 3)
            .ok_or_else(|| {
                BatchError::Format(format!(
                    "column `{name}` does not hold fixed_size_list<float32, 3> points"
                ))
            })?;
        Ok(Points { list, floats })
    }

    /// Point `k` of the flattened point list, or `None` if it (or a coordinate) is null.
    fn get(&self, k: usize) -> Option<[f32; 3]> {
        if self.list.is_null(k) {
            return None;
        }
        let o = self.list.value_offset(k) as usize;
        let mut p = [0.0; 3];
        for (a, v) in p.iter_mut().enumerate() {
            if self.floats.is_null(o + a) {
                return None;
            }
            *v = self.floats.value(o + a);
        }
        Some(p)
    }
}

fn read_batch(
    batch: &RecordBatch,
    first_row: usize,
    out: &mut Vec<Episode>,
) -> Result<(), BatchError> {
    let episode_id = column::<StringArray>(batch, "episode_id")?;
    let scene_id = column::<StringArray>(batch, "scene_id")?;
    let split = column::<StringArray>(batch, "split")?;
    let task = column::<StringArray>(batch, "task")?;
    let seed = column::<UInt64Array>(batch, "seed")?;
    let f32col = |name| column::<Float32Array>(batch, name);
    let start = [f32col("start_x")?, f32col("start_y")?, f32col("start_z")?];
    let start_yaw = f32col("start_yaw")?;
    let goal_xyz = [f32col("goal_x")?, f32col("goal_y")?, f32col("goal_z")?];
    let category = column::<StringArray>(batch, "goal_category")?;
    let room_class = column::<StringArray>(batch, "goal_room_class")?;
    let goal_ids = column::<ListArray>(batch, "goal_ids")?;
    let goal_positions = column::<ListArray>(batch, "goal_positions")?;
    let goal_views = column::<ListArray>(batch, "goal_view_points")?;
    let target_rooms = TargetRooms::of(batch)?;
    let euclid = f32col("euclidean_distance")?;
    let geodesic = f32col("geodesic_distance")?;
    let doors = column::<UInt32Array>(batch, "path_num_doors")?;
    let rooms = column::<UInt32Array>(batch, "path_num_rooms")?;
    let difficulty = column::<StringArray>(batch, "difficulty")?;
    let success_radius = f32col("success_radius")?;
    let max_steps = column::<UInt32Array>(batch, "max_steps")?;
    let route_columns = RouteColumns::of(batch)?;

    let id_values = goal_ids
        .values()
        .as_any()
        .downcast_ref::<StringArray>()
        .ok_or_else(|| BatchError::Format("column `goal_ids` is not list<utf8>".into()))?;
    let positions = Points::new(
        goal_positions
            .values()
            .as_any()
            .downcast_ref::<FixedSizeListArray>()
            .ok_or_else(|| BatchError::Format("column `goal_positions` is not a list".into()))?,
        "goal_positions",
    )?;
    let view_lists = goal_views
        .values()
        .as_any()
        .downcast_ref::<ListArray>()
        .ok_or_else(|| {
            BatchError::Format("column `goal_view_points` is not a list of lists".into())
        })?;
    let views = Points::new(
        view_lists
            .values()
            .as_any()
            .downcast_ref::<FixedSizeListArray>()
            .ok_or_else(|| {
                BatchError::Format("column `goal_view_points` does not hold points".into())
            })?,
        "goal_view_points",
    )?;

    for i in 0..batch.num_rows() {
        let row = first_row + i;
        let bad = |column: &'static str, message: String| BatchError::Value {
            row,
            column,
            message,
        };
        let null = |column: &'static str| bad(column, "null value".into());
        macro_rules! get {
            ($arr:expr, $name:literal) => {{
                if $arr.is_null(i) {
                    return Err(null($name));
                }
                $arr.value(i)
            }};
        }
        let task_name = get!(task, "task");
        let task_v = task_name
            .parse::<Task>()
            .map_err(|e| bad("task", e.to_string()))?;
        let diff_name = get!(difficulty, "difficulty");
        let difficulty_v = diff_name
            .parse::<Difficulty>()
            .map_err(|e| bad("difficulty", e.to_string()))?;

        let goal = if matches!(task_v, Task::PointGoal | Task::Vln) {
            Goal::Point {
                position: [
                    get!(goal_xyz[0], "goal_x"),
                    get!(goal_xyz[1], "goal_y"),
                    get!(goal_xyz[2], "goal_z"),
                ],
            }
        } else {
            for (arr, name) in [
                (goal_ids, "goal_ids"),
                (goal_positions, "goal_positions"),
                (goal_views, "goal_view_points"),
            ] {
                if arr.is_null(i) {
                    return Err(null(name));
                }
            }
            let id_range =
                goal_ids.value_offsets()[i] as usize..goal_ids.value_offsets()[i + 1] as usize;
            let pos_start = goal_positions.value_offsets()[i] as usize;
            let pos_len = goal_positions.value_length(i) as usize;
            let view_start = goal_views.value_offsets()[i] as usize;
            let view_len = goal_views.value_length(i) as usize;
            if pos_len != id_range.len() || view_len != id_range.len() {
                return Err(bad(
                    "goal_positions",
                    format!(
                        "{} ids, {pos_len} positions and {view_len} view point lists: expected one of each per target",
                        id_range.len()
                    ),
                ));
            }
            let mut targets = Vec::with_capacity(id_range.len());
            for (j, k) in id_range.enumerate() {
                if id_values.is_null(k) {
                    return Err(bad("goal_ids", format!("target {j}: null id")));
                }
                let position = positions
                    .get(pos_start + j)
                    .ok_or_else(|| bad("goal_positions", format!("target {j}: null point")))?;
                let vl = view_start + j;
                if view_lists.is_null(vl) {
                    return Err(bad("goal_view_points", format!("target {j}: null list")));
                }
                let v0 = view_lists.value_offsets()[vl] as usize;
                let v1 = view_lists.value_offsets()[vl + 1] as usize;
                let view_points = (v0..v1)
                    .map(|v| {
                        views.get(v).ok_or_else(|| {
                            bad(
                                "goal_view_points",
                                format!("target {j}: view point {}: null point", v - v0),
                            )
                        })
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                targets.push(GoalTarget {
                    id: id_values.value(k).to_string(),
                    position,
                    view_points,
                    room: target_rooms
                        .get(i, j)
                        .map_err(|m| bad("goal_room_ids", format!("target {j}: {m}")))?,
                });
            }
            if task_v == Task::ObjectGoal {
                Goal::Object {
                    category: get!(category, "goal_category").to_string(),
                    targets,
                }
            } else {
                Goal::Room {
                    class: get!(room_class, "goal_room_class").to_string(),
                    targets,
                }
            }
        };

        out.push(Episode {
            episode_id: get!(episode_id, "episode_id").to_string(),
            scene_id: get!(scene_id, "scene_id").to_string(),
            split: get!(split, "split").to_string(),
            task: task_v,
            seed: get!(seed, "seed"),
            start_position: [
                get!(start[0], "start_x"),
                get!(start[1], "start_y"),
                get!(start[2], "start_z"),
            ],
            start_yaw: get!(start_yaw, "start_yaw"),
            goal,
            euclidean_distance: get!(euclid, "euclidean_distance"),
            geodesic_distance: get!(geodesic, "geodesic_distance"),
            path_num_doors: get!(doors, "path_num_doors"),
            path_num_rooms: get!(rooms, "path_num_rooms"),
            difficulty: difficulty_v,
            success_radius: get!(success_radius, "success_radius"),
            max_steps: get!(max_steps, "max_steps"),
            levels_crossed: route_columns
                .levels_crossed(i)
                .map_err(|(c, m)| bad(c, m))?,
            route: route_columns
                .route(i)
                .map_err(|(c, m)| bad(c, m))?
                .map(Box::new),
        });
        if let Some(Err((column, message))) = out.last().map(Episode::validate) {
            return Err(bad(column, message));
        }
    }
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
    use parquet::arrow::ArrowWriter;
    use std::fs::File;

    /// One episode of each task, with several targets and view points, NaN-free.
    pub(crate) fn sample_episodes() -> Vec<Episode> {
        let base = Episode {
            episode_id: "house_a:pointgoal:00000".into(),
            scene_id: "house_a".into(),
            split: "train".into(),
            task: Task::PointGoal,
            seed: u64::MAX - 7,
            start_position: [1.25, 0.05, -3.5],
            start_yaw: 1.25,
            goal: Goal::Point {
                position: [4.0, 0.05, 2.125],
            },
            euclidean_distance: 6.3,
            geodesic_distance: 7.9,
            path_num_doors: 1,
            path_num_rooms: 2,
            difficulty: Difficulty::Hard,
            success_radius: 0.2,
            max_steps: 500,
            levels_crossed: 0,
            route: None,
        };
        let object = Episode {
            episode_id: "house_a:objectgoal:00001".into(),
            task: Task::ObjectGoal,
            split: "val".into(),
            seed: 3,
            start_position: [-2.0, 1.5, 0.75],
            start_yaw: -2.5,
            goal: Goal::Object {
                category: "chair".into(),
                targets: vec![
                    GoalTarget {
                        id: "0_12".into(),
                        position: [0.5, 0.45, 1.0],
                        view_points: vec![[0.0, 0.05, 1.0], [1.0, 0.05, 1.25]],
                        room: Some(TargetRoom {
                            id: "0_2".into(),
                            class: "living_room".into(),
                        }),
                    },
                    GoalTarget {
                        id: "0_13".into(),
                        position: [3.5, 0.45, -1.0],
                        view_points: vec![],
                        room: None,
                    },
                    GoalTarget {
                        id: "0_14".into(),
                        position: [5.5, 0.45, -1.5],
                        view_points: vec![[5.0, 0.05, -1.5]],
                        room: None,
                    },
                ],
            },
            euclidean_distance: 2.75,
            geodesic_distance: 2.9,
            path_num_doors: 0,
            path_num_rooms: 1,
            difficulty: Difficulty::Easy,
            success_radius: 0.1,
            max_steps: 250,
            levels_crossed: 1,
            ..base.clone()
        };
        let room = Episode {
            episode_id: "house_b@dark:roomgoal:00002".into(),
            scene_id: "house_b@dark".into(),
            split: String::new(),
            task: Task::RoomGoal,
            seed: 0,
            goal: Goal::Room {
                class: "kitchen".into(),
                targets: vec![GoalTarget {
                    id: "0_4".into(),
                    position: [7.0, 0.0, 7.0],
                    view_points: vec![[6.5, 0.0, 7.0], [7.5, 0.0, 7.0], [7.0, 0.0, 6.5]],
                    room: Some(TargetRoom {
                        id: "0_4".into(),
                        class: "kitchen".into(),
                    }),
                }],
            },
            difficulty: Difficulty::Medium,
            ..base.clone()
        };
        vec![base, object, room]
    }

    #[test]
    fn files_without_target_rooms_still_read_with_rooms_unknown() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.parquet");
        let eps = sample_episodes();
        write_episodes(&a, &eps).unwrap();
        // Drop the two room columns, as a file written before they existed.
        let batch = ParquetRecordBatchReaderBuilder::try_new(File::open(&a).unwrap())
            .unwrap()
            .build()
            .unwrap()
            .next()
            .unwrap()
            .unwrap();
        let keep: Vec<usize> = (0..batch.num_columns())
            .filter(|&c| {
                !["goal_room_ids", "goal_room_classes"]
                    .contains(&batch.schema().field(c).name().as_str())
            })
            .collect();
        let old = batch.project(&keep).unwrap();
        assert_eq!(old.num_columns() + 2, batch.num_columns());
        let b = dir.path().join("old.parquet");
        let mut w = ArrowWriter::try_new(File::create(&b).unwrap(), old.schema(), None).unwrap();
        w.write(&old).unwrap();
        w.close().unwrap();
        let back = read_episodes(&b).unwrap();
        let mut expected = eps;
        for e in &mut expected {
            if let Goal::Object { targets, .. } | Goal::Room { targets, .. } = &mut e.goal {
                for t in targets {
                    t.room = None;
                }
            }
        }
        assert_eq!(back, expected);
    }

    #[test]
    fn all_tasks_round_trip_exactly_and_rewrite_is_byte_identical() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.parquet");
        let b = dir.path().join("sub/b.parquet");
        let eps = sample_episodes();
        write_episodes(&a, &eps).unwrap();
        let back = read_episodes(&a).unwrap();
        assert_eq!(back, eps);
        write_episodes(&b, &back).unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
        // Different content gives different bytes (the comparison above means something).
        let mut changed = eps.clone();
        changed[1].start_yaw += 0.5;
        write_episodes(&b, &changed).unwrap();
        assert_ne!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    }

    #[test]
    fn empty_file_round_trips_and_many_rows_span_batches() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("e.parquet");
        write_episodes(&p, &[]).unwrap();
        assert!(read_episodes(&p).unwrap().is_empty());
        let eps: Vec<Episode> = (0..BATCH_ROWS + 10)
            .map(|i| {
                let mut e = sample_episodes()[i % 3].clone();
                e.episode_id = format!("x:{i}");
                e.seed = i as u64;
                e
            })
            .collect();
        write_episodes(&p, &eps).unwrap();
        let back = read_episodes(&p).unwrap();
        assert_eq!(back.len(), eps.len());
        assert_eq!(back, eps);
    }

    #[test]
    fn columns_are_what_the_documentation_says() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.parquet");
        write_episodes(&p, &sample_episodes()).unwrap();
        let reader = ParquetRecordBatchReaderBuilder::try_new(File::open(&p).unwrap()).unwrap();
        let names: Vec<String> = reader
            .schema()
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .collect();
        let expected = "episode_id scene_id split task seed start_x start_y start_z start_yaw \
            goal_x goal_y goal_z goal_category goal_room_class goal_ids goal_positions \
            goal_view_points goal_room_ids goal_room_classes euclidean_distance \
            geodesic_distance path_num_doors \
            path_num_rooms difficulty success_radius max_steps levels_crossed route_path \
            route_room_ids route_room_classes route_door_ids route_levels route_landmark_ids \
            route_goal_object instructions";
        assert_eq!(names, expected.split_whitespace().collect::<Vec<_>>());
        let batch = reader.build().unwrap().next().unwrap().unwrap();
        // ObjectGoal row: goal_x/y/z is the first target's position; nulls where documented.
        let gx = batch.column_by_name("goal_x").unwrap();
        let gx = gx.as_any().downcast_ref::<Float32Array>().unwrap();
        assert_eq!(gx.value(1), 0.5);
        let cat = batch.column_by_name("goal_category").unwrap();
        assert!(cat.is_null(0) && !cat.is_null(1) && cat.is_null(2));
        let room = batch.column_by_name("goal_room_class").unwrap();
        assert!(room.is_null(0) && room.is_null(1) && !room.is_null(2));
        let ids = batch.column_by_name("goal_ids").unwrap();
        let ids = ids.as_any().downcast_ref::<ListArray>().unwrap();
        assert_eq!(
            (
                ids.value_length(0),
                ids.value_length(1),
                ids.value_length(2)
            ),
            (0, 3, 1)
        );
    }

    /// Rewrites column `name` of the file at `p` with `value` in every row.
    fn with_string_column(p: &Path, name: &str, value: &str) {
        let reader = ParquetRecordBatchReaderBuilder::try_new(File::open(p).unwrap())
            .unwrap()
            .build()
            .unwrap();
        let batch = reader.into_iter().next().unwrap().unwrap();
        let schema = batch.schema();
        let cols: Vec<ArrayRef> = schema
            .fields()
            .iter()
            .zip(batch.columns())
            .map(|(f, c)| {
                if f.name() == name {
                    Arc::new(StringArray::from_iter_values(std::iter::repeat_n(
                        value,
                        batch.num_rows(),
                    ))) as ArrayRef
                } else {
                    c.clone()
                }
            })
            .collect();
        let batch = RecordBatch::try_new(schema.clone(), cols).unwrap();
        let mut w = ArrowWriter::try_new(File::create(p).unwrap(), schema, None).unwrap();
        w.write(&batch).unwrap();
        w.close().unwrap();
    }

    #[test]
    fn bad_values_name_file_row_and_column() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.parquet");
        write_episodes(&p, &sample_episodes()).unwrap();
        with_string_column(&p, "task", "flygoal");
        let err = read_episodes(&p).unwrap_err().to_string();
        assert!(
            err.contains("bad.parquet: row 0: task: unknown task `flygoal`"),
            "{err}"
        );

        write_episodes(&p, &sample_episodes()).unwrap();
        with_string_column(&p, "difficulty", "brutal");
        let err = read_episodes(&p).unwrap_err().to_string();
        assert!(
            err.contains("row 0: difficulty: unknown difficulty `brutal`"),
            "{err}"
        );

        // Text quoted from the file stays on one line.
        write_episodes(&p, &sample_episodes()).unwrap();
        with_string_column(&p, "task", "fly\ngoal");
        let err = read_episodes(&p).unwrap_err().to_string();
        assert!(
            err.contains("row 0: task: unknown task `fly\\ngoal`") && !err.contains('\n'),
            "{err}"
        );

        // Numbers later stages compute with are checked: a NaN start, a negative radius.
        let mut eps = sample_episodes();
        eps[1].start_position[1] = f32::NAN;
        write_episodes(&p, &eps).unwrap();
        let err = read_episodes(&p).unwrap_err().to_string();
        assert!(err.contains("row 1: start_y: NaN is not finite"), "{err}");
        let mut eps = sample_episodes();
        eps[0].success_radius = -0.5;
        write_episodes(&p, &eps).unwrap();
        let err = read_episodes(&p).unwrap_err().to_string();
        assert!(
            err.contains("row 0: success_radius: -0.5 is not a finite radius"),
            "{err}"
        );

        let missing = dir.path().join("missing.parquet");
        let err = read_episodes(&missing).unwrap_err().to_string();
        assert!(err.starts_with(&missing.display().to_string()), "{err}");
    }
}
