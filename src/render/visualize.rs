//! Turning sensor images into PNG files people can look at: colour as is, depth as 16-bit
//! millimetres, normals as (n + 1) / 2, labels with a fixed colour per id.

use std::path::Path;

use image::{ImageBuffer, Luma, Rgb, RgbImage};

use super::image::{Image, Modality};

/// A fixed, well-spread colour for a label id (0 is black).
pub fn label_color(id: u32) -> [u8; 3] {
    if id == 0 {
        return [0, 0, 0];
    }
    let h = crate::seed::splitmix64(u64::from(id));
    [
        64 + (h & 0xbf) as u8,
        64 + ((h >> 8) & 0xbf) as u8,
        64 + ((h >> 16) & 0xbf) as u8,
    ]
}

/// Writes `image` (of a sensor with `modality`, `width` × `height`) as a PNG.
pub fn write_png(
    path: &Path,
    modality: Modality,
    image: &Image,
    width: u32,
    height: u32,
) -> std::io::Result<()> {
    let bytes = encode_png(modality, image, width, height)?;
    crate::atomic::write_bytes_atomic(path, &bytes)
}

/// Encodes `image` (of a sensor with `modality`, `width` × `height`) as PNG bytes.
pub fn encode_png(
    modality: Modality,
    image: &Image,
    width: u32,
    height: u32,
) -> std::io::Result<Vec<u8>> {
    let n = (width * height) as usize;
    fn encode<P: image::PixelWithColorType, C: std::ops::Deref<Target = [P::Subpixel]>>(
        img: &ImageBuffer<P, C>,
    ) -> std::io::Result<Vec<u8>>
    where
        [P::Subpixel]: image::EncodableLayout,
    {
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png)
            .map_err(std::io::Error::other)?;
        Ok(out.into_inner())
    }
    let save_rgb = |pixels: Vec<[u8; 3]>| -> std::io::Result<Vec<u8>> {
        let mut img = RgbImage::new(width, height);
        for (i, p) in pixels.into_iter().enumerate().take(n) {
            img.put_pixel(i as u32 % width, i as u32 / width, Rgb(p));
        }
        encode(&img)
    };
    match (modality, image) {
        (Modality::Color, Image::U8 { data, .. }) => {
            save_rgb(data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
        }
        (Modality::Gray | Modality::Depth, Image::U8 { data, .. }) => {
            let img: ImageBuffer<Luma<u8>, Vec<u8>> =
                ImageBuffer::from_raw(width, height, data.clone())
                    .ok_or_else(|| std::io::Error::other("size"))?;
            encode(&img)
        }
        (Modality::Depth, Image::F32 { data, .. }) => {
            let mm: Vec<u16> = data
                .iter()
                .map(|d| (d * 1000.0).round().clamp(0.0, 65535.0) as u16)
                .collect();
            let img: ImageBuffer<Luma<u16>, Vec<u16>> = ImageBuffer::from_raw(width, height, mm)
                .ok_or_else(|| std::io::Error::other("size"))?;
            encode(&img)
        }
        (Modality::Depth, Image::U16(data)) => {
            let img: ImageBuffer<Luma<u16>, Vec<u16>> =
                ImageBuffer::from_raw(width, height, data.clone())
                    .ok_or_else(|| std::io::Error::other("size"))?;
            encode(&img)
        }
        (Modality::Normal, Image::F32 { data, .. }) => save_rgb(
            data.chunks_exact(3)
                .map(|n| {
                    n.iter()
                        .map(|v| ((v + 1.0) * 0.5 * 255.0).round() as u8)
                        .collect::<Vec<_>>()
                })
                .map(|v| [v[0], v[1], v[2]])
                .collect(),
        ),
        (_, Image::U16(d)) => save_rgb(d.iter().map(|&v| label_color(u32::from(v))).collect()),
        (_, Image::U32(d)) => save_rgb(d.iter().map(|&v| label_color(v)).collect()),
        (Modality::RoomClass, Image::U8 { data, .. }) => save_rgb(
            data.iter()
                .map(|&c| {
                    if c == 0 {
                        [0, 0, 0]
                    } else {
                        crate::scene::room_colors::ROOM_CLASS_COLORS[(c as usize).min(8)]
                    }
                })
                .collect(),
        ),
        _ => Err(std::io::Error::other(format!(
            "no PNG view of {modality:?} stored as {}",
            image.dtype().0
        ))),
    }
}
