//! Helpers shared by the episode importers ([`super::habitat`], [`super::minos_csv`]): opening
//! possibly compressed text files, the defaults for fields a foreign format lacks, and the
//! yaw ↔ quaternion conversion of the conventions (`[x, y, z, w] = [0, sin(yaw/2), 0,
//! cos(yaw/2)]`).
//!
//! This module knows no file layout; the importers decide what a missing field means and call
//! the defaults here so that both formats agree.

use std::fs::File;
use std::io::{self, BufRead, BufReader, Read};
use std::path::Path;

use super::Difficulty;

/// Step limit given to imported episodes whose source has none.
pub const DEFAULT_MAX_STEPS: u32 = 500;

/// Geodesic distance (m) below which an imported episode without a difficulty is `easy`.
pub const EASY_BELOW_M: f32 = 3.0;

/// Geodesic distance (m) below which an imported episode without a difficulty is `medium`
/// (and from which it is `hard`).
pub const MEDIUM_BELOW_M: f32 = 6.0;

/// The difficulty of an imported episode whose source gives none: `easy` below
/// [`EASY_BELOW_M`] of geodesic distance, `medium` below [`MEDIUM_BELOW_M`], `hard` from
/// there; `medium` when the geodesic distance is unknown (NaN or infinite).
pub fn difficulty_for_geodesic(geodesic: f32) -> Difficulty {
    if !geodesic.is_finite() {
        Difficulty::Medium
    } else if geodesic < EASY_BELOW_M {
        Difficulty::Easy
    } else if geodesic < MEDIUM_BELOW_M {
        Difficulty::Medium
    } else {
        Difficulty::Hard
    }
}

/// Straight-line distance between two points, computed in f64.
pub fn distance(a: [f32; 3], b: [f32; 3]) -> f32 {
    let d: f64 = (0..3)
        .map(|i| {
            let t = f64::from(a[i]) - f64::from(b[i]);
            t * t
        })
        .sum();
    d.sqrt() as f32
}

/// Habitat's `start_rotation` for a yaw: `[x, y, z, w] = [0, sin(yaw/2), 0, cos(yaw/2)]`.
pub fn yaw_to_quaternion(yaw: f32) -> [f64; 4] {
    let half = f64::from(yaw) / 2.0;
    [0.0, half.sin(), 0.0, half.cos()]
}

/// The yaw (radians, CCW about +Y, 0 faces −Z) of a rotation about +Y given by its `y` and `w`
/// quaternion components, wrapped to `(−π, π]`.
pub fn yaw_from_y_w(y: f64, w: f64) -> f32 {
    let mut yaw = 2.0 * y.atan2(w);
    if yaw > std::f64::consts::PI {
        yaw -= std::f64::consts::TAU;
    } else if yaw <= -std::f64::consts::PI {
        yaw += std::f64::consts::TAU;
    }
    yaw as f32
}

/// Which compression a file uses, told by its first bytes (not its name).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    /// Plain text.
    None,
    /// gzip (`1f 8b`).
    Gzip,
    /// bzip2 (`BZh`).
    Bzip2,
}

/// Opens `path` for buffered reading, decompressing gzip or bzip2 (detected from the magic
/// bytes) on the fly; plain files are read as they are.
pub fn open_text(path: &Path) -> io::Result<(Box<dyn BufRead>, Compression)> {
    let mut file = BufReader::with_capacity(1 << 16, File::open(path)?);
    let head = file.fill_buf()?;
    let kind = if head.starts_with(&[0x1f, 0x8b]) {
        Compression::Gzip
    } else if head.starts_with(b"BZh") {
        Compression::Bzip2
    } else {
        Compression::None
    };
    let reader: Box<dyn BufRead> = match kind {
        Compression::None => Box::new(file),
        Compression::Gzip => Box::new(BufReader::with_capacity(
            1 << 16,
            flate2::bufread::MultiGzDecoder::new(file),
        )),
        Compression::Bzip2 => Box::new(BufReader::with_capacity(
            1 << 16,
            bzip2::bufread::MultiBzDecoder::new(file),
        )),
    };
    Ok((reader, kind))
}

/// Reads the whole (decompressed) content of `path`.
pub fn read_text_bytes(path: &Path) -> io::Result<Vec<u8>> {
    let (mut r, _) = open_text(path)?;
    let mut bytes = Vec::new();
    r.read_to_end(&mut bytes)?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn difficulty_thresholds_and_unknown_distance() {
        assert_eq!(difficulty_for_geodesic(2.99), Difficulty::Easy);
        assert_eq!(difficulty_for_geodesic(3.0), Difficulty::Medium);
        assert_eq!(difficulty_for_geodesic(5.99), Difficulty::Medium);
        assert_eq!(difficulty_for_geodesic(6.0), Difficulty::Hard);
        assert_eq!(difficulty_for_geodesic(f32::NAN), Difficulty::Medium);
    }

    #[test]
    fn yaw_quaternion_round_trip_wraps_to_half_open_interval() {
        for yaw in [0.0f32, 0.5, -1.0, 3.0, -3.0, std::f32::consts::PI] {
            let q = yaw_to_quaternion(yaw);
            assert_eq!((q[0], q[2]), (0.0, 0.0));
            let back = yaw_from_y_w(q[1], q[3]);
            assert!(back > -std::f32::consts::PI && back <= std::f32::consts::PI);
            let d = (back - yaw).rem_euclid(std::f32::consts::TAU);
            assert!(d.min(std::f32::consts::TAU - d) < 1e-6, "{yaw} -> {back}");
        }
        // 3π/2 comes back as −π/2.
        let q = yaw_to_quaternion(1.5 * std::f32::consts::PI);
        assert!((yaw_from_y_w(q[1], q[3]) + std::f32::consts::FRAC_PI_2).abs() < 1e-6);
    }

    #[test]
    fn compression_is_detected_from_content() {
        let dir = tempfile::tempdir().unwrap();
        let text = b"a,b\n1,2\n";
        let plain = dir.path().join("x.csv.gz"); // misleading name: content decides
        std::fs::write(&plain, text).unwrap();
        let gz = dir.path().join("x.bin");
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        e.write_all(text).unwrap();
        std::fs::write(&gz, e.finish().unwrap()).unwrap();
        let bz = dir.path().join("y.bin");
        let mut e = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::default());
        e.write_all(text).unwrap();
        std::fs::write(&bz, e.finish().unwrap()).unwrap();
        for (p, kind) in [
            (&plain, Compression::None),
            (&gz, Compression::Gzip),
            (&bz, Compression::Bzip2),
        ] {
            assert_eq!(open_text(p).unwrap().1, kind);
            assert_eq!(read_text_bytes(p).unwrap(), text);
        }
    }
}
