//! The images sensors produce: what a camera records ([`Modality`]) and the pixels
//! ([`Image`]), typed by their NumPy dtype.

use serde::{Deserialize, Serialize};

/// What a camera sensor records.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Modality {
    /// RGB, 3 × u8 per pixel.
    Color,
    /// Grey, 1 × u8 per pixel.
    Gray,
    /// Depth along the viewing axis (float metres or quantised, as the sensor says).
    Depth,
    /// World-space unit normals, 3 × f32 per pixel.
    Normal,
    /// Semantic class per pixel (u16) in the sensor's taxonomy.
    Semantic,
    /// Object instance per pixel (u32, object index + 1, 0 = none).
    Instance,
    /// Room per pixel (u32, room index + 1, 0 = none).
    Room,
    /// MINOS room class per pixel (u8).
    RoomClass,
}

/// A sensor image.
#[derive(Debug, Clone, PartialEq)]
pub enum Image {
    /// Interleaved u8 channels (colour: 3, grey/depth-u8/room class: 1).
    U8 {
        /// Channels per pixel.
        channels: u32,
        /// Pixels.
        data: Vec<u8>,
    },
    /// u16 per pixel (depth-u16, semantic).
    U16(Vec<u16>),
    /// u32 per pixel (instance, room).
    U32(Vec<u32>),
    /// Interleaved f32 channels (depth: 1, normals: 3).
    F32 {
        /// Channels per pixel.
        channels: u32,
        /// Pixels.
        data: Vec<f32>,
    },
}

impl Image {
    /// `(dtype, channels)` as a NumPy dtype name.
    pub fn dtype(&self) -> (&'static str, u32) {
        match self {
            Image::U8 { channels, .. } => ("uint8", *channels),
            Image::U16(_) => ("uint16", 1),
            Image::U32(_) => ("uint32", 1),
            Image::F32 { channels, .. } => ("float32", *channels),
        }
    }

    /// Raw little-endian bytes.
    pub fn to_le_bytes(&self) -> Vec<u8> {
        match self {
            Image::U8 { data, .. } => data.clone(),
            Image::U16(d) => d.iter().flat_map(|v| v.to_le_bytes()).collect(),
            Image::U32(d) => d.iter().flat_map(|v| v.to_le_bytes()).collect(),
            Image::F32 { data, .. } => data.iter().flat_map(|v| v.to_le_bytes()).collect(),
        }
    }
}
