//! The baked grid file `DATA/nav/<scene>[@variant].nav` (layout in `docs/FORMATS.md`):
//! magic `MINOSNAV`, a u32 format version, a postcard-encoded header (everything but the
//! per-span arrays), then `column_start`, the spans and `span_objects` as fixed-width
//! little-endian records. The bulk arrays are decoded straight from the file in chunks, with
//! no varints and no intermediate copy of the whole file: reading a 55k-span grid takes about
//! 0.4 ms where version 1 (all postcard) took about 1.8 ms (`cargo bench --bench episodes`).

use std::io::Read;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::io::atomic::write_bytes_atomic;

use super::grid::{Island, NavGrid, NavObject, NavRoom, Span};
use super::params::NavParams;

/// First bytes of every `.nav` file.
pub const MAGIC: &[u8; 8] = b"MINOSNAV";
/// Bumped whenever the encoding of [`NavGrid`] changes (2: fixed-width span arrays).
pub const FORMAT_VERSION: u32 = 2;
/// Bytes of one span record.
pub const SPAN_BYTES: usize = 56;

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

/// What the header says (the grid without its per-span arrays), as written.
#[derive(Serialize)]
struct HeaderOut<'a> {
    scene: &'a str,
    params: &'a NavParams,
    x0: f32,
    z0: f32,
    nx: u32,
    nz: u32,
    rooms: &'a [NavRoom],
    objects: &'a [NavObject],
    islands: &'a [Island],
    level_heights: &'a [f32],
    columns: u64,
    spans: u64,
    span_objects: u64,
}

/// The header as read (same fields as [`HeaderOut`], owned).
#[derive(Deserialize)]
struct HeaderIn {
    scene: String,
    params: NavParams,
    x0: f32,
    z0: f32,
    nx: u32,
    nz: u32,
    rooms: Vec<NavRoom>,
    objects: Vec<NavObject>,
    islands: Vec<Island>,
    level_heights: Vec<f32>,
    columns: u64,
    spans: u64,
    span_objects: u64,
}

/// Appends a span's fixed-width record.
fn put_span(out: &mut Vec<u8>, s: &Span) {
    out.extend_from_slice(&s.y.to_le_bytes());
    out.extend_from_slice(&s.headroom.to_le_bytes());
    out.extend_from_slice(&s.clearance.to_le_bytes());
    for l in s.links {
        out.extend_from_slice(&l.to_le_bytes());
    }
    out.extend_from_slice(&s.room.to_le_bytes());
    out.extend_from_slice(&s.island.to_le_bytes());
    out.extend_from_slice(&s.level.to_le_bytes());
    out.push(u8::from(s.walkable));
    out.push(0);
}

/// Little-endian u32 at `at` of a record.
#[inline(always)]
fn u32_at<const N: usize>(r: &[u8; N], at: usize) -> u32 {
    u32::from_le_bytes([r[at], r[at + 1], r[at + 2], r[at + 3]])
}

/// Decodes a span record (any non-zero walkable byte reads as walkable; [`span_ok`] checks
/// it).
#[inline(always)]
fn get_span(r: &[u8; SPAN_BYTES]) -> Span {
    let mut links = [0u32; 8];
    for (d, l) in links.iter_mut().enumerate() {
        *l = u32_at(r, 12 + 4 * d);
    }
    Span {
        y: f32::from_bits(u32_at(r, 0)),
        headroom: f32::from_bits(u32_at(r, 4)),
        clearance: f32::from_bits(u32_at(r, 8)),
        links,
        walkable: r[54] != 0,
        room: u32_at(r, 44),
        island: u32_at(r, 48),
        level: u16::from_le_bytes([r[52], r[53]]),
    }
}

/// Is a span record's walkable byte 0 or 1?
#[inline(always)]
fn span_ok(r: &[u8; SPAN_BYTES]) -> bool {
    r[54] <= 1
}

/// The bytes of a grid's file.
fn encode(grid: &NavGrid) -> Result<Vec<u8>, postcard::Error> {
    let header = postcard::to_stdvec(&HeaderOut {
        scene: &grid.scene,
        params: &grid.params,
        x0: grid.x0,
        z0: grid.z0,
        nx: grid.nx,
        nz: grid.nz,
        rooms: &grid.rooms,
        objects: &grid.objects,
        islands: &grid.islands,
        level_heights: &grid.level_heights,
        columns: grid.column_start.len() as u64,
        spans: grid.spans.len() as u64,
        span_objects: grid.span_objects.len() as u64,
    })?;
    let mut bytes = Vec::with_capacity(
        16 + header.len()
            + 4 * grid.column_start.len()
            + SPAN_BYTES * grid.spans.len()
            + 8 * grid.span_objects.len(),
    );
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    bytes.extend_from_slice(&(header.len() as u32).to_le_bytes());
    bytes.extend_from_slice(&header);
    for c in &grid.column_start {
        bytes.extend_from_slice(&c.to_le_bytes());
    }
    for s in &grid.spans {
        put_span(&mut bytes, s);
    }
    for (s, o) in &grid.span_objects {
        bytes.extend_from_slice(&s.to_le_bytes());
        bytes.extend_from_slice(&o.to_le_bytes());
    }
    Ok(bytes)
}

/// Writes a grid atomically.
pub fn write_nav(path: &Path, grid: &NavGrid) -> Result<(), NavFileError> {
    let bytes = encode(grid).map_err(|e| NavFileError::Format {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    write_bytes_atomic(path, &bytes).map_err(|cause| NavFileError::Io {
        path: path.to_path_buf(),
        cause,
    })
}

/// Why a read failed, before the path is attached.
enum ReadError {
    Io(std::io::Error),
    Format(String),
}

impl From<std::io::Error> for ReadError {
    fn from(e: std::io::Error) -> Self {
        if e.kind() == std::io::ErrorKind::UnexpectedEof {
            ReadError::Format("corrupt: the file ends early".into())
        } else {
            ReadError::Io(e)
        }
    }
}

/// Records decoded per chunk read from the file.
const CHUNK_RECORDS: usize = 1024;

/// Reads `count` fixed-width records of `N` bytes in chunks, decoding each with `f`; fails
/// when `ok` rejects one.
fn read_records<const N: usize, T>(
    r: &mut impl Read,
    count: u64,
    f: impl Fn(&[u8; N]) -> T,
    ok: impl Fn(&[u8; N]) -> bool,
    what: &str,
) -> Result<Vec<T>, ReadError> {
    let count = usize::try_from(count)
        .map_err(|_| ReadError::Format(format!("corrupt: {count} {what}s")))?;
    // The count is checked against the file's length before this is called, so the
    // reservation is bounded by the file's size.
    let mut out = Vec::with_capacity(count);
    let mut buf = vec![0u8; N * CHUNK_RECORDS.min(count.max(1))];
    let mut left = count;
    let mut good = true;
    while left > 0 {
        let k = left.min(CHUNK_RECORDS);
        let chunk = &mut buf[..N * k];
        r.read_exact(chunk)?;
        let (records, _) = chunk.as_chunks::<N>();
        good &= records.iter().fold(true, |g, rec| g & ok(rec));
        out.extend(records.iter().map(&f));
        left -= k;
    }
    if !good {
        return Err(ReadError::Format(format!("corrupt: bad {what}")));
    }
    Ok(out)
}

/// Reads a grid. Files of another format version are refused with a message asking for a
/// rebake.
pub fn read_nav(path: &Path) -> Result<NavGrid, NavFileError> {
    let file = std::fs::File::open(path).map_err(|cause| NavFileError::Io {
        path: path.to_path_buf(),
        cause,
    })?;
    let grid = file
        .metadata()
        .map_err(ReadError::Io)
        .and_then(|m| read_from(file, m.len()));
    grid.map_err(|e| match e {
        ReadError::Io(cause) => NavFileError::Io {
            path: path.to_path_buf(),
            cause,
        },
        ReadError::Format(message) => NavFileError::Format {
            path: path.to_path_buf(),
            message,
        },
    })
}

/// Decodes a grid file of `len` bytes from `file`.
fn read_from(file: std::fs::File, len: u64) -> Result<NavGrid, ReadError> {
    let mut r = std::io::BufReader::with_capacity(1 << 16, file);
    let mut head = [0u8; 16];
    r.read_exact(&mut head[..12])
        .map_err(|_| ReadError::Format("not a minos navigation grid (too short)".into()))?;
    if &head[..8] != MAGIC {
        return Err(ReadError::Format(
            "not a minos navigation grid (bad magic)".into(),
        ));
    }
    let version = u32::from_le_bytes([head[8], head[9], head[10], head[11]]);
    if version != FORMAT_VERSION {
        return Err(ReadError::Format(format!(
            "navigation grid format version {version}, this minos reads version \
             {FORMAT_VERSION}: rebake it (`minos bake`; `--variant NAME` for a variant's grid)"
        )));
    }
    r.read_exact(&mut head[12..16])?;
    let header_len = u32::from_le_bytes([head[12], head[13], head[14], head[15]]);
    if u64::from(header_len) > len.saturating_sub(16) {
        return Err(ReadError::Format("corrupt: header length".into()));
    }
    let mut header = vec![0u8; header_len as usize];
    r.read_exact(&mut header)?;
    let h: HeaderIn =
        postcard::from_bytes(&header).map_err(|e| ReadError::Format(format!("corrupt: {e}")))?;
    let body = h
        .columns
        .checked_mul(4)
        .zip(h.spans.checked_mul(SPAN_BYTES as u64))
        .zip(h.span_objects.checked_mul(8))
        .and_then(|((a, b), c)| a.checked_add(b)?.checked_add(c));
    if body.is_none() || body != len.checked_sub(16 + u64::from(header_len)) {
        return Err(ReadError::Format(
            "corrupt: array lengths do not match the file's size".into(),
        ));
    }
    if h.columns != u64::from(h.nx) * u64::from(h.nz) + 1 {
        return Err(ReadError::Format(format!(
            "corrupt: {} column starts for {} x {} columns",
            h.columns, h.nx, h.nz
        )));
    }
    let column_start = read_records::<4, u32>(
        &mut r,
        h.columns,
        |b| u32::from_le_bytes(*b),
        |_| true,
        "column start",
    )?;
    if column_start.last().map(|&c| u64::from(c)) != Some(h.spans)
        || column_start.windows(2).any(|w| w[0] > w[1])
    {
        return Err(ReadError::Format(
            "corrupt: column starts do not cover the spans in order".into(),
        ));
    }
    let spans = read_records::<SPAN_BYTES, Span>(&mut r, h.spans, get_span, span_ok, "span")?;
    let span_objects = read_records::<8, (u32, u32)>(
        &mut r,
        h.span_objects,
        |b| (u32_at(b, 0), u32_at(b, 4)),
        |_| true,
        "span object",
    )?;
    Ok(NavGrid {
        scene: h.scene,
        params: h.params,
        x0: h.x0,
        z0: h.z0,
        nx: h.nx,
        nz: h.nz,
        column_start,
        spans,
        rooms: h.rooms,
        objects: h.objects,
        span_objects,
        islands: h.islands,
        level_heights: h.level_heights,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::navmesh::testmaps::MapSpec;

    fn grid() -> NavGrid {
        let rows = [
            "##########",
            "#aaaa*aaa#",
            "#aaaaDbbb#",
            "#aaaaabbb#",
            "##########",
        ];
        MapSpec::ascii(&rows, 0.1).build(NavParams::default())
    }

    #[test]
    fn grids_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.nav");
        let g = grid();
        assert!(!g.span_objects.is_empty());
        write_nav(&path, &g).unwrap();
        assert_eq!(read_nav(&path).unwrap(), g);
    }

    #[test]
    fn old_versions_and_corrupt_files_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.nav");
        let bytes = encode(&grid()).unwrap();
        let mut old = bytes.clone();
        old[8..12].copy_from_slice(&1u32.to_le_bytes());
        std::fs::write(&path, &old).unwrap();
        let e = read_nav(&path).unwrap_err().to_string();
        assert!(e.contains("version 1") && e.contains("minos bake"), "{e}");
        assert!(!e.contains('\n'), "{e}");
        std::fs::write(&path, &bytes[..bytes.len() - 3]).unwrap();
        let e = read_nav(&path).unwrap_err().to_string();
        assert!(e.contains("corrupt"), "{e}");
        std::fs::write(&path, b"MINOSNAV").unwrap();
        assert!(read_nav(&path).is_err());
        std::fs::write(&path, b"something else entirely").unwrap();
        assert!(read_nav(&path).unwrap_err().to_string().contains("magic"));
        // A span whose walkable byte is not 0 or 1.
        let mut bad = bytes.clone();
        let g = grid();
        let at = bytes.len() - 8 * g.span_objects.len() - SPAN_BYTES + 54;
        bad[at] = 7;
        std::fs::write(&path, &bad).unwrap();
        assert!(read_nav(&path)
            .unwrap_err()
            .to_string()
            .contains("bad span"));
    }
}
