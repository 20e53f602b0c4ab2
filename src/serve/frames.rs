//! What the page draws, as bytes: each camera image turned into RGB pixels (colour as is,
//! depth grey — near is bright —, labels in their fixed colours), the top-down map of the
//! navigation grid as a PNG, and the binary WebSocket messages that carry them.

use image::ImageEncoder as _;

use crate::navmesh::preview::render_level;
use crate::navmesh::NavGrid;
use crate::render::visualize::label_color;
use crate::render::{Image, Modality};

/// First byte of a binary message: a camera image as RGB pixels.
pub const KIND_CAMERA: u8 = 1;
/// First byte of a binary message: the map of the current level as a PNG.
pub const KIND_MAP: u8 = 2;
/// Bytes before the payload of a binary message: kind, camera index, width and height (u16
/// little-endian), two zero bytes.
pub const HEADER: usize = 8;

/// Depth shown as black from this far on (m).
const DEPTH_SHOWN: f32 = 10.0;

/// A binary message: the header then `payload`.
pub fn message(kind: u8, index: u8, width: u32, height: u32, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER + payload.len());
    out.extend_from_slice(&[kind, index]);
    out.extend_from_slice(&(width.min(u32::from(u16::MAX)) as u16).to_le_bytes());
    out.extend_from_slice(&(height.min(u32::from(u16::MAX)) as u16).to_le_bytes());
    out.extend_from_slice(&[0, 0]);
    out.extend_from_slice(payload);
    out
}

/// `image` of a camera with `modality` as RGB bytes (`depth_range` maps quantised depth
/// back to metres); `None` for an image whose type does not match its modality.
pub fn display_rgb(modality: Modality, image: &Image, depth_range: [f32; 2]) -> Option<Vec<u8>> {
    let grey = |v: u8| [v, v, v];
    let depth = |m: f32| {
        if m > 0.0 && m.is_finite() {
            (255.0 * (1.0 - (m / DEPTH_SHOWN).min(1.0))) as u8
        } else {
            0
        }
    };
    let [lo, hi] = depth_range;
    Some(match (modality, image) {
        (Modality::Color, Image::U8 { channels: 3, data }) => data.clone(),
        (Modality::Depth, Image::F32 { channels: 1, data }) => {
            data.iter().flat_map(|&m| grey(depth(m))).collect()
        }
        (Modality::Depth, Image::U16(data)) => data
            .iter()
            .flat_map(|&v| grey(depth(quantised(f32::from(v), 65535.0, lo, hi))))
            .collect(),
        (Modality::Depth, Image::U8 { channels: 1, data }) => data
            .iter()
            .flat_map(|&v| grey(depth(quantised(f32::from(v), 255.0, lo, hi))))
            .collect(),
        (Modality::Gray, Image::U8 { channels: 1, data }) => {
            data.iter().flat_map(|&v| grey(v)).collect()
        }
        (Modality::Semantic, Image::U16(data)) => data
            .iter()
            .flat_map(|&v| label_color(u32::from(v)))
            .collect(),
        (Modality::Instance | Modality::Room, Image::U32(data)) => {
            data.iter().flat_map(|&v| label_color(v)).collect()
        }
        (Modality::RoomClass, Image::U8 { channels: 1, data }) => data
            .iter()
            .flat_map(|&v| label_color(u32::from(v)))
            .collect(),
        (Modality::Normal, Image::F32 { channels: 3, data }) => data
            .iter()
            .map(|&n| ((n.clamp(-1.0, 1.0) + 1.0) * 127.5) as u8)
            .collect(),
        _ => return None,
    })
}

/// Metres of a quantised depth value (0 = no return).
fn quantised(v: f32, max: f32, lo: f32, hi: f32) -> f32 {
    if v == 0.0 {
        0.0
    } else {
        lo + v / max * (hi - lo)
    }
}

/// The map of one level of a grid: PNG bytes and how world (x, z) maps to its pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct Map {
    /// The PNG.
    pub png: Vec<u8>,
    /// Its width and height (pixels).
    pub size: [u32; 2],
    /// The level drawn.
    pub level: u16,
    /// World x, z of the image's top-left corner.
    pub origin: [f32; 2],
    /// Pixels per metre.
    pub pixels_per_metre: f32,
}

/// Largest side of a map (pixels) unless one pixel per cell is more.
const MAP_SIDE: u32 = 512;

/// The map of `level` of `grid` (the navigation grid's preview: rooms coloured by class,
/// doors marked), scaled to about `MAP_SIDE` pixels.
pub fn map(grid: &NavGrid, level: u16) -> Result<Map, image::ImageError> {
    let scale = (MAP_SIDE / grid.nx.max(grid.nz).max(1)).max(1);
    let img = render_level(grid, level, scale);
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new_with_quality(
        &mut png,
        image::codecs::png::CompressionType::Fast,
        image::codecs::png::FilterType::Sub,
    )
    .write_image(
        img.as_raw(),
        img.width(),
        img.height(),
        image::ExtendedColorType::Rgb8,
    )?;
    Ok(Map {
        png,
        size: [img.width(), img.height()],
        level,
        origin: [grid.x0, grid.z0],
        pixels_per_metre: scale as f32 / grid.cell(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_is_bright_near_and_black_without_return() {
        let img = Image::F32 {
            channels: 1,
            data: vec![0.0, 1.0, 5.0, 20.0, f32::INFINITY],
        };
        let rgb = display_rgb(Modality::Depth, &img, [0.0, 10.0]).expect("depth");
        let grey: Vec<u8> = rgb.chunks(3).map(|p| p[0]).collect();
        // 255 × (1 − m / 10), by hand: 0 (no return), 229.5, 127.5, 0 (far), 0 (inf).
        assert_eq!(grey, vec![0, 229, 127, 0, 0]);
        // u16 depth over [0, 10] m: 65535 = 10 m, 6553.5 ≈ 1 m.
        let q = display_rgb(Modality::Depth, &Image::U16(vec![0, 6554]), [0.0, 10.0])
            .expect("u16 depth");
        assert_eq!(q.chunks(3).map(|p| p[0]).collect::<Vec<_>>(), vec![0, 229]);
    }

    #[test]
    fn labels_use_their_fixed_colours_and_mismatches_are_refused() {
        let rgb = display_rgb(Modality::Semantic, &Image::U16(vec![0, 7]), [0.0, 10.0])
            .expect("semantic");
        assert_eq!(&rgb[..3], &[0, 0, 0]);
        assert_eq!(&rgb[3..], &label_color(7));
        assert!(display_rgb(Modality::Color, &Image::U16(vec![1]), [0.0, 1.0]).is_none());
    }

    #[test]
    fn messages_carry_their_header() {
        let m = message(KIND_CAMERA, 2, 300, 2, &[9, 8]);
        assert_eq!(m, vec![1, 2, 44, 1, 2, 0, 0, 0, 9, 8]);
    }
}
