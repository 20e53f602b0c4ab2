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

/// The dtype of a sensor's pixels, named as NumPy names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PixelType {
    /// `uint8`.
    U8,
    /// `uint16`.
    U16,
    /// `uint32`.
    U32,
    /// `float32`.
    F32,
}

impl crate::vocab::Vocabulary for PixelType {
    const WHAT: &'static str = "pixel type";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: PixelType::U8,
            name: "uint8",
            aliases: &[],
            help: "8-bit unsigned (colour, grey, quantised depth, room class)",
        },
        crate::vocab::Term {
            value: PixelType::U16,
            name: "uint16",
            aliases: &[],
            help: "16-bit unsigned (semantic classes, quantised depth)",
        },
        crate::vocab::Term {
            value: PixelType::U32,
            name: "uint32",
            aliases: &[],
            help: "32-bit unsigned (instance and room ids)",
        },
        crate::vocab::Term {
            value: PixelType::F32,
            name: "float32",
            aliases: &[],
            help: "32-bit float (depth in metres, normals)",
        },
    ];
}

crate::vocab::name_traits!(PixelType);

impl PixelType {
    /// The NumPy dtype name.
    pub fn name(self) -> &'static str {
        crate::vocab::Vocabulary::term_name(self)
    }
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
    /// `(dtype, channels)`.
    pub fn dtype(&self) -> (PixelType, u32) {
        match self {
            Image::U8 { channels, .. } => (PixelType::U8, *channels),
            Image::U16(_) => (PixelType::U16, 1),
            Image::U32(_) => (PixelType::U32, 1),
            Image::F32 { channels, .. } => (PixelType::F32, *channels),
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
