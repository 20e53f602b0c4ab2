//! The features of a minos LeRobot dataset: what each column is, how `meta/info.json`
//! describes it (LeRobot dtype, shape, names), how Hugging Face `datasets` types it (the
//! `huggingface` schema metadata of the data files) and its Arrow type.
//!
//! | key | LeRobot dtype, shape | from |
//! |---|---|---|
//! | `observation.state` | float32 \[5\]: x, y, z, yaw, tilt | the pose before the action |
//! | `action` | float32 \[9\]: the eight action strengths and `stop` | the decision |
//! | `observation.images.<sensor>` | `image` [h, w, c] (PPM / PGM) | colour and grey cameras |
//! | `observation.images.<sensor>` | `video` [h, w, 3] (H.264 in MP4, [`super::video`]) | colour cameras with `--video` |
//! | `observation.<sensor>` | `image` [h, w, 1] (PFM / PGM / TIFF), lossless | depth (metres), semantic, instance, room and room-class ids |
//! | `observation.<sensor>` | the sensor's dtype [c, h, w], lossless | several-channel arrays (normals) |
//! | `observation.goal`, `.goal_room`, `.at_goal`, `.contact`, `.collision`, `.previous_action`, `.steps_left` | float32 vectors | the per-step features ([`crate::run::step_features`]) of the trajectory row |
//! | `observation.goal_object` | int64 \[1\] | the object goal's category, an index into the dataset's vocabulary |
//! | `next.reward`, `next.done`, `next.success` | float32 / bool \[1\] | the step's outcome |
//! | `timestamp`, `frame_index`, `episode_index`, `index`, `task_index` | LeRobot's own | |
//!
//! Every camera comes out of `LeRobotDataset` channel-first, as LeRobot's images do. A
//! one-channel camera is a small image file per frame ([`ImageFile`]): Hugging Face
//! `datasets` decodes it with Pillow and LeRobot turns it into a tensor with torchvision's
//! `to_tensor`, which scales only 8-bit pictures to \[0, 1\]; a float32 PFM comes back as
//! float32 (1, h, w) in metres and a 16-bit PGM or 32-bit TIFF as int32 (1, h, w) ids, exact.
//! `datasets`' array features (`Array3D`) would go through nested Python lists (≈ 9.5 ms
//! a row against ≈ 0.1 ms for a file); only cameras no Pillow mode holds (normals: three
//! float channels) are stored so, as [c, h, w]. The keys of non-picture cameras avoid the word `image`, because
//! LeRobot requires the statistics of such keys to be 3-channel in [0, 1], and their
//! statistics are per channel, as (c, 1, 1), in the tensor's own units.

use std::sync::Arc;

use arrow::datatypes::{DataType, Field, Fields};
use serde_json::{json, Value};

use super::image_file::ImageFile;
use super::stats::StatLayout;
use super::video::VideoSettings;
use crate::io::image_codec::{modality_name, CellFormat};
use crate::render::Modality;
use crate::render::PixelType;
use crate::run::step_features::{contact_names, GOAL_NAMES};
use crate::scene::RoomClass;
use crate::sim::Actions;

/// Names of the state vector's elements.
pub const STATE_NAMES: [&str; 5] = ["x", "y", "z", "yaw", "tilt"];

/// Names of the action vector's elements: the eight strengths of MINOS's actions (the
/// simulator's names, in the trajectory table's order), then `stop` (1 when the agent declared
/// the goal reached).
pub const ACTION_NAMES: [&str; 9] = {
    let n = Actions::NAMES;
    [n[0], n[1], n[2], n[3], n[4], n[5], n[6], n[7], "stop"]
};

/// A camera of the run, as its observation column describes it.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// The sensor's name (its column in `observations.parquet`).
    pub name: String,
    /// What it records.
    pub modality: Modality,
    /// How the run stored it, and the pixels' dtype and shape.
    pub format: CellFormat,
}

impl Camera {
    /// Whether the camera becomes a LeRobot `image` feature (8-bit colour or grey); other
    /// cameras become lossless arrays.
    pub fn is_image(&self) -> bool {
        matches!(self.modality, Modality::Color | Modality::Gray)
            && self.format.dtype == PixelType::U8
            && matches!(self.format.channels, 1 | 3)
    }

    /// Whether the camera can become a LeRobot `video` feature (`--video`): 8-bit colour
    /// with even sides H.264 takes ([`super::video::video_shape_ok`]).
    pub fn is_video(&self) -> bool {
        self.modality == Modality::Color
            && self.format.dtype == PixelType::U8
            && self.format.channels == 3
            && super::video::video_shape_ok(self.format.width, self.format.height)
    }

    /// The file each frame is stored as, or `None` for a channel-first array.
    pub fn image_file(&self) -> Option<ImageFile> {
        ImageFile::of(self.format.dtype, self.format.channels, self.is_image())
    }
}

/// A scalar feature's value type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scalar {
    /// `float32`.
    F32,
    /// `bool`.
    Bool,
    /// `int64`.
    I64,
}

/// A fixed-length float32 vector of each frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VectorValue {
    /// `observation.state`: the pose before the action.
    State,
    /// `action`: the strengths and stop.
    Action,
    /// `observation.goal`: distance to the goal and unit direction in the agent frame.
    Goal,
    /// `observation.goal_room`: the room goal's class, one-hot.
    GoalRoom,
    /// `observation.at_goal`: 1 when the success test holds.
    AtGoal,
    /// `observation.contact`: the contact bits (this many sensors).
    Contact(usize),
    /// `observation.collision`: 1 when the step into this frame collided.
    Collision,
    /// `observation.previous_action`: the previous frame's `action` (zeros at the start).
    PreviousAction,
    /// `observation.steps_left`: steps before the step limit.
    StepsLeft,
}

impl VectorValue {
    /// The feature key.
    pub fn key(self) -> &'static str {
        match self {
            VectorValue::State => "observation.state",
            VectorValue::Action => "action",
            VectorValue::Goal => "observation.goal",
            VectorValue::GoalRoom => "observation.goal_room",
            VectorValue::AtGoal => "observation.at_goal",
            VectorValue::Contact(_) => "observation.contact",
            VectorValue::Collision => "observation.collision",
            VectorValue::PreviousAction => "observation.previous_action",
            VectorValue::StepsLeft => "observation.steps_left",
        }
    }

    /// Names of the elements.
    pub fn names(self) -> Vec<String> {
        let owned = |n: &[&str]| n.iter().map(|s| s.to_string()).collect();
        match self {
            VectorValue::State => owned(&STATE_NAMES),
            VectorValue::Action | VectorValue::PreviousAction => owned(&ACTION_NAMES),
            VectorValue::Goal => owned(&GOAL_NAMES),
            VectorValue::GoalRoom => RoomClass::ALL
                .iter()
                .map(|c| c.name().to_string())
                .collect(),
            VectorValue::AtGoal => owned(&["at_goal"]),
            VectorValue::Contact(n) => contact_names(n),
            VectorValue::Collision => owned(&["collision"]),
            VectorValue::StepsLeft => owned(&["steps_left"]),
        }
    }

    /// Number of elements.
    pub fn len(self) -> usize {
        match self {
            VectorValue::State => STATE_NAMES.len(),
            VectorValue::Action | VectorValue::PreviousAction => ACTION_NAMES.len(),
            VectorValue::Goal => GOAL_NAMES.len(),
            VectorValue::GoalRoom => RoomClass::ALL.len(),
            VectorValue::Contact(n) => n,
            VectorValue::AtGoal | VectorValue::Collision | VectorValue::StepsLeft => 1,
        }
    }

    /// Never: every vector has elements (a run without contact sensors has no contact
    /// feature).
    pub fn is_empty(self) -> bool {
        self.len() == 0
    }

    /// What the feature means, its frame and unit (`info.json`'s `info.minos.meaning`).
    pub fn meaning(self) -> &'static str {
        match self {
            VectorValue::State => "world pose before the action: x, y, z (m), yaw, tilt (rad)",
            VectorValue::Action => "the eight action strengths, then 1 for stop",
            VectorValue::Goal => {
                "straight-line distance to the goal (m), then the unit direction to it in the \
                 agent frame [right, forward]; object and room goals: to the target the \
                 shortest path ends at; zeros without a goal"
            }
            VectorValue::GoalRoom => {
                "the room goal's MINOS room class, one-hot (zeros for other tasks)"
            }
            VectorValue::AtGoal => "1 when the episode's success test holds at this frame",
            VectorValue::Contact(_) => {
                "1 per contact sensor touching something (sensor k looks k × 360°/n \
                 counter-clockwise from forward)"
            }
            VectorValue::Collision => "1 when the step that led to this frame collided",
            VectorValue::PreviousAction => {
                "the previous frame's action vector (zeros at an episode's first frame)"
            }
            VectorValue::StepsLeft => "steps left before the episode's step limit",
        }
    }
}

/// A single value of each frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameValue {
    /// `next.reward`.
    Reward,
    /// `next.done`.
    Done,
    /// `next.success`.
    Success,
    /// `timestamp`: frame / fps.
    Timestamp,
    /// `frame_index`: frame in its episode.
    FrameIndex,
    /// `episode_index`.
    EpisodeIndex,
    /// `index`: frame in the dataset.
    Index,
    /// `task_index`.
    TaskIndex,
}

impl FrameValue {
    /// Every frame value, in column order.
    pub const ALL: [FrameValue; 8] = [
        FrameValue::Reward,
        FrameValue::Done,
        FrameValue::Success,
        FrameValue::Timestamp,
        FrameValue::FrameIndex,
        FrameValue::EpisodeIndex,
        FrameValue::Index,
        FrameValue::TaskIndex,
    ];

    /// The feature key.
    pub fn key(self) -> &'static str {
        match self {
            FrameValue::Reward => "next.reward",
            FrameValue::Done => "next.done",
            FrameValue::Success => "next.success",
            FrameValue::Timestamp => "timestamp",
            FrameValue::FrameIndex => "frame_index",
            FrameValue::EpisodeIndex => "episode_index",
            FrameValue::Index => "index",
            FrameValue::TaskIndex => "task_index",
        }
    }

    /// Its value type.
    pub fn scalar(self) -> Scalar {
        match self {
            FrameValue::Reward | FrameValue::Timestamp => Scalar::F32,
            FrameValue::Done | FrameValue::Success => Scalar::Bool,
            _ => Scalar::I64,
        }
    }
}

/// What a feature holds.
#[derive(Debug, Clone, PartialEq)]
pub enum FeatureKind {
    /// A fixed-length float32 vector with named elements.
    Vector(VectorValue),
    /// One value per frame.
    Frame(FrameValue),
    /// The colour or grey camera `cameras[i]` (`observation.images.<name>`), as 8-bit
    /// image files.
    Image(usize),
    /// The colour camera `cameras[camera]` (`observation.images.<name>`) as a video of
    /// `fps` frames a second ([`super::video`]); not a column of the data files.
    Video {
        /// Its index in the cameras.
        camera: usize,
        /// Frames per second.
        fps: u32,
        /// How it is encoded.
        settings: VideoSettings,
    },
    /// Any other camera `cameras[i]` (`observation.<name>`): as image files that keep its
    /// values where it has [`Camera::image_file`], else as a [c, h, w] array of its dtype.
    Array(usize),
    /// `observation.goal_object`: the object goal's category as an index into this
    /// vocabulary (the dataset's goal categories, sorted), −1 for other tasks.
    GoalObject(Vec<String>),
}

/// One column of the data files.
#[derive(Debug, Clone, PartialEq)]
pub struct Feature {
    /// Its key (column name).
    pub key: String,
    /// What it holds.
    pub kind: FeatureKind,
}

/// Errors in the features (a sensor whose name makes a bad key).
#[derive(Debug, thiserror::Error)]
#[error("sensor `{sensor}`: {message}")]
pub struct FeatureError {
    /// The sensor.
    pub sensor: String,
    /// What is wrong.
    pub message: String,
}

/// What the run's trajectory rows say beyond the cameras that shapes the features.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunShape {
    /// Contact sensors per frame (0: no contact feature).
    pub contacts: usize,
    /// The object goals' categories, sorted and distinct (the `observation.goal_object`
    /// vocabulary).
    pub goal_objects: Vec<String>,
}

/// The dataset's features, in column order, for the run's cameras and shape; with `video`,
/// colour cameras H.264 takes become video features of `fps` frames per second, encoded so.
pub fn features(
    cameras: &[Camera],
    shape: &RunShape,
    fps: u32,
    video: Option<VideoSettings>,
) -> Result<Vec<Feature>, FeatureError> {
    let mut out: Vec<Feature> = [VectorValue::State, VectorValue::Action]
        .into_iter()
        .map(|v| Feature {
            key: v.key().into(),
            kind: FeatureKind::Vector(v),
        })
        .collect();
    for (i, c) in cameras.iter().enumerate() {
        let bad = |message: &str| FeatureError {
            sensor: c.name.clone(),
            message: message.into(),
        };
        if c.name.is_empty() || c.name.contains('/') {
            return Err(bad("LeRobot feature names cannot be empty or contain `/`"));
        }
        if let Some(settings) = video.filter(|_| c.is_video()) {
            out.push(Feature {
                key: format!("observation.images.{}", c.name),
                kind: FeatureKind::Video {
                    camera: i,
                    fps,
                    settings,
                },
            });
        } else if c.is_image() {
            out.push(Feature {
                key: format!("observation.images.{}", c.name),
                kind: FeatureKind::Image(i),
            });
        } else {
            if c.name.contains("image") || c.name == "state" || c.name == "environment_state" {
                return Err(bad(
                    "an array sensor's key `observation.<name>` must not contain `image` \
                     (LeRobot reads such keys as 3-channel images) nor be `state` or \
                     `environment_state`; rename the sensor",
                ));
            }
            out.push(Feature {
                key: format!("observation.{}", c.name),
                kind: FeatureKind::Array(i),
            });
        }
    }
    let mut vectors = vec![
        VectorValue::Goal,
        VectorValue::GoalRoom,
        VectorValue::AtGoal,
    ];
    if shape.contacts > 0 {
        vectors.push(VectorValue::Contact(shape.contacts));
    }
    vectors.extend([
        VectorValue::Collision,
        VectorValue::PreviousAction,
        VectorValue::StepsLeft,
    ]);
    out.extend(vectors.into_iter().map(|v| Feature {
        key: v.key().into(),
        kind: FeatureKind::Vector(v),
    }));
    out.push(Feature {
        key: GOAL_OBJECT_KEY.into(),
        kind: FeatureKind::GoalObject(shape.goal_objects.clone()),
    });
    out.extend(FrameValue::ALL.into_iter().map(|v| Feature {
        key: v.key().into(),
        kind: FeatureKind::Frame(v),
    }));
    Ok(out)
}

/// The key of the object goal's category index.
pub const GOAL_OBJECT_KEY: &str = "observation.goal_object";

fn scalar_name(s: Scalar) -> &'static str {
    match s {
        Scalar::F32 => "float32",
        Scalar::Bool => "bool",
        Scalar::I64 => "int64",
    }
}

fn arrow_pixel(t: PixelType) -> DataType {
    match t {
        PixelType::U8 => DataType::UInt8,
        PixelType::U16 => DataType::UInt16,
        PixelType::U32 => DataType::UInt32,
        PixelType::F32 => DataType::Float32,
    }
}

/// `List<item>` with nullable items, as Hugging Face writes nested lists.
fn list_of(t: DataType) -> DataType {
    DataType::List(Arc::new(Field::new("item", t, true)))
}

impl Feature {
    /// The entry in `meta/info.json`'s `features`.
    pub fn info(&self, cameras: &[Camera]) -> Value {
        match &self.kind {
            FeatureKind::Vector(v) => match v {
                VectorValue::State | VectorValue::Action => {
                    json!({"dtype": "float32", "shape": [v.len()], "names": v.names()})
                }
                _ => json!({
                    "dtype": "float32",
                    "shape": [v.len()],
                    "names": v.names(),
                    "info": {"minos.meaning": v.meaning()},
                }),
            },
            FeatureKind::GoalObject(vocabulary) => json!({
                "dtype": "int64",
                "shape": [1],
                "names": null,
                "info": {
                    "minos.meaning": "the object goal's category: an index into \
                                      minos.vocabulary, -1 for other tasks",
                    "minos.vocabulary": vocabulary,
                },
            }),
            FeatureKind::Frame(v) => {
                json!({"dtype": scalar_name(v.scalar()), "shape": [1], "names": null})
            }
            FeatureKind::Video {
                camera,
                fps,
                settings,
            } => {
                let c = &cameras[*camera];
                let f = &c.format;
                json!({
                    "dtype": "video",
                    "shape": [f.height, f.width, 3],
                    "names": ["height", "width", "channels"],
                    "info": {
                        "video.height": f.height,
                        "video.width": f.width,
                        "video.codec": super::video::CODEC,
                        "video.pix_fmt": super::video::PIX_FMT,
                        "video.is_depth_map": false,
                        "video.fps": fps,
                        "video.channels": 3,
                        "has_audio": false,
                        "minos.sensor": c.name,
                        "minos.modality": modality_name(c.modality),
                        "minos.sensor_dtype": f.dtype.name(),
                        "minos.storage": settings.storage(),
                        "minos.video_qp": settings.qp,
                        "minos.tensor": format!("float32 [3, {}, {}] in [0, 1]", f.height, f.width),
                    },
                })
            }
            FeatureKind::Image(i) | FeatureKind::Array(i) => {
                let c = &cameras[*i];
                let f = &c.format;
                let mut info = json!({
                    "minos.sensor": c.name,
                    "minos.modality": modality_name(c.modality),
                    "minos.sensor_dtype": f.dtype.name(),
                });
                if c.modality == Modality::Depth && f.dtype == PixelType::F32 {
                    info["minos.unit"] = json!("m (0 = no return)");
                }
                match c.image_file() {
                    Some(file) => {
                        info["minos.storage"] = json!(format!("{}, lossless", file.name()));
                        info["minos.tensor"] = json!(format!(
                            "{} [{}, {}, {}]{}",
                            file.tensor_dtype(),
                            f.channels,
                            f.height,
                            f.width,
                            if file.scaled() {
                                " in [0, 1]"
                            } else {
                                ", the sensor's values"
                            }
                        ));
                        json!({
                            "dtype": "image",
                            "shape": [f.height, f.width, f.channels],
                            "names": ["height", "width", "channels"],
                            "info": info,
                        })
                    }
                    None => {
                        info["minos.storage"] =
                            json!("array of the sensor's values, channel-first, lossless");
                        json!({
                            "dtype": f.dtype.name(),
                            "shape": [f.channels, f.height, f.width],
                            "names": ["channels", "height", "width"],
                            "info": info,
                        })
                    }
                }
            }
        }
    }

    /// The Hugging Face `datasets` feature (the `huggingface` schema metadata).
    pub fn hf(&self, cameras: &[Camera]) -> Value {
        match &self.kind {
            // LeRobot types a feature of shape [1] as a plain value.
            FeatureKind::Vector(v) if v.len() == 1 => json!({"dtype": "float32", "_type": "Value"}),
            FeatureKind::Vector(v) => json!({
                "feature": {"dtype": "float32", "_type": "Value"},
                "length": v.len(),
                "_type": "List",
            }),
            FeatureKind::GoalObject(_) => json!({"dtype": "int64", "_type": "Value"}),
            FeatureKind::Frame(v) => json!({"dtype": scalar_name(v.scalar()), "_type": "Value"}),
            // Not a column: LeRobot decodes it from the video files.
            FeatureKind::Video { .. } => Value::Null,
            FeatureKind::Image(i) | FeatureKind::Array(i) => {
                let c = &cameras[*i];
                let f = &c.format;
                match c.image_file() {
                    Some(_) => json!({"_type": "Image"}),
                    None => json!({
                        "shape": [f.channels, f.height, f.width],
                        "dtype": f.dtype.name(),
                        "_type": "Array3D",
                    }),
                }
            }
        }
    }

    /// The Arrow type of the column.
    pub fn arrow_type(&self, cameras: &[Camera]) -> DataType {
        match &self.kind {
            FeatureKind::Vector(v) if v.len() == 1 => DataType::Float32,
            FeatureKind::Vector(v) => DataType::FixedSizeList(
                Arc::new(Field::new("element", DataType::Float32, true)),
                v.len() as i32,
            ),
            FeatureKind::GoalObject(_) => DataType::Int64,
            FeatureKind::Frame(v) => match v.scalar() {
                Scalar::F32 => DataType::Float32,
                Scalar::Bool => DataType::Boolean,
                Scalar::I64 => DataType::Int64,
            },
            FeatureKind::Video { .. } => DataType::Null,
            FeatureKind::Image(i) | FeatureKind::Array(i) => match cameras[*i].image_file() {
                Some(_) => DataType::Struct(Fields::from(vec![
                    Field::new("bytes", DataType::Binary, true),
                    Field::new("path", DataType::Utf8, true),
                ])),
                None => list_of(list_of(list_of(arrow_pixel(cameras[*i].format.dtype)))),
            },
        }
    }

    /// Whether it is a column of the data files (video features are in `videos/`).
    pub fn in_data(&self) -> bool {
        !matches!(self.kind, FeatureKind::Video { .. })
    }

    /// How its statistics are nested: per channel as (c, 1, 1) for cameras, which
    /// broadcasts against their channel-first tensors.
    pub fn stat_layout(&self) -> StatLayout {
        match self.kind {
            FeatureKind::Image(_) | FeatureKind::Array(_) | FeatureKind::Video { .. } => {
                StatLayout::Image
            }
            _ => StatLayout::Flat,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::image_codec::CellEncoding;

    fn camera(name: &str, modality: Modality, dtype: PixelType, channels: u32) -> Camera {
        Camera {
            name: name.into(),
            modality,
            format: CellFormat {
                encoding: CellEncoding::RawLe,
                dtype,
                width: 84,
                height: 64,
                channels,
            },
        }
    }

    #[test]
    fn colour_is_a_picture_and_other_cameras_are_lossless_and_channel_first() {
        let cams = vec![
            camera("rgb", Modality::Color, PixelType::U8, 3),
            camera("depth", Modality::Depth, PixelType::F32, 1),
            camera("semantic", Modality::Semantic, PixelType::U16, 1),
            camera("rooms", Modality::RoomClass, PixelType::U8, 1),
            camera("normal", Modality::Normal, PixelType::F32, 3),
        ];
        let f = features(&cams, &RunShape::default(), 10, None).expect("valid");
        let keys: Vec<&str> = f.iter().map(|f| f.key.as_str()).collect();
        assert_eq!(
            &keys[..6],
            [
                "observation.state",
                "action",
                "observation.images.rgb",
                "observation.depth",
                "observation.semantic",
                "observation.rooms"
            ]
        );
        assert_eq!(f[2].info(&cams)["dtype"], "image");
        assert_eq!(f[2].info(&cams)["shape"], json!([64, 84, 3]));
        // One-channel depth and labels: lossless image files LeRobot returns as (1, h, w).
        for (k, storage, tensor) in [
            (
                3,
                "PFM (float32), lossless",
                "float32 [1, 64, 84], the sensor's values",
            ),
            (
                4,
                "PGM (P5, 16-bit), lossless",
                "int32 [1, 64, 84], the sensor's values",
            ),
            (
                5,
                "PGM (P5, 16-bit), lossless",
                "int32 [1, 64, 84], the sensor's values",
            ),
        ] {
            let info = f[k].info(&cams);
            assert_eq!(info["dtype"], "image", "{}", f[k].key);
            assert_eq!(info["shape"], json!([64, 84, 1]));
            assert_eq!(info["info"]["minos.storage"], storage);
            assert_eq!(info["info"]["minos.tensor"], tensor);
            assert_eq!(f[k].hf(&cams), json!({"_type": "Image"}));
            assert_eq!(f[k].stat_layout(), StatLayout::Image);
        }
        assert_eq!(f[3].info(&cams)["info"]["minos.sensor_dtype"], "float32");
        assert_eq!(f[4].info(&cams)["info"]["minos.sensor_dtype"], "uint16");
        assert_eq!(f[5].info(&cams)["info"]["minos.sensor_dtype"], "uint8");
        // Normals: no Pillow mode holds three float channels; a channel-first array.
        let n = &f[6];
        assert_eq!(n.key, "observation.normal");
        assert_eq!(n.info(&cams)["dtype"], "float32");
        assert_eq!(n.info(&cams)["shape"], json!([3, 64, 84]));
        assert_eq!(
            n.info(&cams)["names"],
            json!(["channels", "height", "width"])
        );
        assert_eq!(
            n.hf(&cams),
            json!({"shape": [3, 64, 84], "dtype": "float32", "_type": "Array3D"})
        );
        assert_eq!(n.stat_layout(), StatLayout::Image);
        assert_eq!(f[1].info(&cams)["shape"], json!([9]));
        for k in [
            "timestamp",
            "frame_index",
            "episode_index",
            "index",
            "task_index",
        ] {
            assert!(keys.contains(&k), "{k}");
        }
    }

    #[test]
    fn with_video_colour_becomes_a_video_feature_and_the_rest_stays() {
        let mut odd = camera("odd", Modality::Color, PixelType::U8, 3);
        odd.format.width = 85;
        let cams = vec![
            camera("rgb", Modality::Color, PixelType::U8, 3),
            camera("gray", Modality::Gray, PixelType::U8, 1),
            camera("depth", Modality::Depth, PixelType::F32, 1),
            odd,
        ];
        let settings = VideoSettings::with_qp(31).expect("a quantiser");
        let f = features(&cams, &RunShape::default(), 10, Some(settings)).expect("valid");
        assert_eq!(
            f[2].kind,
            FeatureKind::Video {
                camera: 0,
                fps: 10,
                settings
            }
        );
        assert!(!f[2].in_data());
        let info = f[2].info(&cams);
        assert_eq!(info["dtype"], "video");
        assert_eq!(info["shape"], json!([64, 84, 3]));
        assert_eq!(info["info"]["video.fps"], 10);
        assert_eq!(info["info"]["video.codec"], "h264");
        assert_eq!(info["info"]["minos.video_qp"], 31);
        assert!(info["info"]["minos.storage"]
            .as_str()
            .is_some_and(|s| s.contains("constant QP 31")));
        assert_eq!(f[2].stat_layout(), StatLayout::Image);
        // Grey, depth and an odd-width colour camera (no 4:2:0 video) stay image files.
        for k in [3, 4, 5] {
            assert_eq!(f[k].info(&cams)["dtype"], "image", "{}", f[k].key);
            assert!(f[k].in_data());
        }
        // Without video, colour is an image.
        let f = features(&cams, &RunShape::default(), 10, None).expect("valid");
        assert_eq!(f[2].kind, FeatureKind::Image(0));
    }

    #[test]
    fn each_camera_gets_the_file_that_keeps_its_values() {
        let file = |m, t, c| camera("x", m, t, c).image_file();
        assert_eq!(
            file(Modality::Color, PixelType::U8, 3),
            Some(ImageFile::Ppm)
        );
        assert_eq!(
            file(Modality::Gray, PixelType::U8, 1),
            Some(ImageFile::Pgm8)
        );
        // An 8-bit depth or class image is ids, not grey: 16-bit so Pillow reads integers.
        assert_eq!(
            file(Modality::Depth, PixelType::U8, 1),
            Some(ImageFile::Pgm16)
        );
        assert_eq!(
            file(Modality::RoomClass, PixelType::U8, 1),
            Some(ImageFile::Pgm16)
        );
        assert_eq!(
            file(Modality::Depth, PixelType::U16, 1),
            Some(ImageFile::Pgm16)
        );
        assert_eq!(
            file(Modality::Instance, PixelType::U32, 1),
            Some(ImageFile::Tiff32)
        );
        assert_eq!(
            file(Modality::Depth, PixelType::F32, 1),
            Some(ImageFile::Pfm)
        );
        assert_eq!(file(Modality::Normal, PixelType::F32, 3), None);
        assert!(ImageFile::Ppm.scaled() && !ImageFile::Pfm.scaled());
        assert_eq!(ImageFile::Tiff32.tensor_dtype(), "int32");
    }

    #[test]
    fn sensor_names_that_make_bad_keys_are_refused() {
        for name in ["a/b", "", "state", "depth_image"] {
            let cams = vec![camera(name, Modality::Depth, PixelType::F32, 1)];
            let e = features(&cams, &RunShape::default(), 10, None)
                .expect_err(name)
                .to_string();
            assert!(e.contains(&format!("sensor `{name}`")), "{e}");
        }
        // An image sensor may be called anything LeRobot accepts.
        assert!(features(
            &[camera("image", Modality::Color, PixelType::U8, 3)],
            &RunShape::default(),
            10,
            None
        )
        .is_ok());
    }
}
