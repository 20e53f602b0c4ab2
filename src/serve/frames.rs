//! What the page draws, as bytes: each camera image turned into RGB pixels (colour as is,
//! depth grey — near is bright —, labels in their fixed colours) and compressed as the
//! server's [`FrameFormat`] says (JPEG by default; PNG or WebP when lossless frames are asked
//! for),
//! the top-down map of the navigation grid as a PNG, and the binary WebSocket messages that
//! carry them.

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
/// little-endian), the payload's format ([`FrameFormat::code`]; 0 for the map, a PNG), a
/// zero byte.
pub const HEADER: usize = 8;

/// How camera images travel to the page.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameFormat {
    /// JPEG at this quality (1–100): small, lossy (the default).
    Jpeg(u8),
    /// PNG (fast compression): lossless.
    Png,
    /// WebP, lossless: ≈ 2× smaller than PNG for ≈ 2× its time (for a page on a slow link).
    WebP,
    /// The RGB pixels as they are: lossless, no compression (for a client on this machine).
    Raw,
}

impl Default for FrameFormat {
    fn default() -> Self {
        FrameFormat::Jpeg(DEFAULT_JPEG_QUALITY)
    }
}

/// The lossless formats a server may send camera images in instead of JPEG, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LosslessFormat {
    /// [`FrameFormat::Png`].
    Png,
    /// [`FrameFormat::WebP`].
    WebP,
}

impl From<LosslessFormat> for FrameFormat {
    fn from(f: LosslessFormat) -> FrameFormat {
        match f {
            LosslessFormat::Png => FrameFormat::Png,
            LosslessFormat::WebP => FrameFormat::WebP,
        }
    }
}

impl crate::vocab::Vocabulary for LosslessFormat {
    const WHAT: &'static str = "lossless frame format";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: LosslessFormat::Png,
            name: "png",
            aliases: &[],
            help: "PNG: fast to write",
        },
        crate::vocab::Term {
            value: LosslessFormat::WebP,
            name: "webp",
            aliases: &[],
            help: "WebP (lossless): about half PNG's bytes",
        },
    ];
}

crate::vocab::name_traits!(LosslessFormat);

/// JPEG quality of [`FrameFormat::default`].
pub const DEFAULT_JPEG_QUALITY: u8 = 85;

impl FrameFormat {
    /// The format's byte in a message header: 0 raw RGB, 1 JPEG, 2 PNG, 3 WebP.
    pub fn code(self) -> u8 {
        match self {
            FrameFormat::Raw => 0,
            FrameFormat::Jpeg(_) => 1,
            FrameFormat::Png => 2,
            FrameFormat::WebP => 3,
        }
    }

    /// Its name, as the page's `/api/info` says it.
    pub fn name(self) -> &'static str {
        match self {
            FrameFormat::Raw => "raw",
            FrameFormat::Jpeg(_) => "jpeg",
            FrameFormat::Png => "png",
            FrameFormat::WebP => "webp",
        }
    }

    /// Whether the page sees exactly the pixels.
    pub fn lossless(self) -> bool {
        !matches!(self, FrameFormat::Jpeg(_))
    }

    /// The format a camera of `modality` is sent in: JPEG only for colour (and grey) images;
    /// depth, labels and normals — flat areas with hard edges, where JPEG smears and costs
    /// more (PNG of a 256² label image: ≈ 0.02–0.05 ms against 1.4–3 ms as JPEG) — go as PNG.
    pub fn for_modality(self, modality: Modality) -> FrameFormat {
        match (self, modality) {
            (FrameFormat::Jpeg(_), Modality::Color | Modality::Gray) => self,
            (FrameFormat::Jpeg(_), _) => FrameFormat::Png,
            _ => self,
        }
    }
}

/// The camera message of `rgb` (`width` × `height` RGB pixels) as camera `index`, its
/// pixels compressed as `format` says.
pub fn camera_message(
    format: FrameFormat,
    index: u8,
    width: u32,
    height: u32,
    rgb: &[u8],
) -> Result<Vec<u8>, image::ImageError> {
    let mut out = message(KIND_CAMERA, index, width, height, &[]);
    out[6] = format.code();
    match format {
        FrameFormat::Raw => out.extend_from_slice(rgb),
        FrameFormat::Jpeg(quality) => {
            out.reserve(rgb.len() / 8);
            jpeg(&mut out, rgb, width, height, quality)?;
        }
        FrameFormat::Png => {
            out.reserve(rgb.len() / 4);
            png_fast(&mut out, rgb, width, height)?;
        }
        FrameFormat::WebP => {
            out.reserve(rgb.len() / 4);
            image::codecs::webp::WebPEncoder::new_lossless(&mut out).write_image(
                rgb,
                width,
                height,
                image::ExtendedColorType::Rgb8,
            )?;
        }
    }
    Ok(out)
}

/// `rgb` as a JPEG of `quality` (4:2:0 chroma, as cameras and browsers use) appended to
/// `out`.
fn jpeg(
    out: &mut Vec<u8>,
    rgb: &[u8],
    width: u32,
    height: u32,
    quality: u8,
) -> Result<(), image::ImageError> {
    let too_big = || {
        image::ImageError::Limits(image::error::LimitError::from_kind(
            image::error::LimitErrorKind::DimensionError,
        ))
    };
    let w = u16::try_from(width).map_err(|_| too_big())?;
    let h = u16::try_from(height).map_err(|_| too_big())?;
    let mut encoder = jpeg_encoder::Encoder::new(out, quality.clamp(1, 100));
    encoder.set_sampling_factor(jpeg_encoder::SamplingFactor::R_4_2_0);
    encoder
        .encode(rgb, w, h, jpeg_encoder::ColorType::Rgb)
        .map_err(|e| {
            image::ImageError::Encoding(image::error::EncodingError::new(
                image::error::ImageFormatHint::Exact(image::ImageFormat::Jpeg),
                e,
            ))
        })
}

/// `rgb` as a PNG (fast compression, the Sub filter) appended to `out`.
fn png_fast(
    out: &mut Vec<u8>,
    rgb: &[u8],
    width: u32,
    height: u32,
) -> Result<(), image::ImageError> {
    image::codecs::png::PngEncoder::new_with_quality(
        out,
        image::codecs::png::CompressionType::Fast,
        image::codecs::png::FilterType::Sub,
    )
    .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
}

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
    png_fast(&mut png, img.as_raw(), img.width(), img.height())?;
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

    /// A 64² test picture: smooth gradients with a hard edge.
    fn picture() -> Vec<u8> {
        (0..64u32 * 64)
            .flat_map(|i| {
                let (x, y) = (i % 64, i / 64);
                let edge = if x > 32 { 200 } else { 20 };
                [(x * 4) as u8, (y * 4) as u8, edge]
            })
            .collect()
    }

    #[test]
    fn frames_decode_to_their_pixels_exactly_when_lossless_and_closely_as_jpeg() {
        let rgb = picture();
        let decode = |m: &[u8]| {
            image::load_from_memory(&m[HEADER..])
                .expect("decodable")
                .to_rgb8()
                .into_raw()
        };
        let png = camera_message(FrameFormat::Png, 1, 64, 64, &rgb).expect("png");
        assert_eq!(&png[..HEADER], &[1, 1, 64, 0, 64, 0, 2, 0]);
        assert_eq!(decode(&png), rgb, "PNG frames are lossless");
        let webp = camera_message(FrameFormat::WebP, 1, 64, 64, &rgb).expect("webp");
        assert_eq!(webp[6], 3);
        assert_eq!(decode(&webp), rgb, "WebP frames are lossless");
        let raw = camera_message(FrameFormat::Raw, 0, 64, 64, &rgb).expect("raw");
        assert_eq!(raw[6], 0);
        assert_eq!(&raw[HEADER..], &rgb[..]);
        let jpeg = camera_message(FrameFormat::default(), 0, 64, 64, &rgb).expect("jpeg");
        assert_eq!(jpeg[6], 1);
        assert!(jpeg.len() < rgb.len() / 4, "{} bytes", jpeg.len());
        let back = decode(&jpeg);
        assert_eq!(back.len(), rgb.len());
        // Mean absolute error of a quality-85 JPEG of smooth gradients: a few levels.
        let mae = back
            .iter()
            .zip(&rgb)
            .map(|(a, b)| (i32::from(*a) - i32::from(*b)).abs())
            .sum::<i32>() as f64
            / rgb.len() as f64;
        assert!(mae < 4.0, "mean error {mae}");
        assert!(FrameFormat::Png.lossless() && !FrameFormat::default().lossless());
        assert!(FrameFormat::WebP.lossless());
        assert_eq!(
            FrameFormat::WebP.for_modality(Modality::Semantic),
            FrameFormat::WebP
        );
        let jpeg = FrameFormat::default();
        assert_eq!(jpeg.for_modality(Modality::Color), jpeg);
        assert_eq!(jpeg.for_modality(Modality::Semantic), FrameFormat::Png);
        assert_eq!(jpeg.for_modality(Modality::Depth), FrameFormat::Png);
        assert_eq!(
            FrameFormat::Raw.for_modality(Modality::Depth),
            FrameFormat::Raw
        );
    }
}
