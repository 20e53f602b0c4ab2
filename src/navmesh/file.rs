//! The baked grid file `DATA/nav/<scene>[@variant].nav` (layout in `docs/FORMATS.md`):
//! magic `MINOSNAV`, a u32 format version, then the postcard-encoded [`NavGrid`].

use std::path::{Path, PathBuf};

use crate::io::atomic::write_bytes_atomic;

use super::grid::NavGrid;

/// First bytes of every `.nav` file.
pub const MAGIC: &[u8; 8] = b"MINOSNAV";
/// Bumped whenever the encoding of [`NavGrid`] changes.
pub const FORMAT_VERSION: u32 = 1;

/// Errors reading or writing `.nav` files.
#[derive(Debug, thiserror::Error)]
pub enum NavFileError {
    /// File system error.
    #[error("{}: {cause}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        cause: std::io::Error,
    },
    /// Not a `.nav` file of this version, or corrupt.
    #[error("{}: {message}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// Where a scene's grid lives in a DATA folder.
pub fn nav_path(data: &Path, scene: &str) -> PathBuf {
    data.join("nav").join(format!("{scene}.nav"))
}

/// Writes a grid atomically.
pub fn write_nav(path: &Path, grid: &NavGrid) -> Result<(), NavFileError> {
    let body = postcard::to_stdvec(grid).map_err(|e| NavFileError::Format {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let mut bytes = Vec::with_capacity(12 + body.len());
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    bytes.extend_from_slice(&body);
    write_bytes_atomic(path, &bytes).map_err(|cause| NavFileError::Io {
        path: path.to_path_buf(),
        cause,
    })
}

/// Reads a grid.
pub fn read_nav(path: &Path) -> Result<NavGrid, NavFileError> {
    let bytes = std::fs::read(path).map_err(|cause| NavFileError::Io {
        path: path.to_path_buf(),
        cause,
    })?;
    let bad = |m: String| NavFileError::Format {
        path: path.to_path_buf(),
        message: m,
    };
    if bytes.len() < 12 || &bytes[..8] != MAGIC {
        return Err(bad("not a minos navigation grid (bad magic)".into()));
    }
    let version = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
    if version != FORMAT_VERSION {
        return Err(bad(format!(
            "format version {version}, this minos reads {FORMAT_VERSION} (re-run bake)"
        )));
    }
    postcard::from_bytes(&bytes[12..]).map_err(|e| bad(format!("corrupt: {e}")))
}
