//! One episode's frames as a record batch of the data files, and the episode's statistics
//! for every feature.

use std::sync::Arc;

use arrow::array::{
    ArrayRef, BinaryBuilder, BooleanArray, FixedSizeListBuilder, Float32Array, Float32Builder,
    Int64Array, ListArray, PrimitiveArray, RecordBatch, StringArray, StructArray,
};
use arrow::buffer::{OffsetBuffer, ScalarBuffer};
use arrow::datatypes::{
    ArrowPrimitiveType, DataType, Field, Float32Type, Schema, SchemaRef, UInt16Type, UInt32Type,
    UInt8Type,
};
use serde_json::json;

use super::features::{Camera, Feature, FeatureKind, FrameValue, Scalar, VectorValue};
use super::image_file::{ImageFile, ImageFileError};
use super::source::StepRow;
use super::stats::FeatureStats;
use crate::io::image_codec::CellFormat;
use crate::render::Image;

/// The frames of one episode, ready to be laid out.
pub struct EpisodeFrames<'a> {
    /// Its trajectory rows, in step order.
    pub steps: &'a [StepRow],
    /// Each frame's images, in camera order.
    pub images: Vec<Vec<Image>>,
    /// Its index in the dataset.
    pub episode_index: i64,
    /// The dataset index of its first frame.
    pub first_index: i64,
    /// Its task's index.
    pub task_index: i64,
    /// Frames per second.
    pub fps: u32,
}

/// The data files' schema: one nullable column per feature but videos (as Hugging Face
/// writes them) and the `huggingface` metadata naming each column's `datasets` feature.
pub fn data_schema(features: &[Feature], cameras: &[Camera]) -> SchemaRef {
    let fields: Vec<Field> = features
        .iter()
        .filter(|f| f.in_data())
        .map(|f| Field::new(&f.key, f.arrow_type(cameras), true))
        .collect();
    let hf: serde_json::Map<String, serde_json::Value> = features
        .iter()
        .filter(|f| f.in_data())
        .map(|f| (f.key.clone(), f.hf(cameras)))
        .collect();
    let meta = json!({"info": {"features": hf}}).to_string();
    Arc::new(Schema::new(fields).with_metadata([("huggingface".to_string(), meta)].into()))
}

/// An episode's frames that could not be laid out as rows (the caller names the file and
/// episode).
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    /// Arrow could not build a column or the rows.
    #[error(transparent)]
    Arrow(#[from] arrow::error::ArrowError),
    /// A frame's image could not be encoded into its column.
    #[error("frame {frame}")]
    Image {
        /// The frame.
        frame: usize,
        /// Why.
        #[source]
        source: ImageFileError,
    },
    /// The frames do not fit the dataset's features: how.
    #[error("{0}")]
    Mismatch(String),
}

/// Builds the episode's batch (video features are not columns) and its statistics (one per
/// feature, in feature order; a video's from the camera's own frames).
pub fn episode_batch(
    features: &[Feature],
    cameras: &[Camera],
    schema: &SchemaRef,
    ep: &EpisodeFrames,
) -> Result<(RecordBatch, Vec<FeatureStats>), FrameError> {
    let n = ep.steps.len();
    let frames = n as u64;
    let mut columns: Vec<ArrayRef> = Vec::with_capacity(features.len());
    let mut stats = Vec::with_capacity(features.len());
    for f in features {
        let (column, s) = match &f.kind {
            FeatureKind::Vector(v) => {
                let rows: Vec<&[f32]> = ep
                    .steps
                    .iter()
                    .map(|s| match v {
                        VectorValue::State => &s.state[..],
                        VectorValue::Action => &s.action[..],
                        VectorValue::Goal => &s.goal[..],
                        VectorValue::GoalRoom => &s.goal_room[..],
                        VectorValue::AtGoal => &s.at_goal[..],
                        VectorValue::Contact(_) => &s.contact[..],
                        VectorValue::Collision => &s.collision[..],
                        VectorValue::PreviousAction => &s.previous_action[..],
                        VectorValue::StepsLeft => &s.steps_left[..],
                    })
                    .collect();
                if let Some(r) = rows.iter().find(|r| r.len() != v.len()) {
                    return Err(FrameError::Mismatch(format!(
                        "{}: a frame has {} values, the dataset {}",
                        v.key(),
                        r.len(),
                        v.len()
                    )));
                }
                vector_column(&rows, v.len(), frames)
            }
            FeatureKind::GoalObject(vocabulary) => goal_object_column(vocabulary, ep, frames)?,
            FeatureKind::Frame(v) => frame_column(*v, ep, frames),
            FeatureKind::Video { camera, .. } => {
                stats.push(picture_stats(*camera, 3, ep, frames));
                continue;
            }
            FeatureKind::Image(c) | FeatureKind::Array(c) => match cameras[*c].image_file() {
                Some(file) => image_column(*c, file, &cameras[*c].format, ep, frames)?,
                None => array_column(*c, &cameras[*c].format, ep, frames)?,
            },
        };
        columns.push(column);
        stats.push(s);
    }
    let batch = RecordBatch::try_new(schema.clone(), columns)?;
    Ok((batch, stats))
}

/// A vector feature's column: fixed-size lists, or plain values for a single element (as
/// LeRobot types features of shape \[1\]); statistics per element.
fn vector_column(rows: &[&[f32]], len: usize, frames: u64) -> (ArrayRef, FeatureStats) {
    if len == 1 {
        let values: Vec<f32> = rows.iter().map(|r| r[0]).collect();
        let mut channels = [values.iter().map(|v| f64::from(*v)).collect::<Vec<f64>>()];
        return (
            Arc::new(Float32Array::from(values)),
            FeatureStats::of_channels(&mut channels, frames),
        );
    }
    let field = Arc::new(Field::new("element", DataType::Float32, true));
    let mut b =
        FixedSizeListBuilder::new(Float32Builder::new(), len as i32).with_field(field.clone());
    let mut channels = vec![Vec::with_capacity(rows.len()); len];
    for r in rows {
        b.values().append_slice(r);
        b.append(true);
        for (k, v) in r.iter().enumerate() {
            channels[k].push(f64::from(*v));
        }
    }
    (
        Arc::new(b.finish()),
        FeatureStats::of_channels(&mut channels, frames),
    )
}

fn frame_column(value: FrameValue, ep: &EpisodeFrames, frames: u64) -> (ArrayRef, FeatureStats) {
    let n = ep.steps.len();
    let flag = |b: bool| f64::from(u8::from(b));
    let values: Vec<f64> = match value {
        FrameValue::Reward => ep.steps.iter().map(|s| f64::from(s.reward)).collect(),
        FrameValue::Done => ep.steps.iter().map(|s| flag(s.done)).collect(),
        FrameValue::Success => ep.steps.iter().map(|s| flag(s.success)).collect(),
        FrameValue::Timestamp => (0..n)
            .map(|i| f64::from(i as f32 / ep.fps as f32))
            .collect(),
        FrameValue::FrameIndex => (0..n).map(|i| i as f64).collect(),
        FrameValue::EpisodeIndex => vec![ep.episode_index as f64; n],
        FrameValue::Index => (0..n).map(|i| (ep.first_index + i as i64) as f64).collect(),
        FrameValue::TaskIndex => vec![ep.task_index as f64; n],
    };
    let column: ArrayRef = match value.scalar() {
        Scalar::F32 => Arc::new(values.iter().map(|v| *v as f32).collect::<Float32Array>()),
        Scalar::Bool => Arc::new(
            values
                .iter()
                .map(|v| Some(*v != 0.0))
                .collect::<BooleanArray>(),
        ),
        Scalar::I64 => Arc::new(values.iter().map(|v| *v as i64).collect::<Int64Array>()),
    };
    let mut channels = [values];
    (column, FeatureStats::of_channels(&mut channels, frames))
}

/// The object goal's category of each frame as its index in `vocabulary` (−1 for none).
fn goal_object_column(
    vocabulary: &[String],
    ep: &EpisodeFrames,
    frames: u64,
) -> Result<(ArrayRef, FeatureStats), FrameError> {
    let values: Vec<i64> = ep
        .steps
        .iter()
        .map(|s| match &s.goal_object {
            None => Ok(-1),
            Some(name) => vocabulary
                .binary_search(name)
                .map(|k| k as i64)
                .map_err(|_| {
                    FrameError::Mismatch(format!("goal_object `{name}` is not in the vocabulary"))
                }),
        })
        .collect::<Result<_, _>>()?;
    let mut channels = [values.iter().map(|v| *v as f64).collect::<Vec<f64>>()];
    Ok((
        Arc::new(Int64Array::from(values)),
        FeatureStats::of_channels(&mut channels, frames),
    ))
}

/// Image files in Hugging Face's image struct (`bytes`, `path` = null). Statistics of
/// 8-bit pictures per RGB channel over every pixel in [0, 1], grey counted as three equal
/// channels (LeRobot checks `observation.images.*` statistics for three channels); of other
/// cameras per channel in the sensor's own values, as LeRobot returns them.
fn image_column(
    camera: usize,
    file: ImageFile,
    format: &CellFormat,
    ep: &EpisodeFrames,
    frames: u64,
) -> Result<(ArrayRef, FeatureStats), FrameError> {
    let mut bytes = BinaryBuilder::new();
    let c = format.channels as usize;
    let mut hist = vec![[0u64; 256]; c];
    let mut channels: Vec<Vec<f64>> = vec![Vec::new(); if file.scaled() { 0 } else { c }];
    let mut buf = Vec::new();
    for (i, frame) in ep.images.iter().enumerate() {
        let img = &frame[camera];
        file.encode(img, format.width, format.height, &mut buf)
            .map_err(|source| FrameError::Image { frame: i, source })?;
        bytes.append_value(&buf);
        if file.scaled() {
            if let Image::U8 { data, .. } = img {
                for px in data.chunks_exact(c) {
                    for (k, v) in px.iter().enumerate() {
                        hist[k][*v as usize] += 1;
                    }
                }
            }
        } else {
            collect_channels(img, &mut channels);
        }
    }
    let stats = if file.scaled() {
        if hist.len() == 1 {
            hist = vec![hist[0]; 3];
        }
        FeatureStats::of_histograms(&hist, frames)
    } else {
        FeatureStats::of_channels(&mut channels, frames)
    };
    let n = ep.images.len();
    let column = StructArray::new(
        vec![
            Field::new("bytes", DataType::Binary, true),
            Field::new("path", DataType::Utf8, true),
        ]
        .into(),
        vec![
            Arc::new(bytes.finish()) as ArrayRef,
            Arc::new(StringArray::new_null(n)),
        ],
        None,
    );
    Ok((Arc::new(column), stats))
}

/// Statistics of an 8-bit camera's frames per channel in [0, 1] (as [`image_column`]).
fn picture_stats(camera: usize, c: usize, ep: &EpisodeFrames, frames: u64) -> FeatureStats {
    let mut hist = vec![[0u64; 256]; c];
    for frame in &ep.images {
        if let Image::U8 { data, .. } = &frame[camera] {
            for px in data.chunks_exact(c) {
                for (k, v) in px.iter().enumerate() {
                    hist[k][*v as usize] += 1;
                }
            }
        }
    }
    FeatureStats::of_histograms(&hist, frames)
}

/// Appends every value of `img` to its channel's list (channels interleaved).
fn collect_channels(img: &Image, channels: &mut [Vec<f64>]) {
    let c = channels.len().max(1);
    let mut push = |k: usize, v: f64| {
        if let Some(ch) = channels.get_mut(k % c) {
            ch.push(v);
        }
    };
    match img {
        Image::U8 { data, .. } => data
            .iter()
            .enumerate()
            .for_each(|(k, v)| push(k, f64::from(*v))),
        Image::U16(d) => d
            .iter()
            .enumerate()
            .for_each(|(k, v)| push(k, f64::from(*v))),
        Image::U32(d) => d
            .iter()
            .enumerate()
            .for_each(|(k, v)| push(k, f64::from(*v))),
        Image::F32 { data, .. } => data
            .iter()
            .enumerate()
            .for_each(|(k, v)| push(k, f64::from(*v))),
    }
}

/// Frames as channel-first `[c][h][w]` nested lists of the sensor's own values (for cameras
/// no [`ImageFile`] holds); statistics per channel.
fn array_column(
    camera: usize,
    format: &CellFormat,
    ep: &EpisodeFrames,
    frames: u64,
) -> Result<(ArrayRef, FeatureStats), FrameError> {
    let c = format.channels as usize;
    let mut channels = vec![Vec::new(); c];
    let values: ArrayRef = match ep.images.first().map(|f| &f[camera]) {
        Some(Image::U8 { .. }) | None => {
            flat::<UInt8Type>(ep, camera, &mut channels, |img| match img {
                Image::U8 { data, .. } => Some(data.clone()),
                _ => None,
            })?
        }
        Some(Image::U16(_)) => flat::<UInt16Type>(ep, camera, &mut channels, |img| match img {
            Image::U16(d) => Some(d.clone()),
            _ => None,
        })?,
        Some(Image::U32(_)) => flat::<UInt32Type>(ep, camera, &mut channels, |img| match img {
            Image::U32(d) => Some(d.clone()),
            _ => None,
        })?,
        Some(Image::F32 { .. }) => {
            flat::<Float32Type>(ep, camera, &mut channels, |img| match img {
                Image::F32 { data, .. } => Some(data.clone()),
                _ => None,
            })?
        }
    };
    let (h, w) = (format.height as usize, format.width as usize);
    let n = ep.images.len();
    if values.len() != n * h * w * c {
        return Err(FrameError::Mismatch(format!(
            "{} values for {n} frames of {h}×{w}×{c}",
            values.len()
        )));
    }
    let item = |t: DataType| Arc::new(Field::new("item", t, true));
    let nest = |values: ArrayRef, size: usize, count: usize| -> Result<ArrayRef, FrameError> {
        let offsets = OffsetBuffer::new(ScalarBuffer::from(
            (0..=count).map(|i| (i * size) as i32).collect::<Vec<i32>>(),
        ));
        let list = ListArray::try_new(item(values.data_type().clone()), offsets, values, None)?;
        Ok(Arc::new(list))
    };
    let rows = nest(values, w, n * c * h)?;
    let planes = nest(rows, h, n * c)?;
    let column = nest(planes, c, n)?;
    Ok((column, FeatureStats::of_channels(&mut channels, frames)))
}

/// Concatenates one camera's frames into a flat array, each frame channel-first (its
/// interleaved pixels transposed to `[c][h][w]`), collecting every channel's values.
fn flat<T>(
    ep: &EpisodeFrames,
    camera: usize,
    channels: &mut [Vec<f64>],
    pixels: impl Fn(&Image) -> Option<Vec<T::Native>>,
) -> Result<ArrayRef, FrameError>
where
    T: ArrowPrimitiveType,
    T::Native: Into<f64> + Copy,
{
    let c = channels.len();
    let mut all: Vec<T::Native> = Vec::new();
    for (i, frame) in ep.images.iter().enumerate() {
        let data = pixels(&frame[camera])
            .ok_or_else(|| FrameError::Mismatch(format!("frame {i}: image type changed")))?;
        for (k, v) in data.iter().enumerate() {
            channels[k % c].push((*v).into());
        }
        for ch in 0..c {
            all.extend(data.iter().skip(ch).step_by(c.max(1)).copied());
        }
    }
    Ok(Arc::new(PrimitiveArray::<T>::from_iter_values(all)))
}
