//! Texture images for the colour sensor: decoding (PNG, JPEG), a bounded size, and sampling.
//!
//! Sampling is **bilinear with repeat wrap**, without mipmaps: texture coordinates follow the
//! OBJ/OpenGL convention of [`Mesh::uvs`](crate::scene::Mesh::uvs) (u to the right, v up,
//! (0, 0) the bottom-left corner of the image), and coordinates outside [0, 1] repeat. Images
//! are downscaled at load so that neither side exceeds [`MAX_TEXTURE_SIZE`] (aspect kept, a
//! triangle filter), which bounds memory to about 192 KiB per texture and acts as a fixed
//! pre-filter: the sensors' images are small (84²–256²), so finer texels would only alias.

use crate::file_error::FileError;
use std::path::{Path, PathBuf};

/// Largest side of a texture after loading (pixels).
pub const MAX_TEXTURE_SIZE: u32 = 256;

/// Why a texture could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum TextureError {
    /// The file could not be read.
    #[error(transparent)]
    Io(#[from] FileError),
    /// The file is not an image minos can decode (PNG or JPEG).
    #[error("{}: not a PNG or JPEG image", path.display())]
    Decode {
        /// The file.
        path: PathBuf,
        /// What the decoder said.
        #[source]
        source: TextureDecodeError,
    },
}

/// Why image bytes are not a texture.
#[derive(Debug, thiserror::Error)]
pub enum TextureDecodeError {
    /// The image crate could not decode them.
    #[error(transparent)]
    Image(#[from] image::ImageError),
    /// The image has no pixels.
    #[error("empty image")]
    Empty,
}

/// An RGB texture (sRGB bytes, rows from the top of the image).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Texture {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Texels, row-major from the top-left.
    pub texels: Vec<[u8; 3]>,
}

impl Texture {
    /// A texture from texels (row-major from the top-left); `None` when the sizes disagree or
    /// either side is zero.
    pub fn from_texels(width: u32, height: u32, texels: Vec<[u8; 3]>) -> Option<Texture> {
        (width > 0 && height > 0 && texels.len() == (width * height) as usize).then_some(Texture {
            width,
            height,
            texels,
        })
    }

    /// Decodes a PNG or JPEG file and downscales it to at most [`MAX_TEXTURE_SIZE`] per side.
    pub fn load(path: &Path) -> Result<Texture, TextureError> {
        let bytes =
            std::fs::read(path).map_err(|source| TextureError::Io(FileError::new(path, source)))?;
        Texture::decode(&bytes).map_err(|source| TextureError::Decode {
            path: path.to_path_buf(),
            source,
        })
    }

    /// Decodes PNG or JPEG bytes (format from the content) and downscales them to at most
    /// [`MAX_TEXTURE_SIZE`] per side.
    pub fn decode(bytes: &[u8]) -> Result<Texture, TextureDecodeError> {
        let img = image::load_from_memory(bytes)?;
        let (w, h) = (img.width(), img.height());
        if w == 0 || h == 0 {
            return Err(TextureDecodeError::Empty);
        }
        let img = if w.max(h) > MAX_TEXTURE_SIZE {
            let scale = MAX_TEXTURE_SIZE as f64 / w.max(h) as f64;
            let nw = ((w as f64 * scale).round() as u32).max(1);
            let nh = ((h as f64 * scale).round() as u32).max(1);
            img.resize_exact(nw, nh, image::imageops::FilterType::Triangle)
        } else {
            img
        };
        let rgb = img.to_rgb8();
        let (width, height) = rgb.dimensions();
        let texels = rgb.pixels().map(|p| p.0).collect();
        Ok(Texture {
            width,
            height,
            texels,
        })
    }

    /// Bilinear sample at `(u, v)` with repeat wrap, as RGB in [0, 1]; v = 0 is the bottom
    /// row of the image.
    pub fn sample(&self, u: f32, v: f32) -> [f32; 3] {
        if !u.is_finite() || !v.is_finite() || u.abs() > 1e6 || v.abs() > 1e6 {
            return self.texel(0, 0);
        }
        let (w, h) = (self.width, self.height);
        // Continuous texel coordinates of the wrapped coordinate, texel centres at i + 0.5
        // (rows from the top, so v is flipped). Truncating casts instead of `floor`, which
        // is a library call on baseline x86-64.
        let x = wrap01(u) * w as f32 - 0.5;
        let y = wrap01(1.0 - v) * h as f32 - 0.5;
        let (xi, yi) = (floor_small(x), floor_small(y));
        let (fx, fy) = (x - xi as f32, y - yi as f32);
        let index = |i: i32, n: u32| {
            if i < 0 {
                n - 1
            } else if i as u32 >= n {
                0
            } else {
                i as u32
            }
        };
        let (xa, xb) = (index(xi, w), index(xi + 1, w));
        let (ya, yb) = (index(yi, h), index(yi + 1, h));
        let (a, b, c, d) = (
            self.texel(xa, ya),
            self.texel(xb, ya),
            self.texel(xa, yb),
            self.texel(xb, yb),
        );
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            top + (bottom - top) * fy
        })
    }

    /// One texel as RGB in [0, 1].
    fn texel(&self, x: u32, y: u32) -> [f32; 3] {
        self.texels[(y * self.width + x) as usize].map(|c| f32::from(c) / 255.0)
    }
}

/// `t` wrapped into [0, 1] (|t| ≤ 1e6).
#[inline]
fn wrap01(t: f32) -> f32 {
    let f = t - (t as i32) as f32;
    if f < 0.0 {
        f + 1.0
    } else {
        f
    }
}

/// ⌊x⌋ for x ≥ −1 (texel coordinates of a wrapped coordinate).
#[inline]
fn floor_small(x: f32) -> i32 {
    if x < 0.0 {
        -1
    } else {
        x as i32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker() -> Texture {
        // Top row red, green; bottom row blue, white.
        Texture::from_texels(
            2,
            2,
            vec![[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]],
        )
        .unwrap()
    }

    #[test]
    fn texel_centres_sample_exactly_with_v_up_and_repeat() {
        let t = checker();
        assert_eq!(t.sample(0.25, 0.75), [1.0, 0.0, 0.0], "top-left is red");
        assert_eq!(t.sample(0.75, 0.75), [0.0, 1.0, 0.0]);
        assert_eq!(t.sample(0.25, 0.25), [0.0, 0.0, 1.0], "v = 0 is the bottom");
        assert_eq!(t.sample(1.25, -0.75), [0.0, 0.0, 1.0], "coordinates repeat");
        // Halfway between red and green texels: an even mix.
        let mid = t.sample(0.5, 0.75);
        assert!((mid[0] - 0.5).abs() < 1e-6 && (mid[1] - 0.5).abs() < 1e-6);
        // Across the wrap seam: u = 0 mixes the left and right columns.
        let seam = t.sample(0.0, 0.75);
        assert!((seam[0] - 0.5).abs() < 1e-6 && (seam[1] - 0.5).abs() < 1e-6);
    }

    #[test]
    fn large_images_are_downscaled_and_garbage_is_an_error() {
        let img = image::RgbImage::from_pixel(1024, 512, image::Rgb([10, 200, 30]));
        let mut png = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        let t = Texture::decode(&png).unwrap();
        assert_eq!((t.width, t.height), (256, 128));
        assert_eq!(t.texels[0], [10, 200, 30]);
        assert!(matches!(
            Texture::decode(b"not an image"),
            Err(TextureDecodeError::Image(_))
        ));
        let e = Texture::load(Path::new("/nonexistent/x.png")).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/x.png"), "{e}");
    }
}
