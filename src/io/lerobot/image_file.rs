//! One camera frame as a small, uncompressed image file that Pillow opens in the mode that
//! keeps its values exact, so that Hugging Face `datasets` (an `Image` feature) and LeRobot
//! (`hf_transform_to_torch`, torchvision's `to_tensor`) hand it over as a channel-first
//! tensor without going through Python lists:
//!
//! | file | Pillow mode | tensor | for |
//! |---|---|---|---|
//! | PPM (`P6`, maxval 255) | `RGB` | float32 (3, h, w) in \[0, 1\] | 8-bit colour |
//! | PGM (`P5`, maxval 255) | `L` | float32 (1, h, w) in \[0, 1\] | 8-bit grey |
//! | PFM (`Pf`, little-endian) | `F` | float32 (1, h, w), the values | float32, one channel (depth in metres) |
//! | PGM (`P5`, maxval 65535) | `I` | int32 (1, h, w), the values | u8 and u16 ids, one channel |
//! | TIFF (32-bit signed, uncompressed) | `I` | int32 (1, h, w), the values | u32 ids below 2³¹, one channel |
//!
//! The files are uncompressed (the Parquet column is zstd-compressed as a whole): Pillow
//! reads them with its `raw` decoder, which is what makes them fast to load. Every byte is a
//! function of the pixels, so the same image gives the same file.

use crate::invalid::Invalid;
use crate::render::Image;
use crate::render::PixelType;

/// The file format of a camera's frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageFile {
    /// Binary PPM, 8-bit RGB.
    Ppm,
    /// Binary PGM, maxval 255: 8-bit grey.
    Pgm8,
    /// Binary PGM, maxval 65535 (big-endian 16-bit samples): ids up to 65535.
    Pgm16,
    /// PFM (Portable FloatMap), one channel of little-endian float32, rows bottom-up.
    Pfm,
    /// Baseline TIFF, one strip of little-endian 32-bit signed integers.
    Tiff32,
}

/// Why a frame cannot be written in its file format.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ImageFileError {
    /// The pixel count is not width × height × channels.
    #[error("{got} values for a {width}×{height}×{channels} image")]
    Size {
        /// Values given.
        got: usize,
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// Channels the format holds.
        channels: u32,
    },
    /// Pixels of a type the format does not hold.
    #[error("{dtype} pixels cannot be written as {format}")]
    Type {
        /// The pixels' dtype.
        dtype: PixelType,
        /// The format's name.
        format: &'static str,
    },
    /// A value the format (and LeRobot's int32 tensor) cannot hold.
    #[error("value {value} at pixel {index} is above {max}, the largest {format} holds")]
    Range {
        /// The value.
        value: u64,
        /// Its index in the frame.
        index: usize,
        /// The largest value.
        max: u64,
        /// The format's name.
        format: &'static str,
    },
}

impl ImageFile {
    /// The format's name in `meta/info.json`.
    pub fn name(self) -> &'static str {
        match self {
            ImageFile::Ppm => "PPM (P6, 8-bit)",
            ImageFile::Pgm8 => "PGM (P5, 8-bit)",
            ImageFile::Pgm16 => "PGM (P5, 16-bit)",
            ImageFile::Pfm => "PFM (float32)",
            ImageFile::Tiff32 => "TIFF (int32, uncompressed)",
        }
    }

    /// Channels per pixel.
    pub fn channels(self) -> u32 {
        match self {
            ImageFile::Ppm => 3,
            _ => 1,
        }
    }

    /// The dtype of the tensor LeRobot returns for it.
    pub fn tensor_dtype(self) -> &'static str {
        match self {
            ImageFile::Ppm | ImageFile::Pgm8 | ImageFile::Pfm => "float32",
            ImageFile::Pgm16 | ImageFile::Tiff32 => "int32",
        }
    }

    /// Whether LeRobot scales the values to \[0, 1\] (divides by 255).
    pub fn scaled(self) -> bool {
        matches!(self, ImageFile::Ppm | ImageFile::Pgm8)
    }

    fn check(self, len: usize, width: u32, height: u32) -> Result<(), ImageFileError> {
        let channels = self.channels();
        if len != width as usize * height as usize * channels as usize {
            return Err(ImageFileError::Size {
                got: len,
                width,
                height,
                channels,
            });
        }
        Ok(())
    }

    /// The format of a camera's frames given their dtype and channels (`visual`: colour or
    /// grey, read as an 8-bit picture), or `None` where no Pillow mode holds them (several
    /// float or integer channels).
    pub fn of(dtype: PixelType, channels: u32, visual: bool) -> Option<ImageFile> {
        match (dtype, channels) {
            (PixelType::U8, 3) if visual => Some(ImageFile::Ppm),
            (PixelType::U8, 1) if visual => Some(ImageFile::Pgm8),
            (PixelType::U8 | PixelType::U16, 1) => Some(ImageFile::Pgm16),
            (PixelType::U32, 1) => Some(ImageFile::Tiff32),
            (PixelType::F32, 1) => Some(ImageFile::Pfm),
            _ => None,
        }
    }

    /// Writes `image` (`width` × `height`, row-major, channels interleaved) into `out`
    /// (cleared first).
    pub fn encode(
        self,
        image: &Image,
        width: u32,
        height: u32,
        out: &mut Vec<u8>,
    ) -> Result<(), ImageFileError> {
        let len = match image {
            Image::U8 { data, .. } => data.len(),
            Image::U16(d) => d.len(),
            Image::U32(d) => d.len(),
            Image::F32 { data, .. } => data.len(),
        };
        self.check(len, width, height)?;
        out.clear();
        match (self, image) {
            (ImageFile::Ppm | ImageFile::Pgm8, Image::U8 { data, .. }) => {
                let magic = if self == ImageFile::Ppm { "P6" } else { "P5" };
                out.extend_from_slice(format!("{magic}\n{width} {height}\n255\n").as_bytes());
                out.extend_from_slice(data);
            }
            (ImageFile::Pgm16, Image::U8 { data, .. }) => {
                pgm16(width, height, data.iter().map(|v| u16::from(*v)), out);
            }
            (ImageFile::Pgm16, Image::U16(data)) => pgm16(width, height, data.iter().copied(), out),
            (ImageFile::Tiff32, Image::U32(data)) => {
                if let Some((index, v)) =
                    data.iter().enumerate().find(|(_, v)| **v > i32::MAX as u32)
                {
                    return Err(ImageFileError::Range {
                        value: u64::from(*v),
                        index,
                        max: i32::MAX as u64,
                        format: "an int32 TIFF",
                    });
                }
                write_tiff_header(width, height, out);
                for v in data {
                    out.extend_from_slice(&v.to_le_bytes());
                }
            }
            (ImageFile::Pfm, Image::F32 { data, .. }) => {
                // A negative scale means little-endian samples; PFM stores the bottom row
                // first.
                out.extend_from_slice(format!("Pf\n{width} {height}\n-1.0\n").as_bytes());
                let w = width as usize;
                if w > 0 {
                    for row in data.chunks_exact(w).rev() {
                        for v in row {
                            out.extend_from_slice(&v.to_le_bytes());
                        }
                    }
                }
            }
            _ => {
                let (dtype, _) = image.dtype();
                return Err(ImageFileError::Type {
                    dtype,
                    format: self.name(),
                });
            }
        }
        Ok(())
    }
}

/// A 16-bit PGM: big-endian samples.
fn pgm16(width: u32, height: u32, values: impl Iterator<Item = u16>, out: &mut Vec<u8>) {
    out.extend_from_slice(format!("P5\n{width} {height}\n65535\n").as_bytes());
    for v in values {
        out.extend_from_slice(&v.to_be_bytes());
    }
}

/// TIFF tags of the header, in ascending order (as TIFF requires).
const TIFF_TAGS: usize = 10;

/// Little-endian TIFF header and one IFD describing a `width` × `height` strip of int32
/// samples that starts right after it.
fn write_tiff_header(width: u32, height: u32, out: &mut Vec<u8>) {
    const SHORT: u16 = 3;
    const LONG: u16 = 4;
    let ifd = 8u32;
    let data = ifd + 2 + 12 * TIFF_TAGS as u32 + 4;
    let bytes = width.saturating_mul(height).saturating_mul(4);
    let entries: [(u16, u16, u32); TIFF_TAGS] = [
        (256, LONG, width),  // ImageWidth
        (257, LONG, height), // ImageLength
        (258, SHORT, 32),    // BitsPerSample
        (259, SHORT, 1),     // Compression: none
        (262, SHORT, 1),     // PhotometricInterpretation: BlackIsZero
        (273, LONG, data),   // StripOffsets
        (277, SHORT, 1),     // SamplesPerPixel
        (278, LONG, height), // RowsPerStrip
        (279, LONG, bytes),  // StripByteCounts
        (339, SHORT, 2),     // SampleFormat: signed integer
    ];
    out.extend_from_slice(b"II*\0");
    out.extend_from_slice(&ifd.to_le_bytes());
    out.extend_from_slice(&(TIFF_TAGS as u16).to_le_bytes());
    for (tag, kind, value) in entries {
        out.extend_from_slice(&tag.to_le_bytes());
        out.extend_from_slice(&kind.to_le_bytes());
        out.extend_from_slice(&1u32.to_le_bytes());
        // A SHORT value sits in the first two bytes of the 4-byte value field.
        if kind == SHORT {
            out.extend_from_slice(&(value as u16).to_le_bytes());
            out.extend_from_slice(&[0, 0]);
        } else {
            out.extend_from_slice(&value.to_le_bytes());
        }
    }
    out.extend_from_slice(&0u32.to_le_bytes()); // no next IFD
}

/// A frame read back from its file: the format found by its magic bytes, its size and its
/// pixels (as [`ImageFile::encode`] was given them: interleaved, top row first).
#[derive(Debug, Clone, PartialEq)]
pub struct DecodedFrame {
    /// The file's format.
    pub file: ImageFile,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The pixels.
    pub image: Image,
}

/// Reads a frame file back (the formats [`ImageFile`] writes: PPM, PGM with maxval 255 or
/// 65535, PFM, minos's one-strip int32 TIFF). The error says what is wrong (`truncated: 7,040
/// pixel bytes where 84×84×3 need 21,168`).
pub fn decode(bytes: &[u8]) -> Result<DecodedFrame, Invalid> {
    if bytes.starts_with(b"II*\0") {
        return decode_tiff(bytes);
    }
    let magic = bytes.get(..2).ok_or("empty file")?;
    let (tokens, at) = netpbm_header(bytes)?;
    let [width, height, maxval] = tokens;
    let pixels = width as usize * height as usize;
    let body = &bytes[at..];
    let need = |n: usize, what: &str| -> Result<(), Invalid> {
        if body.len() != n {
            let how = if body.len() < n {
                "truncated"
            } else {
                "too long"
            };
            return Err(format!(
                "{how}: {} pixel bytes where a {width}×{height} {what} needs {n}",
                body.len()
            )
            .into());
        }
        Ok(())
    };
    let (file, image) = match (magic, maxval) {
        (b"P6", 255) => {
            need(pixels * 3, "PPM")?;
            let data = body.to_vec();
            (ImageFile::Ppm, Image::U8 { channels: 3, data })
        }
        (b"P5", 255) => {
            need(pixels, "8-bit PGM")?;
            let data = body.to_vec();
            (ImageFile::Pgm8, Image::U8 { channels: 1, data })
        }
        (b"P5", 65535) => {
            need(pixels * 2, "16-bit PGM")?;
            let data = body
                .chunks_exact(2)
                .map(|b| u16::from_be_bytes([b[0], b[1]]))
                .collect();
            (ImageFile::Pgm16, Image::U16(data))
        }
        (b"Pf", _) => {
            need(pixels * 4, "PFM")?;
            let w = (width as usize).max(1);
            let mut data = Vec::with_capacity(pixels);
            for row in body.chunks_exact(4 * w).rev() {
                data.extend(
                    row.chunks_exact(4)
                        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                );
            }
            (ImageFile::Pfm, Image::F32 { channels: 1, data })
        }
        _ => {
            return Err(format!(
                "not a PPM, PGM (maxval 255 or 65535), PFM or TIFF file (starts with {:?}, maxval {maxval})",
                String::from_utf8_lossy(magic)
            ).into())
        }
    };
    Ok(DecodedFrame {
        file,
        width,
        height,
        image,
    })
}

/// The three numbers after a Netpbm/PFM magic (width, height, maxval or scale — a PFM's
/// scale is read as 0) and where the pixels start (after one whitespace byte).
fn netpbm_header(bytes: &[u8]) -> Result<([u32; 3], usize), Invalid> {
    let mut at = 2;
    let mut tokens = [0u32; 3];
    for (k, token) in tokens.iter_mut().enumerate() {
        while bytes.get(at).is_some_and(u8::is_ascii_whitespace) {
            at += 1;
        }
        let start = at;
        while bytes.get(at).is_some_and(|b| !b.is_ascii_whitespace()) {
            at += 1;
        }
        let text = std::str::from_utf8(&bytes[start..at]).unwrap_or("");
        *token = if k == 2 && bytes.starts_with(b"Pf") {
            text.parse::<f32>()
                .map(|_| 0)
                .map_err(|_| Invalid::new(format!("header: scale `{text}` is not a number")))?
        } else {
            text.parse::<u32>().map_err(|_| {
                Invalid::new(format!("header: `{}` is not a size", text.escape_debug()))
            })?
        };
        if k < 2 && *token == 0 {
            return Err("header: zero width or height".into());
        }
    }
    if bytes.get(at).is_none_or(|b| !b.is_ascii_whitespace()) {
        return Err("header: no pixels".into());
    }
    Ok((tokens, at + 1))
}

/// minos's TIFF (one strip of 32-bit signed samples): the size and strip from its tags.
fn decode_tiff(bytes: &[u8]) -> Result<DecodedFrame, Invalid> {
    let u16_at = |i: usize| {
        bytes
            .get(i..i + 2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
    };
    let u32_at = |i: usize| {
        bytes
            .get(i..i + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let short = "truncated TIFF header";
    let ifd = u32_at(4).ok_or(short)? as usize;
    let count = u16_at(ifd).ok_or(short)? as usize;
    let (mut width, mut height, mut offset, mut length, mut bits) = (0, 0, 0, 0, 0);
    for k in 0..count {
        let e = ifd + 2 + 12 * k;
        let tag = u16_at(e).ok_or(short)?;
        let kind = u16_at(e + 2).ok_or(short)?;
        let value = if kind == 3 {
            u32::from(u16_at(e + 8).ok_or(short)?)
        } else {
            u32_at(e + 8).ok_or(short)?
        };
        match tag {
            256 => width = value,
            257 => height = value,
            258 => bits = value,
            273 => offset = value as usize,
            279 => length = value as usize,
            _ => {}
        }
    }
    if bits != 32 || width == 0 || height == 0 {
        return Err(format!(
            "TIFF of {width}×{height} with {bits}-bit samples, not minos's 32-bit ids"
        )
        .into());
    }
    let need = width as usize * height as usize * 4;
    let strip = bytes.get(offset..).unwrap_or(&[]);
    if length != need || strip.len() < need {
        return Err(format!(
            "truncated: {} strip bytes where a {width}×{height} int32 TIFF needs {need}",
            strip.len().min(length)
        )
        .into());
    }
    let data = strip[..need]
        .chunks_exact(4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    Ok(DecodedFrame {
        file: ImageFile::Tiff32,
        width,
        height,
        image: Image::U32(data),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Splits a Netpbm/PFM file into its three header lines and the samples.
    fn netpbm(bytes: &[u8]) -> (Vec<String>, &[u8]) {
        let mut lines = Vec::new();
        let mut at = 0;
        for _ in 0..3 {
            let end = at + bytes[at..].iter().position(|b| *b == b'\n').expect("line");
            lines.push(String::from_utf8(bytes[at..end].to_vec()).expect("ascii"));
            at = end + 1;
        }
        (lines, &bytes[at..])
    }

    #[test]
    fn netpbm_files_hold_the_pixels_in_their_documented_layout() {
        // 3 wide, 2 high, so rows and columns cannot be confused.
        let rgb: Vec<u8> = (0..18).collect();
        let mut out = Vec::new();
        let u8s = |channels, data: &[u8]| Image::U8 {
            channels,
            data: data.to_vec(),
        };
        ImageFile::Ppm
            .encode(&u8s(3, &rgb), 3, 2, &mut out)
            .expect("ppm");
        let (head, body) = netpbm(&out);
        assert_eq!(head, ["P6", "3 2", "255"]);
        assert_eq!(body, &rgb[..]);

        let ids: Vec<u16> = vec![0, 1, 255, 256, 40000, 65535];
        ImageFile::Pgm16
            .encode(&Image::U16(ids.clone()), 3, 2, &mut out)
            .expect("pgm");
        let (head, body) = netpbm(&out);
        assert_eq!(head, ["P5", "3 2", "65535"]);
        let back: Vec<u16> = body
            .chunks_exact(2)
            .map(|c| u16::from_be_bytes([c[0], c[1]]))
            .collect();
        assert_eq!(back, ids);
        // u8 ids are widened to 16 bits, so that Pillow reads them as integers, not grey.
        ImageFile::Pgm16
            .encode(&u8s(1, &[7, 8, 9, 10, 11, 12]), 3, 2, &mut out)
            .expect("pgm");
        assert_eq!(netpbm(&out).0[2], "65535");
        assert_eq!(&netpbm(&out).1[..4], &[0, 7, 0, 8]);

        let depth = [0.5f32, 1.25, 0.0, 3.0, f32::MAX, 1e-7];
        let f32s = Image::F32 {
            channels: 1,
            data: depth.to_vec(),
        };
        ImageFile::Pfm.encode(&f32s, 3, 2, &mut out).expect("pfm");
        let (head, body) = netpbm(&out);
        assert_eq!(head, ["Pf", "3 2", "-1.0"]);
        let back: Vec<f32> = body
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        // Bottom row first.
        assert_eq!(back, [3.0, f32::MAX, 1e-7, 0.5, 1.25, 0.0]);
    }

    #[test]
    fn tiff_has_one_strip_of_signed_32_bit_samples_after_its_header() {
        let ids: Vec<u32> = vec![0, 1, 70000, i32::MAX as u32, 5, 6];
        let mut out = Vec::new();
        ImageFile::Tiff32
            .encode(&Image::U32(ids.clone()), 3, 2, &mut out)
            .expect("tiff");
        assert_eq!(&out[..4], b"II*\0");
        let u16_at = |i: usize| u16::from_le_bytes([out[i], out[i + 1]]);
        let u32_at = |i: usize| u32::from_le_bytes([out[i], out[i + 1], out[i + 2], out[i + 3]]);
        let ifd = u32_at(4) as usize;
        let n = u16_at(ifd) as usize;
        let tag = |t: u16| {
            (0..n)
                .map(|k| ifd + 2 + 12 * k)
                .find(|e| u16_at(*e) == t)
                .map(|e| {
                    if u16_at(e + 2) == 3 {
                        u32::from(u16_at(e + 8))
                    } else {
                        u32_at(e + 8)
                    }
                })
                .expect("tag")
        };
        assert_eq!((tag(256), tag(257)), (3, 2));
        assert_eq!((tag(258), tag(259), tag(277), tag(339)), (32, 1, 1, 2));
        let start = tag(273) as usize;
        assert_eq!(tag(279) as usize, 24);
        assert_eq!(out.len(), start + 24);
        let back: Vec<u32> = (0..6).map(|k| u32_at(start + 4 * k)).collect();
        assert_eq!(back, ids);
        // Tags ascend, as TIFF readers may require.
        let tags: Vec<u16> = (0..n).map(|k| u16_at(ifd + 2 + 12 * k)).collect();
        assert!(tags.windows(2).all(|w| w[0] < w[1]), "{tags:?}");
    }

    #[test]
    fn values_and_sizes_a_format_cannot_hold_are_errors() {
        let mut out = Vec::new();
        let e = ImageFile::Tiff32
            .encode(&Image::U32(vec![1, 1 << 31]), 2, 1, &mut out)
            .expect_err("2^31");
        assert!(e.to_string().contains("2147483648"), "{e}");
        let five = Image::U8 {
            channels: 3,
            data: vec![0; 5],
        };
        assert!(matches!(
            ImageFile::Ppm.encode(&five, 1, 2, &mut out),
            Err(ImageFileError::Size { got: 5, .. })
        ));
        assert!(matches!(
            ImageFile::Pfm.encode(&Image::U16(vec![0; 4]), 2, 2, &mut out),
            Err(ImageFileError::Type { .. })
        ));
    }

    #[test]
    fn the_same_pixels_give_the_same_bytes() {
        let ids: Vec<u16> = (0..64).map(|i| i * 997).collect();
        let (mut a, mut b) = (Vec::new(), vec![1, 2, 3]);
        let img = Image::U16(ids);
        ImageFile::Pgm16.encode(&img, 8, 8, &mut a).expect("a");
        ImageFile::Pgm16.encode(&img, 8, 8, &mut b).expect("b");
        assert_eq!(a, b);
    }

    #[test]
    fn every_format_decodes_back_to_its_pixels_and_damage_is_named() {
        let cases: Vec<(ImageFile, Image)> = vec![
            (
                ImageFile::Ppm,
                Image::U8 {
                    channels: 3,
                    data: (0..18).collect(),
                },
            ),
            (
                ImageFile::Pgm8,
                Image::U8 {
                    channels: 1,
                    data: (0..6).collect(),
                },
            ),
            (
                ImageFile::Pgm16,
                Image::U16(vec![0, 1, 255, 256, 40000, 65535]),
            ),
            (
                ImageFile::Pfm,
                Image::F32 {
                    channels: 1,
                    data: vec![0.0, 1.5, -2.0, 3.25, 4.0, 5.5],
                },
            ),
            (
                ImageFile::Tiff32,
                Image::U32(vec![0, 1, 70000, 5, 6, 2147483647]),
            ),
        ];
        for (file, image) in cases {
            let mut out = Vec::new();
            file.encode(&image, 3, 2, &mut out).expect("encode");
            let back = decode(&out).expect("decode");
            assert_eq!((back.file, back.width, back.height), (file, 3, 2));
            assert_eq!(back.image, image, "{file:?}");
            let cut = decode(&out[..out.len() - 1]).unwrap_err();
            assert!(cut.to_string().starts_with("truncated"), "{file:?}: {cut}");
        }
        assert!(decode(b"").is_err());
        assert!(decode(b"P6\n3 x\n255\n")
            .unwrap_err()
            .to_string()
            .contains("`x`"));
    }
}
