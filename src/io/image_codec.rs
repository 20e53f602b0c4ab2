//! How one camera image is stored in a table cell, and how it is read back.
//!
//! Every stored form either keeps the sensor's pixels exactly or is lossy in one documented
//! way, and the column metadata (see [`CellFormat::metadata`]) always states the pixels'
//! real dtype and shape, the encoding, and the quantisation of a lossy one, so a reader can
//! get the raw arrays back with [`decode_cell`]:
//!
//! | sensor pixels | `raw` | `png` |
//! |---|---|---|
//! | u8 (colour, grey, room class, byte depth) | `raw-le` | `png` 8-bit RGB / grey, lossless |
//! | u16 (semantic ids, 16-bit depth) | `raw-le` | `png16` 16-bit grey, lossless |
//! | u32 (instance, room ids) | `raw-le` | `png-rgba8-u32le`: the id's four little-endian bytes as R, G, B, A, lossless |
//! | f32 depth (metres) | `raw-le` | `png16-depth-mm`: millimetres, rounded, clipped to 0–65.535 m (lossy: ≤ 0.5 mm) |
//! | f32 normals (−1…1) | `raw-le` | `png16-normal`: (v + 1) / 2 × 65535, rounded (lossy: ≤ 1.6e-5) |
//!
//! Previews for people (label colours, room-class colours) are `render::visualize`'s job;
//! nothing here colourises.

use std::collections::HashMap;

use image::{DynamicImage, ImageBuffer, Luma, Rgb, Rgba};

use crate::render::{Image, Modality, PixelType};
use crate::sim::{dtype_of, CameraSensor};

/// Millimetres per metre of `png16-depth-mm`.
const DEPTH_UNITS_PER_METRE: f32 = 1000.0;

/// How images are stored in a run's tables (the user's choice, `--image-encoding`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ImageEncoding {
    /// Raw little-endian pixels; shape and dtype in the column metadata.
    #[default]
    Raw,
    /// PNG: lossless for integer pixels, documented quantisation for float depth and
    /// normals (see the module table).
    Png,
}

impl ImageEncoding {
    /// `raw` or `png`.
    pub fn name(self) -> &'static str {
        crate::vocab::Vocabulary::term_name(self)
    }
}

impl crate::vocab::Vocabulary for ImageEncoding {
    const WHAT: &'static str = "image encoding";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: ImageEncoding::Raw,
            name: "raw",
            aliases: &[],
            help: "raw little-endian pixels (shape and dtype in the column metadata)",
        },
        crate::vocab::Term {
            value: ImageEncoding::Png,
            name: "png",
            aliases: &[],
            help: "PNG: lossless for colour and ids; depth as 16-bit millimetres and normals as \
                   16-bit values (the quantisation is in the column metadata)",
        },
    ];
}

crate::vocab::name_traits!(ImageEncoding);

/// The stored form of one image column (one row of the module table).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellEncoding {
    /// Raw little-endian pixels.
    RawLe,
    /// 8-bit PNG (grey, or RGB for three channels).
    Png8,
    /// 16-bit grey PNG.
    Png16,
    /// u32 ids as 8-bit RGBA PNG: the four little-endian bytes of each id.
    PngRgba8U32Le,
    /// f32 depth as 16-bit grey PNG of millimetres.
    Png16DepthMm,
    /// f32 unit normals as 16-bit RGB PNG of (v + 1) / 2 × 65535.
    Png16Normal,
}

impl crate::vocab::Vocabulary for CellEncoding {
    const WHAT: &'static str = "cell encoding";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: CellEncoding::RawLe,
            name: "raw-le",
            aliases: &[],
            help: "raw little-endian pixels",
        },
        crate::vocab::Term {
            value: CellEncoding::Png8,
            name: "png",
            aliases: &[],
            help: "8-bit PNG (grey, or RGB for three channels)",
        },
        crate::vocab::Term {
            value: CellEncoding::Png16,
            name: "png16",
            aliases: &[],
            help: "16-bit grey PNG",
        },
        crate::vocab::Term {
            value: CellEncoding::PngRgba8U32Le,
            name: "png-rgba8-u32le",
            aliases: &[],
            help: "u32 ids as 8-bit RGBA PNG (the id's little-endian bytes)",
        },
        crate::vocab::Term {
            value: CellEncoding::Png16DepthMm,
            name: "png16-depth-mm",
            aliases: &[],
            help: "f32 depth as 16-bit grey PNG of millimetres",
        },
        crate::vocab::Term {
            value: CellEncoding::Png16Normal,
            name: "png16-normal",
            aliases: &[],
            help: "f32 unit normals as 16-bit RGB PNG of (v + 1) / 2 × 65535",
        },
    ];
}

crate::vocab::name_traits!(CellEncoding);

/// Everything needed to decode one image column: the pixels' dtype and shape and their
/// stored form.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CellFormat {
    /// The stored form.
    pub encoding: CellEncoding,
    /// The decoded pixels' dtype.
    pub dtype: PixelType,
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// Channels per pixel.
    pub channels: u32,
}

/// An image that cannot be encoded or a cell that cannot be decoded.
#[derive(Debug, thiserror::Error)]
pub enum CodecError {
    /// The image does not have the column's dtype or size.
    #[error("image is {got}, the column holds {expected}")]
    Mismatch {
        /// What the column holds.
        expected: String,
        /// What was given or decoded.
        got: String,
    },
    /// PNG encoding or decoding failed.
    #[error("PNG")]
    Png(#[source] image::ImageError),
    /// The image's pixel count does not fit its stated size.
    #[error("PNG: pixel count does not fit the size")]
    PngSize,
    /// The column metadata does not describe an image column.
    #[error("column metadata: {0}")]
    Metadata(String),
}

impl CellEncoding {
    /// The form `choice` stores pixels of `dtype` from a sensor of `modality` in.
    pub fn choose(choice: ImageEncoding, modality: Modality, dtype: PixelType) -> CellEncoding {
        match (choice, dtype) {
            (ImageEncoding::Raw, _) => CellEncoding::RawLe,
            (ImageEncoding::Png, PixelType::U8) => CellEncoding::Png8,
            (ImageEncoding::Png, PixelType::U16) => CellEncoding::Png16,
            (ImageEncoding::Png, PixelType::U32) => CellEncoding::PngRgba8U32Le,
            (ImageEncoding::Png, PixelType::F32) if modality == Modality::Normal => {
                CellEncoding::Png16Normal
            }
            (ImageEncoding::Png, PixelType::F32) => CellEncoding::Png16DepthMm,
        }
    }

    /// The name in the column metadata's `encoding`.
    pub fn name(self) -> &'static str {
        crate::vocab::Vocabulary::term_name(self)
    }

    /// The largest difference between a pixel and its decoded value (0 for lossless forms).
    pub fn max_error(self) -> f32 {
        match self {
            CellEncoding::Png16DepthMm => 0.5 / DEPTH_UNITS_PER_METRE,
            CellEncoding::Png16Normal => 1.0 / 65535.0,
            _ => 0.0,
        }
    }

    /// Key/value pairs that describe a lossy form (empty for lossless ones): how a stored
    /// value maps back (`value = stored * scale + offset`), the range kept and the largest
    /// error.
    fn quantisation(self) -> Vec<(&'static str, String)> {
        match self {
            CellEncoding::Png16DepthMm => vec![
                ("scale", "0.001".into()),
                ("offset", "0".into()),
                ("clip", "[0, 65.535]".into()),
                ("max_error", "0.0005".into()),
                ("unit", "m".into()),
            ],
            CellEncoding::Png16Normal => vec![
                ("scale", format!("{}", 2.0 / 65535.0)),
                ("offset", "-1".into()),
                ("clip", "[-1, 1]".into()),
                ("max_error", format!("{}", 1.0 / 65535.0)),
            ],
            _ => Vec::new(),
        }
    }
}

impl CellFormat {
    /// How `choice` stores the images of `camera`.
    pub fn for_camera(camera: &CameraSensor, choice: ImageEncoding) -> CellFormat {
        let (dtype, channels) = dtype_of(camera);
        CellFormat {
            encoding: CellEncoding::choose(choice, camera.modality, dtype),
            dtype,
            width: camera.resolution[0],
            height: camera.resolution[1],
            channels,
        }
    }

    /// The column metadata: `dtype` and `shape` ([height, width, channels]) of the decoded
    /// pixels, `modality`, `encoding`, `lossless`, and a lossy form's quantisation.
    pub fn metadata(&self, modality: Modality) -> HashMap<String, String> {
        let mut meta = HashMap::new();
        meta.insert("dtype".into(), self.dtype.name().into());
        meta.insert(
            "shape".into(),
            format!("[{}, {}, {}]", self.height, self.width, self.channels),
        );
        meta.insert("modality".into(), modality_name(modality));
        meta.insert("encoding".into(), self.encoding.name().into());
        let quantisation = self.encoding.quantisation();
        meta.insert("lossless".into(), quantisation.is_empty().to_string());
        for (k, v) in quantisation {
            meta.insert(k.into(), v);
        }
        meta
    }

    /// Reads the format back from a column's metadata (as [`CellFormat::metadata`] wrote it).
    pub fn from_metadata(meta: &HashMap<String, String>) -> Result<CellFormat, CodecError> {
        let get = |k: &str| {
            meta.get(k)
                .ok_or_else(|| CodecError::Metadata(format!("no `{k}`")))
        };
        let dtype = get("dtype")?;
        let dtype = dtype
            .parse::<PixelType>()
            .map_err(|e| CodecError::Metadata(e.to_string()))?;
        let encoding = get("encoding")?
            .parse::<CellEncoding>()
            .map_err(|e| CodecError::Metadata(e.to_string()))?;
        let shape = get("shape")?;
        let dims: Vec<u32> = shape
            .trim_matches(|c| c == '[' || c == ']')
            .split(',')
            .map(|t| t.trim().parse::<u32>())
            .collect::<Result<_, _>>()
            .map_err(|_| CodecError::Metadata(format!("shape `{shape}` is not [h, w, c]")))?;
        match dims[..] {
            [height, width, channels] if height > 0 && width > 0 && (1..=4).contains(&channels) => {
                Ok(CellFormat {
                    encoding,
                    dtype,
                    width,
                    height,
                    channels,
                })
            }
            _ => Err(CodecError::Metadata(format!(
                "shape `{shape}` is not [h, w, c] with 1–4 channels"
            ))),
        }
    }

    fn describe(&self) -> String {
        format!(
            "{}×{}×{} {}",
            self.height,
            self.width,
            self.channels,
            self.dtype.name()
        )
    }

    fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

/// A modality's name as sensor files spell it (`color`, `room_class`, …).
pub fn modality_name(modality: Modality) -> String {
    serde_json::to_value(modality)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_default()
}

/// Parses [`modality_name`].
pub fn modality_from_name(name: &str) -> Option<Modality> {
    serde_json::from_value(serde_json::Value::String(name.to_string())).ok()
}

fn describe_image(img: &Image, pixels: usize) -> String {
    let (dtype, channels) = img.dtype();
    let values = match img {
        Image::U8 { data, .. } => data.len(),
        Image::U16(d) => d.len(),
        Image::U32(d) => d.len(),
        Image::F32 { data, .. } => data.len(),
    };
    let _ = pixels;
    format!("{values} values of {dtype} in {channels} channel(s)")
}

/// Appends `img`, stored as `format` says, to `out`.
pub fn encode_cell(img: &Image, format: &CellFormat, out: &mut Vec<u8>) -> Result<(), CodecError> {
    let n = format.pixels();
    let c = format.channels as usize;
    let mismatch = || CodecError::Mismatch {
        expected: format.describe(),
        got: describe_image(img, n),
    };
    let (w, h) = (format.width, format.height);
    match (format.encoding, img) {
        (CellEncoding::RawLe, img) => {
            if img.dtype() != (format.dtype, format.channels) {
                return Err(mismatch());
            }
            let start = out.len();
            append_le_bytes(out, img);
            if out.len() - start != n * c * bytes_per_value(format.dtype) {
                out.truncate(start);
                return Err(mismatch());
            }
            Ok(())
        }
        (CellEncoding::Png8, Image::U8 { channels, data }) if *channels == format.channels => {
            match channels {
                1 => png(
                    ImageBuffer::<Luma<u8>, _>::from_raw(w, h, data.as_slice()),
                    out,
                ),
                3 => png(
                    ImageBuffer::<Rgb<u8>, _>::from_raw(w, h, data.as_slice()),
                    out,
                ),
                4 => png(
                    ImageBuffer::<Rgba<u8>, _>::from_raw(w, h, data.as_slice()),
                    out,
                ),
                _ => Err(mismatch()),
            }
        }
        (CellEncoding::Png16, Image::U16(d)) if c == 1 => png(
            ImageBuffer::<Luma<u16>, _>::from_raw(w, h, d.as_slice()),
            out,
        ),
        (CellEncoding::PngRgba8U32Le, Image::U32(d)) if c == 1 => {
            let bytes: Vec<u8> = d.iter().flat_map(|v| v.to_le_bytes()).collect();
            png(ImageBuffer::<Rgba<u8>, _>::from_raw(w, h, bytes), out)
        }
        (CellEncoding::Png16DepthMm, Image::F32 { channels: 1, data }) if c == 1 => {
            let mm: Vec<u16> = data
                .iter()
                .map(|d| (d * DEPTH_UNITS_PER_METRE).round().clamp(0.0, 65535.0) as u16)
                .collect();
            png(ImageBuffer::<Luma<u16>, _>::from_raw(w, h, mm), out)
        }
        (CellEncoding::Png16Normal, Image::F32 { channels: 3, data }) if c == 3 => {
            let q: Vec<u16> = data
                .iter()
                .map(|v| ((v.clamp(-1.0, 1.0) + 1.0) * 0.5 * 65535.0).round() as u16)
                .collect();
            png(ImageBuffer::<Rgb<u16>, _>::from_raw(w, h, q), out)
        }
        _ => Err(mismatch()),
    }
}

/// Reads one cell back into the sensor's pixels (exactly, or within
/// [`CellEncoding::max_error`] for the lossy forms).
pub fn decode_cell(bytes: &[u8], format: &CellFormat) -> Result<Image, CodecError> {
    let n = format.pixels();
    let c = format.channels;
    let got = |what: String| CodecError::Mismatch {
        expected: format.describe(),
        got: what,
    };
    if format.encoding == CellEncoding::RawLe {
        let want = n * c as usize * bytes_per_value(format.dtype);
        if bytes.len() != want {
            return Err(got(format!("{} bytes", bytes.len())));
        }
        return Ok(from_le_bytes(bytes, format.dtype, c));
    }
    let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Png)
        .map_err(CodecError::Png)?;
    if (img.width(), img.height()) != (format.width, format.height) {
        return Err(got(format!("a {}×{} PNG", img.width(), img.height())));
    }
    let kind = format!("{:?} PNG", img.color());
    match (format.encoding, img) {
        (CellEncoding::Png8, DynamicImage::ImageLuma8(b)) if c == 1 => Ok(Image::U8 {
            channels: 1,
            data: b.into_raw(),
        }),
        (CellEncoding::Png8, DynamicImage::ImageRgb8(b)) if c == 3 => Ok(Image::U8 {
            channels: 3,
            data: b.into_raw(),
        }),
        (CellEncoding::Png8, DynamicImage::ImageRgba8(b)) if c == 4 => Ok(Image::U8 {
            channels: 4,
            data: b.into_raw(),
        }),
        (CellEncoding::Png16, DynamicImage::ImageLuma16(b)) if c == 1 => {
            Ok(Image::U16(b.into_raw()))
        }
        (CellEncoding::PngRgba8U32Le, DynamicImage::ImageRgba8(b)) if c == 1 => Ok(Image::U32(
            b.into_raw()
                .chunks_exact(4)
                .map(|p| u32::from_le_bytes([p[0], p[1], p[2], p[3]]))
                .collect(),
        )),
        (CellEncoding::Png16DepthMm, DynamicImage::ImageLuma16(b)) if c == 1 => Ok(Image::F32 {
            channels: 1,
            data: b
                .into_raw()
                .into_iter()
                .map(|mm| f32::from(mm) / DEPTH_UNITS_PER_METRE)
                .collect(),
        }),
        (CellEncoding::Png16Normal, DynamicImage::ImageRgb16(b)) if c == 3 => Ok(Image::F32 {
            channels: 3,
            data: b
                .into_raw()
                .into_iter()
                .map(|q| f32::from(q) / 65535.0 * 2.0 - 1.0)
                .collect(),
        }),
        _ => Err(got(kind)),
    }
}

fn bytes_per_value(t: PixelType) -> usize {
    match t {
        PixelType::U8 => 1,
        PixelType::U16 => 2,
        PixelType::U32 | PixelType::F32 => 4,
    }
}

/// Appends an image's raw little-endian bytes to `out`.
pub fn append_le_bytes(out: &mut Vec<u8>, img: &Image) {
    #[cfg(target_endian = "little")]
    match img {
        Image::U8 { data, .. } => out.extend_from_slice(data),
        Image::U16(d) => out.extend_from_slice(bytemuck::cast_slice(d)),
        Image::U32(d) => out.extend_from_slice(bytemuck::cast_slice(d)),
        Image::F32 { data, .. } => out.extend_from_slice(bytemuck::cast_slice(data)),
    }
    #[cfg(not(target_endian = "little"))]
    out.extend_from_slice(&img.to_le_bytes());
}

fn from_le_bytes(bytes: &[u8], dtype: PixelType, channels: u32) -> Image {
    match dtype {
        PixelType::U8 => Image::U8 {
            channels,
            data: bytes.to_vec(),
        },
        PixelType::U16 => Image::U16(
            bytes
                .chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]))
                .collect(),
        ),
        PixelType::U32 => Image::U32(
            bytes
                .chunks_exact(4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect(),
        ),
        PixelType::F32 => Image::F32 {
            channels,
            data: bytes
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect(),
        },
    }
}

/// Encodes a pixel buffer as PNG onto `out` (`None`: the buffer does not fit its size).
fn png<P, C>(buffer: Option<ImageBuffer<P, C>>, out: &mut Vec<u8>) -> Result<(), CodecError>
where
    P: image::PixelWithColorType,
    C: std::ops::Deref<Target = [P::Subpixel]>,
    [P::Subpixel]: image::EncodableLayout,
{
    let buffer = buffer.ok_or(CodecError::PngSize)?;
    let mut cursor = std::io::Cursor::new(std::mem::take(out));
    cursor.set_position(cursor.get_ref().len() as u64);
    let result = buffer
        .write_to(&mut cursor, image::ImageFormat::Png)
        .map_err(CodecError::Png);
    *out = cursor.into_inner();
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    fn format(encoding: CellEncoding, dtype: PixelType, channels: u32) -> CellFormat {
        CellFormat {
            encoding,
            dtype,
            width: 5,
            height: 3,
            channels,
        }
    }

    /// Every value kind a sensor can produce, including the extremes of each dtype.
    fn samples() -> Vec<(Modality, Image, u32)> {
        let n = 15;
        vec![
            (
                Modality::Color,
                Image::U8 {
                    channels: 3,
                    data: (0..n * 3).map(|i| (i * 17 % 256) as u8).collect(),
                },
                3,
            ),
            (
                Modality::Gray,
                Image::U8 {
                    channels: 1,
                    data: (0..n).map(|i| [0, 255, 7][i % 3]).collect(),
                },
                1,
            ),
            (
                Modality::Semantic,
                Image::U16((0..n).map(|i| [0, 40, 65535, 1234][i % 4]).collect()),
                1,
            ),
            (
                Modality::Instance,
                Image::U32((0..n).map(|i| [0, 1, 70_000, u32::MAX][i % 4]).collect()),
                1,
            ),
            (
                Modality::Depth,
                Image::F32 {
                    channels: 1,
                    data: (0..n)
                        .map(|i| [0.0, 0.1234, 9.87654, 70.0][i % 4])
                        .collect(),
                },
                1,
            ),
            (
                Modality::Normal,
                Image::F32 {
                    channels: 3,
                    data: (0..n * 3)
                        .map(|i| [-1.0, 1.0, 0.0, 0.577_350_3, -0.3][i % 5])
                        .collect(),
                },
                3,
            ),
        ]
    }

    fn pixel_type(img: &Image) -> PixelType {
        img.dtype().0
    }

    #[test]
    fn every_encoding_decodes_to_the_raw_pixels_within_its_stated_error() {
        for choice in [ImageEncoding::Raw, ImageEncoding::Png] {
            for (modality, img, channels) in samples() {
                let dtype = pixel_type(&img);
                let enc = CellEncoding::choose(choice, modality, dtype);
                let f = format(enc, dtype, channels);
                let mut bytes = Vec::new();
                encode_cell(&img, &f, &mut bytes).expect("encodes");
                let back = decode_cell(&bytes, &f).expect("decodes");
                match (&img, &back) {
                    (Image::F32 { data: a, .. }, Image::F32 { data: b, .. }) => {
                        // The stated bound, checked against an independent quantisation:
                        // values outside the kept range come back clipped.
                        let (lo, hi) = if modality == Modality::Depth {
                            (0.0, 65.535)
                        } else {
                            (-1.0, 1.0)
                        };
                        for (x, y) in a.iter().zip(b) {
                            let expected = if choice == ImageEncoding::Raw {
                                *x
                            } else {
                                x.clamp(lo, hi)
                            };
                            assert!(
                                (expected - y).abs() <= enc.max_error() + 1e-7,
                                "{modality:?} {}: {x} came back as {y}",
                                enc.name()
                            );
                        }
                        if choice == ImageEncoding::Raw {
                            assert_eq!(a, b);
                        }
                    }
                    _ => assert_eq!(img, back, "{modality:?} {} is lossless", enc.name()),
                }
                let lossless = f.metadata(modality)["lossless"] == "true";
                assert_eq!(lossless, enc.max_error() == 0.0, "{}", enc.name());
            }
        }
    }

    #[test]
    fn metadata_states_the_real_dtype_shape_and_encoding_and_reads_back() {
        let f = CellFormat {
            encoding: CellEncoding::Png16DepthMm,
            dtype: PixelType::F32,
            width: 84,
            height: 64,
            channels: 1,
        };
        let meta = f.metadata(Modality::Depth);
        assert_eq!(meta["dtype"], "float32");
        assert_eq!(meta["shape"], "[64, 84, 1]");
        assert_eq!(meta["encoding"], "png16-depth-mm");
        assert_eq!(meta["scale"], "0.001");
        assert_eq!(meta["lossless"], "false");
        assert_eq!(CellFormat::from_metadata(&meta).expect("reads"), f);
        let mut bad = meta.clone();
        bad.insert("encoding".into(), "jpeg".into());
        let e = CellFormat::from_metadata(&bad)
            .expect_err("unknown")
            .to_string();
        assert!(e.contains("jpeg"), "{e}");
        bad = meta;
        bad.insert("shape".into(), "[64, 84]".into());
        assert!(CellFormat::from_metadata(&bad).is_err());
    }

    #[test]
    fn a_wrong_image_or_a_corrupt_cell_is_an_error_not_a_panic() {
        let f = format(CellEncoding::Png16, PixelType::U16, 1);
        let mut out = Vec::new();
        let wrong = Image::U8 {
            channels: 1,
            data: vec![0; 15],
        };
        assert!(encode_cell(&wrong, &f, &mut out).is_err());
        let short = Image::U16(vec![1; 14]);
        assert!(encode_cell(&short, &f, &mut out).is_err());
        // The PNG decoder's own error is kept as the cause.
        let e = decode_cell(b"not a png", &f).unwrap_err();
        assert!(matches!(e, CodecError::Png(_)), "{e:?}");
        let source = std::error::Error::source(&e).expect("the decoder's error");
        assert!(source.is::<image::ImageError>());
        encode_cell(&Image::U16(vec![3; 15]), &f, &mut out).expect("encodes");
        let mut cut = out.clone();
        cut.truncate(out.len() / 2);
        assert!(decode_cell(&cut, &f).is_err());
        // An 8-bit PNG where a 16-bit one is due.
        let f8 = format(CellEncoding::Png8, PixelType::U8, 1);
        let mut png8 = Vec::new();
        encode_cell(&wrong, &f8, &mut png8).expect("encodes");
        let e = decode_cell(&png8, &f).expect_err("wrong depth").to_string();
        assert!(e.contains("L8"), "{e}");
        let raw = format(CellEncoding::RawLe, PixelType::F32, 1);
        assert!(decode_cell(&[0; 7], &raw).is_err());
    }
}
