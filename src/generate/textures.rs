//! Small procedural textures for generated houses (wood planks, tiles, a checker), computed
//! from integer hashes alone so every run writes the same PNG bytes. They are light,
//! nearly neutral patterns: the material colour they are multiplied with keeps the hue.

use std::io;
use std::path::Path;

use crate::atomic::write_bytes_atomic;

/// A procedural texture: its file stem under `texture/` and how to draw it.
#[derive(Debug, Clone, Copy)]
pub struct ProceduralTexture {
    /// File stem (`texture/<name>.png`).
    pub name: &'static str,
    /// Side in pixels (square).
    pub size: u32,
    draw: fn(u32, u32) -> [u8; 3],
}

/// Wood planks running along v (four planks across, grain and per-plank tone).
pub const WOOD: ProceduralTexture = ProceduralTexture {
    name: "g_wood_planks",
    size: 128,
    draw: wood,
};
/// Square tiles with grout lines (4 × 4).
pub const TILES: ProceduralTexture = ProceduralTexture {
    name: "g_tiles",
    size: 64,
    draw: tiles,
};
/// A light/dark checker (8 × 8 squares).
pub const CHECKER: ProceduralTexture = ProceduralTexture {
    name: "g_checker",
    size: 64,
    draw: checker,
};

/// Every texture generated houses use.
pub const ALL: [ProceduralTexture; 3] = [WOOD, TILES, CHECKER];

impl ProceduralTexture {
    /// The path an MTL next to a room or object mesh uses for it
    /// (`room/<house>/` and `object/<model>/` sit two levels below the dataset root).
    pub fn mtl_path(&self) -> String {
        format!("../../texture/{}.png", self.name)
    }

    /// The RGB image, row-major from the top-left.
    pub fn pixels(&self) -> image::RgbImage {
        image::RgbImage::from_fn(self.size, self.size, |x, y| image::Rgb((self.draw)(x, y)))
    }

    /// PNG bytes (deterministic: fixed encoder settings, no metadata).
    pub fn png(&self) -> io::Result<Vec<u8>> {
        let mut out = Vec::new();
        self.pixels()
            .write_to(&mut io::Cursor::new(&mut out), image::ImageFormat::Png)
            .map_err(io::Error::other)?;
        Ok(out)
    }
}

/// Writes every procedural texture to `root/texture/` atomically.
pub fn write_textures(root: &Path) -> io::Result<()> {
    for t in ALL {
        write_bytes_atomic(
            &root.join("texture").join(format!("{}.png", t.name)),
            &t.png()?,
        )?;
    }
    Ok(())
}

/// A 32-bit integer hash (lowbias32), uniform enough for texture noise.
fn hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Hash of two integers as a value in [0, 1).
fn noise(a: u32, b: u32) -> f64 {
    f64::from(hash(a.wrapping_mul(0x9e37_79b9) ^ hash(b)) >> 8) / f64::from(1u32 << 24)
}

fn grey(v: f64) -> [u8; 3] {
    let c = (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    [c, c, c]
}

fn wood(x: u32, y: u32) -> [u8; 3] {
    let plank = x / 32;
    // Planks are staggered: each has a seam at its own offset along v.
    let seam_at = (noise(plank, 7) * 128.0) as u32;
    if x.is_multiple_of(32) || (y + 128 - seam_at).is_multiple_of(128) {
        return grey(0.55);
    }
    let tone = 0.82 + 0.14 * noise(plank, 1);
    // Grain: thin stripes along v (a triangle wave, so no libm call can change a byte) whose
    // phase wanders with a per-column hash.
    let phase = (f64::from(x) * 0.15 + 0.3 * noise(x, plank)).fract();
    let grain = 0.06 * (2.0 * phase - 1.0).abs() + 0.03 * noise(x, y / 8);
    let v = tone - grain;
    let to_u8 = |k: f64| (v * k * 255.0).clamp(0.0, 255.0).round() as u8;
    [to_u8(1.0), to_u8(0.97), to_u8(0.93)]
}

fn tiles(x: u32, y: u32) -> [u8; 3] {
    if x.is_multiple_of(16) || y.is_multiple_of(16) {
        return grey(0.62);
    }
    let tile = (x / 16) + 4 * (y / 16);
    grey(0.93 + 0.05 * noise(tile, 3) - 0.02 * noise(x, y))
}

fn checker(x: u32, y: u32) -> [u8; 3] {
    if ((x / 8) + (y / 8)).is_multiple_of(2) {
        grey(0.95)
    } else {
        grey(0.45)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn textures_are_deterministic_light_patterns() {
        for t in ALL {
            let a = t.png().unwrap();
            assert_eq!(a, t.png().unwrap(), "{} bytes differ between runs", t.name);
            let img = t.pixels();
            let mean =
                img.pixels().map(|p| f64::from(p.0[0])).sum::<f64>() / f64::from(t.size * t.size);
            assert!((100.0..250.0).contains(&mean), "{}: mean {mean}", t.name);
            // Not a flat colour.
            assert!(img.pixels().any(|p| p != img.get_pixel(1, 1)), "{}", t.name);
        }
        assert_eq!(checker(0, 0), [242, 242, 242]);
        assert_eq!(checker(8, 0), [115, 115, 115]);
    }
}
