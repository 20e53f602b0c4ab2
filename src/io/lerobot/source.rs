//! Reading a run's tables for the LeRobot copy: the episodes (with their instructions), the
//! trajectory rows, and the observation rows streamed one at a time with each camera's
//! image decoded, so a run of any size converts in bounded memory (one episode at a time).

use std::path::{Path, PathBuf};

use arrow::array::{
    Array, BinaryArray, BooleanArray, Float32Array, ListArray, RecordBatch, RecordBatchReader,
    StringArray, UInt32Array,
};

use super::features::Camera;
use super::LerobotError;
use crate::invalid::Invalid;
use crate::io::image_codec::{decode_cell, modality_from_name, CellFormat};
use crate::io::run_dir::RunDir;
use crate::parquet_io::{column, read_batches};
use crate::render::{Image, Modality};
use crate::run::agents::Decision;
use crate::run::step_features::action_vector;
use crate::scene::RoomClass;

/// The tables of a run folder that the LeRobot copy is made from.
#[derive(Debug, Clone, PartialEq)]
pub struct RunTables {
    /// `trajectories.parquet`.
    pub trajectories: PathBuf,
    /// `observations.parquet`.
    pub observations: PathBuf,
    /// `episodes.parquet`.
    pub episodes: PathBuf,
}

impl RunTables {
    /// The tables of the run folder `dir`.
    pub fn in_dir(dir: &Path) -> RunTables {
        let run = RunDir::new(dir);
        RunTables {
            trajectories: run.trajectories(),
            observations: run.observations(),
            episodes: run.episodes(),
        }
    }
}

/// One row of the run's episode table.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeRow {
    /// minos's episode id.
    pub episode_id: String,
    /// The scene (or variant).
    pub scene_id: String,
    /// The split subset (may be empty).
    pub split: String,
    /// The task in words.
    pub instruction: String,
}

/// One trajectory row.
#[derive(Debug, Clone, PartialEq)]
pub struct StepRow {
    /// The episode.
    pub episode_id: String,
    /// Step index.
    pub step: u32,
    /// x, y, z, yaw, tilt before the action.
    pub state: [f32; 5],
    /// The eight strengths and stop.
    pub action: [f32; 9],
    /// The reward.
    pub reward: f32,
    /// The episode ended after this step.
    pub done: bool,
    /// The episode succeeded (its last row).
    pub success: bool,
    /// Distance and agent-frame direction to the goal (zeros without a goal).
    pub goal: [f32; 3],
    /// The room goal's class, one-hot.
    pub goal_room: [f32; 9],
    /// The object goal's category.
    pub goal_object: Option<String>,
    /// 1 when the success test held.
    pub at_goal: [f32; 1],
    /// The contact bits.
    pub contact: Vec<f32>,
    /// 1 when the step into this frame collided.
    pub collision: [f32; 1],
    /// The previous frame's action vector.
    pub previous_action: [f32; 9],
    /// Steps left.
    pub steps_left: [f32; 1],
}

fn read_error(path: &Path, record: String, cause: impl Into<super::ReadCause>) -> LerobotError {
    LerobotError::Read {
        path: path.to_path_buf(),
        record,
        cause: cause.into(),
    }
}

fn batches(path: &Path) -> Result<crate::parquet_io::Batches, LerobotError> {
    read_batches(path).map_err(LerobotError::from)
}

/// Reads the episode table.
pub fn read_episodes(path: &Path) -> Result<Vec<EpisodeRow>, LerobotError> {
    let mut out = Vec::new();
    for batch in batches(path)? {
        let batch = batch.map_err(|e| read_error(path, "row group".into(), e))?;
        let text = |name: &str| {
            column::<StringArray>(&batch, name).map_err(|e| read_error(path, "schema".into(), e))
        };
        let (ids, scenes, splits, words) = (
            text("episode_id")?,
            text("scene_id")?,
            text("split")?,
            text("instruction")?,
        );
        for i in 0..batch.num_rows() {
            let record = format!("row {}", out.len());
            for (name, c) in [
                ("episode_id", ids),
                ("scene_id", scenes),
                ("split", splits),
                ("instruction", words),
            ] {
                if c.is_null(i) {
                    return Err(read_error(path, record, format!("{name} is null")));
                }
            }
            out.push(EpisodeRow {
                episode_id: ids.value(i).to_string(),
                scene_id: scenes.value(i).to_string(),
                split: splits.value(i).to_string(),
                instruction: words.value(i).to_string(),
            });
        }
    }
    Ok(out)
}

/// Reads every trajectory row, in table order.
pub fn read_steps(path: &Path) -> Result<Vec<StepRow>, LerobotError> {
    let mut out = Vec::new();
    for batch in batches(path)? {
        let batch = batch.map_err(|e| read_error(path, "row group".into(), e))?;
        let schema_err = |e: Invalid| read_error(path, "schema".into(), e);
        let ids = column::<StringArray>(&batch, "episode_id").map_err(schema_err)?;
        let steps = column::<UInt32Array>(&batch, "step").map_err(schema_err)?;
        let pose: Vec<&Float32Array> = ["x", "y", "z", "yaw", "tilt"]
            .iter()
            .map(|c| column::<Float32Array>(&batch, c).map_err(schema_err))
            .collect::<Result<_, _>>()?;
        let actions = column::<StringArray>(&batch, "action").map_err(schema_err)?;
        let strengths = column::<ListArray>(&batch, "action_strengths").map_err(schema_err)?;
        let reward = column::<Float32Array>(&batch, "reward").map_err(schema_err)?;
        let done = column::<BooleanArray>(&batch, "done").map_err(schema_err)?;
        let success = column::<BooleanArray>(&batch, "success").map_err(schema_err)?;
        let euclidean = column::<Float32Array>(&batch, "euclidean_distance").map_err(schema_err)?;
        let goal_right = column::<Float32Array>(&batch, "goal_right").map_err(schema_err)?;
        let goal_forward = column::<Float32Array>(&batch, "goal_forward").map_err(schema_err)?;
        let goal_room = column::<StringArray>(&batch, "goal_room").map_err(schema_err)?;
        let goal_object = column::<StringArray>(&batch, "goal_object").map_err(schema_err)?;
        let at_goal = column::<BooleanArray>(&batch, "at_goal").map_err(schema_err)?;
        let contacts = column::<ListArray>(&batch, "contacts").map_err(schema_err)?;
        let previous = column::<StringArray>(&batch, "previous_action").map_err(schema_err)?;
        let previous_collision =
            column::<BooleanArray>(&batch, "previous_collision").map_err(schema_err)?;
        let steps_left = column::<UInt32Array>(&batch, "steps_left").map_err(schema_err)?;
        for i in 0..batch.num_rows() {
            let record = format!("row {}", out.len());
            let nulls = [
                ids.is_null(i),
                steps.is_null(i),
                actions.is_null(i),
                strengths.is_null(i),
                reward.is_null(i),
                done.is_null(i),
                success.is_null(i),
                at_goal.is_null(i),
                contacts.is_null(i),
                previous_collision.is_null(i),
                steps_left.is_null(i),
            ];
            if nulls.iter().any(|n| *n) || pose.iter().any(|c| c.is_null(i)) {
                return Err(read_error(path, record, "a required value is null"));
            }
            let s = strengths.value(i);
            let s = s
                .as_any()
                .downcast_ref::<Float32Array>()
                .filter(|s| s.len() == 8 && s.null_count() == 0)
                .ok_or_else(|| {
                    read_error(path, record.clone(), "action_strengths: not 8 numbers")
                })?;
            let mut action = [0.0f32; 9];
            for (k, a) in action.iter_mut().take(8).enumerate() {
                *a = s.value(k);
            }
            action[8] = f32::from(u8::from(actions.value(i) == "stop"));
            let opt = |c: &Float32Array| (!c.is_null(i)).then(|| c.value(i));
            let text = |c: &StringArray| (!c.is_null(i)).then(|| c.value(i).to_string());
            let goal = match opt(euclidean) {
                Some(d) => [
                    d,
                    opt(goal_right).unwrap_or(0.0),
                    opt(goal_forward).unwrap_or(0.0),
                ],
                None => [0.0; 3],
            };
            let mut room = [0.0f32; 9];
            if let Some(name) = text(goal_room) {
                let class = RoomClass::from_label(&name).ok_or_else(|| {
                    read_error(
                        path,
                        record.clone(),
                        format!("goal_room: unknown class `{name}`"),
                    )
                })?;
                room[class.index() as usize] = 1.0;
            }
            let previous_action = match text(previous) {
                None => action_vector(None),
                Some(name) => {
                    let d = Decision::from_name(&name).ok_or_else(|| {
                        read_error(
                            path,
                            record.clone(),
                            format!("previous_action: unknown action `{name}`"),
                        )
                    })?;
                    action_vector(Some(&d))
                }
            };
            let c = contacts.value(i);
            let c = c
                .as_any()
                .downcast_ref::<BooleanArray>()
                .filter(|c| c.null_count() == 0)
                .ok_or_else(|| read_error(path, record.clone(), "contacts: not booleans"))?;
            let contact = (0..c.len())
                .map(|k| f32::from(u8::from(c.value(k))))
                .collect();
            let flag = |b: bool| [f32::from(u8::from(b))];
            out.push(StepRow {
                episode_id: ids.value(i).to_string(),
                step: steps.value(i),
                state: [0, 1, 2, 3, 4].map(|k| pose[k].value(i)),
                action,
                reward: reward.value(i),
                done: done.value(i),
                success: success.value(i),
                goal,
                goal_room: room,
                goal_object: text(goal_object),
                at_goal: flag(at_goal.value(i)),
                contact,
                collision: flag(previous_collision.value(i)),
                previous_action,
                steps_left: [steps_left.value(i) as f32],
            });
        }
    }
    Ok(out)
}

/// The observation table, read row by row.
pub struct ObservationRows {
    path: PathBuf,
    reader: crate::parquet_io::Batches,
    cameras: Vec<Camera>,
    batch: Option<RecordBatch>,
    next: usize,
    rows_read: usize,
}

/// One observation row: the episode, the step and each camera's image.
pub type ObservationRow = (String, u32, Vec<Image>);

impl ObservationRows {
    /// Opens the table; its cameras come from the image columns' metadata.
    pub fn open(path: &Path) -> Result<ObservationRows, LerobotError> {
        let reader = batches(path)?;
        let schema = reader.schema();
        let mut cameras = Vec::new();
        for field in schema.fields().iter().skip(2) {
            let meta = field.metadata();
            let record = format!("column `{}`", field.name());
            let format =
                CellFormat::from_metadata(meta).map_err(|e| read_error(path, record.clone(), e))?;
            let modality: Modality = meta
                .get("modality")
                .and_then(|m| modality_from_name(m))
                .ok_or_else(|| read_error(path, record, "metadata: no known `modality`"))?;
            cameras.push(Camera {
                name: field.name().clone(),
                modality,
                format,
            });
        }
        Ok(ObservationRows {
            path: path.to_path_buf(),
            reader,
            cameras,
            batch: None,
            next: 0,
            rows_read: 0,
        })
    }

    /// The cameras, in column order.
    pub fn cameras(&self) -> &[Camera] {
        &self.cameras
    }

    /// The next row, or `None` at the end of the table.
    pub fn next_row(&mut self) -> Result<Option<ObservationRow>, LerobotError> {
        loop {
            if let Some(b) = &self.batch {
                if self.next < b.num_rows() {
                    break;
                }
            }
            match self.reader.next() {
                None => return Ok(None),
                Some(b) => {
                    self.batch =
                        Some(b.map_err(|e| read_error(&self.path, "row group".into(), e))?);
                    self.next = 0;
                }
            }
        }
        let Some(batch) = &self.batch else {
            return Ok(None);
        };
        let i = self.next;
        let record = format!("row {}", self.rows_read);
        let schema_err = |e: Invalid| read_error(&self.path, "schema".into(), e);
        let ids = column::<StringArray>(batch, "episode_id").map_err(schema_err)?;
        let steps = column::<UInt32Array>(batch, "step").map_err(schema_err)?;
        if ids.is_null(i) || steps.is_null(i) {
            return Err(read_error(&self.path, record, "episode_id or step is null"));
        }
        let mut images = Vec::with_capacity(self.cameras.len());
        for c in &self.cameras {
            let cells = column::<BinaryArray>(batch, &c.name).map_err(schema_err)?;
            if cells.is_null(i) {
                return Err(read_error(&self.path, record, format!("{}: null", c.name)));
            }
            let image = decode_cell(cells.value(i), &c.format)
                .map_err(|e| read_error(&self.path, format!("{record}: column `{}`", c.name), e))?;
            images.push(image);
        }
        let row = (ids.value(i).to_string(), steps.value(i), images);
        self.next += 1;
        self.rows_read += 1;
        Ok(Some(row))
    }
}
