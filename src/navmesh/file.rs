//! The baked grid file `DATA/nav/<scene>[@variant].nav` (layout in `docs/FORMATS.md`):
//! magic `MINOSNAV`, a u32 format version, a postcard-encoded header (everything but the
//! per-span arrays), then `column_start`, the spans and `span_objects` as fixed-width
//! little-endian records. The bulk arrays are decoded straight from the file in chunks, with
//! no varints and no intermediate copy of the whole file: reading a 55k-span grid takes about
//! 0.4 ms where version 1 (all postcard) took about 1.8 ms (`cargo bench --bench episodes`).
//!
//! Version 3 adds, after the arrays, sections of query structures derived from the grid at
//! bake time, as Detour bakes its query structures into a navmesh: the
//! `los::SightIndex`'s clear squares (4 bytes per span), and the sparse
//! graph's edges and landmark distances ([`SparseEdges`], a few kB), each with its counts and
//! a 64-bit [`checksum`]. Reading puts them in [`NavGrid::baked`], where
//! `los::SightIndex::new` (and so every `Geodesic`) picks up the
//! squares instead of redoing the sweep (about 0.8 ms of a 55k-span grid's 1.45 ms
//! `Geodesic::new`), and the first path query's graph build takes the edges instead of
//! walking between every pair of vertices (about 0.45 ms). A section whose counts, checksum
//! or indices do not check out is dropped with one warning and rebuilt in memory; a file
//! whose lengths do not add up is refused as corrupt. Writing always recomputes the sections
//! from the grid, so the bytes depend on the grid alone (about 3 ms more per 55k-span grid).
//!
//! Version 4 adds, after the sparse graph, its labels ([`SparseLabels`]: per-span region or
//! zone, the vertices, the portals and their gates; about 4 bytes per span), checked with
//! [`SparseLabels::fits`], so that the first path query's graph build skips the plateau and
//! zone labelling, the gate and portal search and the vertex scan as well; it only derives
//! the per-span roles and the zone sizes from the areas, and the vertices' corners and the
//! portals' boxes from the grid (about 0.1 ms instead of 1 ms on the episode bench's houses,
//! for about 0.1 ms more reading).

use crate::file_error::FileError;
use std::io::Read;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::atomic::write_bytes_atomic;

use super::geodesic::Geodesic;
use super::grid::{
    Baked, Island, NavGrid, NavObject, NavRoom, Span, SparseEdges, SparseLabels, SPARSE_LANDMARKS,
};
use super::params::NavParams;

/// First bytes of every `.nav` file.
pub const MAGIC: &[u8; 8] = b"MINOSNAV";
/// Bumped whenever the encoding of [`NavGrid`] changes (2: fixed-width span arrays; 3: the
/// stored line-of-sight squares and sparse graph edges after them; 4: the sparse graph's
/// labels after those; 5: a checksum of the header and the grid's arrays after the header
/// length).
pub const FORMAT_VERSION: u32 = 5;
/// Bytes before the header: magic, version, header length, the grid's checksum.
const PREFIX: usize = 24;
/// Bytes of one span record.
pub const SPAN_BYTES: usize = 56;

/// Errors reading or writing `.nav` files.
#[derive(Debug, thiserror::Error)]
pub enum NavFileError {
    /// File system error.
    #[error(transparent)]
    Io(#[from] FileError),
    /// Not a `.nav` file of this version, or corrupt.
    #[error("{}: {message}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
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

/// Bytes of one stored clear-square record (one per span).
pub const SQUARES_BYTES: usize = 4;

/// 64-bit checksum of a stored section: words of 8 bytes (then the remaining bytes) folded
/// in by xor, multiplication by an odd constant and rotation. Every step is a bijection of
/// the state, so changing any one word always changes the result; about a cycle per byte.
pub fn checksum(bytes: &[u8]) -> u64 {
    let mut c = Checksum::new(bytes.len() as u64);
    c.update(bytes);
    c.finish()
}

/// [`checksum`] of `len` bytes fed in pieces of any size (the grid's arrays are hashed as
/// they are read, with no copy of the whole file).
#[derive(Debug, Clone)]
pub struct Checksum {
    h: u64,
    pending: [u8; 8],
    n: usize,
}

impl Checksum {
    const K: u64 = 0x9E37_79B9_7F4A_7C15;

    /// A checksum of `len` bytes in all.
    pub fn new(len: u64) -> Self {
        Checksum {
            h: 0xCBF2_9CE4_8422_2325 ^ len,
            pending: [0; 8],
            n: 0,
        }
    }

    fn word(&mut self, w: u64) {
        self.h = (self.h ^ w).wrapping_mul(Self::K).rotate_left(29);
    }

    /// Feeds the next bytes.
    pub fn update(&mut self, mut bytes: &[u8]) {
        if self.n > 0 {
            let k = (8 - self.n).min(bytes.len());
            self.pending[self.n..self.n + k].copy_from_slice(&bytes[..k]);
            self.n += k;
            bytes = &bytes[k..];
            if self.n < 8 {
                return;
            }
            self.word(u64::from_le_bytes(self.pending));
            self.n = 0;
        }
        let (words, rest) = bytes.as_chunks::<8>();
        for w in words {
            self.word(u64::from_le_bytes(*w));
        }
        self.pending[..rest.len()].copy_from_slice(rest);
        self.n = rest.len();
    }

    /// The checksum of every byte fed.
    pub fn finish(self) -> u64 {
        let mut h = self.h;
        for &b in &self.pending[..self.n] {
            h = (h ^ u64::from(b)).wrapping_mul(Self::K).rotate_left(29);
        }
        h ^ (h >> 32)
    }
}

/// The stored sections of a grid, built from the grid alone (whatever it carries in
/// [`NavGrid::baked`]): the records of `los::SightIndex::squares`, and those of the sparse graph's
/// edges (`first`, `edges`, `marks`) with its vertex and edge counts when it has one.
#[allow(clippy::type_complexity)]
fn stored_sections(
    grid: &NavGrid,
) -> (
    Vec<u8>,
    Option<(u64, u64, Vec<u8>)>,
    Option<([u64; 4], Vec<u8>)>,
) {
    let bare;
    let grid = if grid.baked.sight_squares.is_empty()
        && grid.baked.sparse_edges.is_none()
        && grid.baked.sparse_labels.is_none()
    {
        grid
    } else {
        bare = NavGrid {
            baked: Baked::default(),
            ..grid.clone()
        };
        &bare
    };
    let geo = Geodesic::new(grid);
    let squares = geo.sight().squares();
    let mut records = Vec::with_capacity(SQUARES_BYTES * squares.len());
    for a in &squares {
        records.extend_from_slice(a);
    }
    let graph = geo.sparse_edges().map(|g| {
        let mut out = Vec::with_capacity(
            4 * g.first.len() + 8 * g.edges.len() + 4 * SPARSE_LANDMARKS * g.marks.len(),
        );
        for f in &g.first {
            out.extend_from_slice(&f.to_le_bytes());
        }
        for (v, l) in &g.edges {
            out.extend_from_slice(&v.to_le_bytes());
            out.extend_from_slice(&l.to_le_bytes());
        }
        for d in g.marks.iter().flatten() {
            out.extend_from_slice(&d.to_le_bytes());
        }
        (g.marks.len() as u64, g.edges.len() as u64, out)
    });
    let labels = geo.sparse_labels().map(|l| {
        let counts = [
            l.area.len(),
            l.verts.len(),
            l.portals.len(),
            l.portal_gates.len(),
        ];
        let mut out = Vec::with_capacity(4 * (counts[0] + counts[1]) + 8 * (counts[2] + counts[3]));
        for a in l.area.iter().chain(&l.verts) {
            out.extend_from_slice(&a.to_le_bytes());
        }
        for (a, b) in l.portals.iter().chain(&l.portal_gates) {
            out.extend_from_slice(&a.to_le_bytes());
            out.extend_from_slice(&b.to_le_bytes());
        }
        (counts.map(|c| c as u64), out)
    });
    (records, graph, labels)
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
        PREFIX
            + header.len()
            + 4 * grid.column_start.len()
            + SPAN_BYTES * grid.spans.len()
            + 8 * grid.span_objects.len(),
    );
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    bytes.extend_from_slice(&(header.len() as u32).to_le_bytes());
    bytes.extend_from_slice(&[0; 8]);
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
    let sum = checksum(&bytes[PREFIX..]);
    bytes[16..PREFIX].copy_from_slice(&sum.to_le_bytes());
    let (squares, graph, labels) = stored_sections(grid);
    bytes.extend_from_slice(&(grid.spans.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&checksum(&squares).to_le_bytes());
    bytes.extend_from_slice(&squares);
    if let Some((vertices, edges, records)) = graph {
        bytes.extend_from_slice(&vertices.to_le_bytes());
        bytes.extend_from_slice(&edges.to_le_bytes());
        bytes.extend_from_slice(&checksum(&records).to_le_bytes());
        bytes.extend_from_slice(&records);
        if let Some((counts, records)) = labels {
            for c in counts {
                bytes.extend_from_slice(&c.to_le_bytes());
            }
            bytes.extend_from_slice(&checksum(&records).to_le_bytes());
            bytes.extend_from_slice(&records);
        }
    }
    Ok(bytes)
}

/// Writes a grid atomically.
pub fn write_nav(path: &Path, grid: &NavGrid) -> Result<(), NavFileError> {
    let bytes = encode(grid).map_err(|e| NavFileError::Format {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    write_bytes_atomic(path, &bytes).map_err(|cause| NavFileError::Io(FileError::new(path, cause)))
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
    sum: &mut Checksum,
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
        sum.update(chunk);
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

/// Reads a grid, with the query structures stored after it in [`NavGrid::baked`]. Files of
/// another format version are refused with a message asking for a rebake. A stored section
/// that does not check out (checksum, length) is dropped with one warning: the structures
/// are then rebuilt in memory by their users.
pub fn read_nav(path: &Path) -> Result<NavGrid, NavFileError> {
    let grid = open(path).and_then(|(file, len)| read_from(file, len));
    grid.map(|(grid, warning)| {
        if let Some(w) = warning {
            tracing::warn!("{}: {w}; rebuilding it in memory", path.display());
        }
        grid
    })
    .map_err(|e| e.at(path))
}

/// Decodes a grid file's bytes as [`read_nav`] reads the file (`path` names it in errors and
/// the warning); for fuzzing and tests.
pub fn decode_nav(path: &Path, bytes: &[u8]) -> Result<NavGrid, NavFileError> {
    read_from(bytes, bytes.len() as u64)
        .map(|(grid, warning)| {
            if let Some(w) = warning {
                tracing::warn!("{}: {w}; rebuilding it in memory", path.display());
            }
            grid
        })
        .map_err(|e| e.at(path))
}

/// Reads only the parameters a grid was baked with (its body among them) from the file's
/// header, without its arrays: a cheap check before a batch loads whole grids.
pub fn read_nav_params(path: &Path) -> Result<NavParams, NavFileError> {
    open(path)
        .and_then(|(file, len)| {
            let mut r = std::io::BufReader::new(file);
            read_header(&mut r, len).map(|h| h.0.params)
        })
        .map_err(|e| e.at(path))
}

/// The file and its length.
fn open(path: &Path) -> Result<(std::fs::File, u64), ReadError> {
    let file = std::fs::File::open(path).map_err(ReadError::Io)?;
    let len = file.metadata().map_err(ReadError::Io)?.len();
    Ok((file, len))
}

impl ReadError {
    /// The error, naming `path`.
    fn at(self, path: &Path) -> NavFileError {
        match self {
            ReadError::Io(cause) => NavFileError::Io(FileError::new(path, cause)),
            ReadError::Format(message) => NavFileError::Format {
                path: path.to_path_buf(),
                message,
            },
        }
    }
}

/// Reads the magic, the version and the header of a file of `len` bytes; returns the header,
/// its bytes and the stored checksum of the header and the arrays.
fn read_header(r: &mut impl Read, len: u64) -> Result<(HeaderIn, Vec<u8>, u64), ReadError> {
    let mut head = [0u8; PREFIX];
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
            "navigation grid format version {version}, this minos reads version {FORMAT_VERSION}"
        )));
    }
    r.read_exact(&mut head[12..PREFIX])?;
    let header_len = u32::from_le_bytes([head[12], head[13], head[14], head[15]]);
    let sum = u64_at(&head, 16);
    if u64::from(header_len) > len.saturating_sub(PREFIX as u64) {
        return Err(ReadError::Format("corrupt: header length".into()));
    }
    let mut header = vec![0u8; header_len as usize];
    r.read_exact(&mut header)?;
    let h: HeaderIn =
        postcard::from_bytes(&header).map_err(|e| ReadError::Format(format!("corrupt: {e}")))?;
    Ok((h, header, sum))
}

/// Decodes a grid file of `len` bytes from `file`, with a warning when its stored section
/// was dropped.
fn read_from(file: impl Read, len: u64) -> Result<(NavGrid, Option<String>), ReadError> {
    let mut r = std::io::BufReader::with_capacity(1 << 16, file);
    let (h, header, stored_sum) = read_header(&mut r, len)?;
    let header_len = header.len() as u64;
    let body = h
        .columns
        .checked_mul(4)
        .zip(h.spans.checked_mul(SPAN_BYTES as u64))
        .zip(h.span_objects.checked_mul(8))
        .and_then(|((a, b), c)| a.checked_add(b)?.checked_add(c));
    // What follows the grid's arrays: nothing, or the stored line-of-sight section (16
    // bytes of count and checksum, then its records).
    let rest = body
        .zip(len.checked_sub(PREFIX as u64 + header_len))
        .and_then(|(b, l)| l.checked_sub(b));
    let Some(rest) = rest.filter(|&r| r == 0 || r >= 16) else {
        return Err(ReadError::Format(
            "corrupt: array lengths do not match the file's size".into(),
        ));
    };
    if h.columns != u64::from(h.nx) * u64::from(h.nz) + 1 {
        return Err(ReadError::Format(format!(
            "corrupt: {} column starts for {} x {} columns",
            h.columns, h.nx, h.nz
        )));
    }
    let mut sum = Checksum::new(body.map_or(0, |b| b + header_len));
    sum.update(&header);
    let column_start = read_records::<4, u32>(
        &mut r,
        &mut sum,
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
    let spans =
        read_records::<SPAN_BYTES, Span>(&mut r, &mut sum, h.spans, get_span, span_ok, "span")?;
    let span_objects = read_records::<8, (u32, u32)>(
        &mut r,
        &mut sum,
        h.span_objects,
        |b| (u32_at(b, 0), u32_at(b, 4)),
        |_| true,
        "span object",
    )?;
    // Fuzzing skips the checksum so that the decoder and the validation behind it are reached.
    if !cfg!(fuzzing) && sum.finish() != stored_sum {
        return Err(ReadError::Format(
            "corrupt: the grid fails its checksum".into(),
        ));
    }
    let (sight_squares, rest, mut warning) = if rest == 0 {
        (Vec::new(), 0, None)
    } else {
        read_squares(&mut r, rest, h.spans)?
    };
    let (sparse_edges, rest) = if rest == 0 {
        (None, 0)
    } else {
        let (edges, left, w) = read_graph(&mut r, rest)?;
        warning = warning.or(w);
        (edges, left)
    };
    let sparse_labels = if rest == 0 {
        None
    } else {
        let (labels, w) = read_labels(&mut r, rest, h.spans)?;
        warning = warning.or(w);
        labels
    };
    let grid = NavGrid {
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
        baked: Baked {
            sight_squares,
            sparse_edges,
            sparse_labels,
        },
    };
    // Room ids quoted from the file may hold newlines: keep the error one line.
    grid.validate().map_err(|e| {
        ReadError::Format(format!(
            "corrupt: {}",
            crate::escape::escape_controls(&e.to_string())
        ))
    })?;
    Ok((grid, warning))
}

/// Reads the stored line-of-sight section of a grid of `spans` spans, `rest` bytes (at
/// least 16) being left in the file: the records when their count and checksum check out
/// (otherwise none and the warning to log), and the bytes left after the section. A section
/// longer than what is left is a corrupt file.
#[allow(clippy::type_complexity)]
fn read_squares(
    r: &mut impl Read,
    rest: u64,
    spans: u64,
) -> Result<(Vec<[u8; 4]>, u64, Option<String>), ReadError> {
    let mut head = [0u8; 16];
    r.read_exact(&mut head)?;
    let count = u64_at(&head, 0);
    let sum = u64_at(&head, 8);
    let Some(left) = count
        .checked_mul(SQUARES_BYTES as u64)
        .and_then(|b| b.checked_add(16))
        .and_then(|b| rest.checked_sub(b))
    else {
        return Err(ReadError::Format(
            "corrupt: the line-of-sight section's length does not match the file's size".into(),
        ));
    };
    // Bounded by the file's size.
    let mut bytes = vec![0u8; (rest - 16 - left) as usize];
    r.read_exact(&mut bytes)?;
    if count != spans {
        let w = format!("stored line-of-sight index has {count} records for {spans} spans");
        return Ok((Vec::new(), left, Some(w)));
    }
    if checksum(&bytes) != sum {
        let w = "stored line-of-sight index fails its checksum".to_string();
        return Ok((Vec::new(), left, Some(w)));
    }
    Ok((bytes.as_chunks::<SQUARES_BYTES>().0.to_vec(), left, None))
}

/// Little-endian u64 at `at` of a slice (0 past its end).
fn u64_at(b: &[u8], at: usize) -> u64 {
    b.get(at..at + 8)
        .and_then(|w| w.try_into().ok())
        .map_or(0, u64::from_le_bytes)
}

/// Bytes of the sparse graph section for `vertices` vertices and `edges` edges, after its
/// 24-byte head (`None` on overflow).
fn graph_bytes(vertices: u64, edges: u64) -> Option<u64> {
    let first = vertices.checked_add(1)?.checked_mul(4)?;
    let marks = vertices.checked_mul(4 * SPARSE_LANDMARKS as u64)?;
    first.checked_add(edges.checked_mul(8)?)?.checked_add(marks)
}

/// Reads the stored sparse graph section, `rest` bytes being left in the file: its edges and
/// landmarks when the checksum and [`SparseEdges::fits`] check out (otherwise none and the
/// warning to log), and the bytes left after the section (the labels section, or 0). A
/// section longer than what is left, or followed by less than a labels section's head, is
/// a corrupt file.
#[allow(clippy::type_complexity)]
fn read_graph(
    r: &mut impl Read,
    rest: u64,
) -> Result<(Option<SparseEdges>, u64, Option<String>), ReadError> {
    let bad = || {
        ReadError::Format(
            "corrupt: the sparse graph section's length does not match the file's size".into(),
        )
    };
    if rest < 24 {
        return Err(bad());
    }
    let mut head = [0u8; 24];
    r.read_exact(&mut head)?;
    let (vertices, edges, sum) = (u64_at(&head, 0), u64_at(&head, 8), u64_at(&head, 16));
    let Some(left) = graph_bytes(vertices, edges)
        .and_then(|b| (rest - 24).checked_sub(b))
        .filter(|&l| l == 0 || l >= LABELS_HEAD)
    else {
        return Err(bad());
    };
    // Bounded by the file's size.
    let mut bytes = vec![0u8; (rest - 24 - left) as usize];
    r.read_exact(&mut bytes)?;
    if checksum(&bytes) != sum {
        let w = "stored sparse graph fails its checksum".to_string();
        return Ok((None, left, Some(w)));
    }
    let (v, e) = (vertices as usize, edges as usize);
    let (first, more) = bytes.split_at(4 * (v + 1));
    let (edge_bytes, mark_bytes) = more.split_at(8 * e);
    let g = SparseEdges {
        first: first
            .as_chunks::<4>()
            .0
            .iter()
            .map(|b| u32::from_le_bytes(*b))
            .collect(),
        edges: edge_bytes
            .as_chunks::<8>()
            .0
            .iter()
            .map(|b| (u32_at(b, 0), f32::from_bits(u32_at(b, 4))))
            .collect(),
        marks: mark_bytes
            .as_chunks::<{ 4 * SPARSE_LANDMARKS }>()
            .0
            .iter()
            .map(|b| std::array::from_fn(|k| f32::from_bits(u32_at(b, 4 * k))))
            .collect(),
    };
    if !g.fits(v) {
        let w = "stored sparse graph does not fit its vertex count".to_string();
        return Ok((None, left, Some(w)));
    }
    Ok((Some(g), left, None))
}

/// Bytes of the sparse graph labels section's head: four counts and the checksum.
const LABELS_HEAD: u64 = 40;

/// Reads the stored sparse graph labels section, the last `rest` bytes of the file (at least
/// [`LABELS_HEAD`]), for a grid of `spans` spans: the labels when the checksum and
/// [`SparseLabels::fits`] check out (otherwise none and the warning to log). A section whose
/// length does not match its counts is a corrupt file.
fn read_labels(
    r: &mut impl Read,
    rest: u64,
    spans: u64,
) -> Result<(Option<SparseLabels>, Option<String>), ReadError> {
    let mut head = [0u8; LABELS_HEAD as usize];
    r.read_exact(&mut head)?;
    let c: [u64; 4] = std::array::from_fn(|k| u64_at(&head, 8 * k));
    let sum = u64_at(&head, 32);
    let len = c[0]
        .checked_add(c[1])
        .and_then(|a| a.checked_mul(4))
        .zip(c[2].checked_add(c[3]).and_then(|b| b.checked_mul(8)))
        .and_then(|(a, b)| a.checked_add(b));
    if len != Some(rest - LABELS_HEAD) {
        return Err(ReadError::Format(
            "corrupt: the sparse graph labels section's length does not match the file's size"
                .into(),
        ));
    }
    // Bounded by the file's size.
    let mut bytes = vec![0u8; (rest - LABELS_HEAD) as usize];
    r.read_exact(&mut bytes)?;
    if checksum(&bytes) != sum {
        let w = "stored sparse graph labels fail their checksum".to_string();
        return Ok((None, Some(w)));
    }
    let (words, pairs) = bytes.split_at(4 * (c[0] + c[1]) as usize);
    let words: Vec<u32> = words
        .as_chunks::<4>()
        .0
        .iter()
        .map(|b| u32::from_le_bytes(*b))
        .collect();
    let mut pairs: Vec<(u32, u32)> = pairs
        .as_chunks::<8>()
        .0
        .iter()
        .map(|b| (u32_at(b, 0), u32_at(b, 4)))
        .collect();
    let mut area = words;
    let verts = area.split_off(c[0] as usize);
    let portal_gates = pairs.split_off(c[2] as usize);
    let labels = SparseLabels {
        area,
        verts,
        portals: pairs,
        portal_gates,
    };
    if spans > usize::MAX as u64 || !labels.fits(spans as usize) {
        let w = "stored sparse graph labels do not fit the grid".to_string();
        return Ok((None, Some(w)));
    }
    Ok((Some(labels), None))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::navmesh::los::SightIndex;
    use crate::navmesh::testmaps::MapSpec;
    use crate::navmesh::NONE;

    fn grid() -> NavGrid {
        let rows = [
            "##############################",
            "#aaaaaaaaaaaaaaaaaaaaaaaaaaaa#",
            "#aaaa*aaaaaaaaaaaaaaaaaaaaaaa#",
            "#aaaaDbbbbbbbbbbbbbbbbbbbbbbb#",
            "#aaaaaaaaaaaaaaaaaaaaaaaaaaaa#",
            "#aaaaaaaaaaaaaaaaaaaaaaaaaaaa#",
            "#aaaaaaaaaaaaaaaaaaaaaaaaaaaa#",
            "#aaaaaaaaaaaaaaaaaaaaaaaaaaaa#",
            "#aaaaaaaaaaaaaaaaaaaaaaaaaaaa#",
            "#aaaaaaaaaa####aaaaaaaaaaaaaa#",
            "#aaaaaaaaaa####aaaaaaaaaaaaaa#",
            "#aaaaaaaaaa####aaaaaaaaaaaaaa#",
            "#aaaaaaaaaa####aaaaaaaaaaaaaa#",
            "#aaaaaaaaaa####aaaaaaaaaaaaaa#",
            "#aaaaaaaaaaaaaaaaaaaaaaaaaaaa#",
            "#aaaaaaaaaaaaaaaaaaaaaaaaaaaa#",
            "#aaaaaaaaaaaaaaaaaaaaaaaaaaaa#",
            "#aaaaaaaaaaaaaaaaaaaaaaaaaaaa#",
            "#aaaaaaaaaaaaaaaaaaaaaaaaaaaa#",
            "#aaaaaaaaaaaaaaaaaaaaaaaaaaaa#",
            "#aaaaaaaaaaaaaaaaaaaaaaaaaaaa#",
            "##############################",
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
        let read = read_nav(&path).unwrap();
        assert_eq!(read, g);
        let fresh = SightIndex::build(&g).squares();
        assert_eq!(read.baked.sight_squares, fresh);
        let edges = crate::navmesh::geodesic::Geodesic::new(&g).sparse_edges();
        assert!(edges.as_ref().is_some_and(|e| !e.edges.is_empty()));
        assert_eq!(read.baked.sparse_edges, edges);
        assert!(fresh.iter().any(|a| a.iter().any(|&l| l > 1)));
        // Same bytes whatever the grid carries.
        write_nav(&path, &read).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), encode(&g).unwrap());
    }

    #[test]
    fn the_parameters_read_alone_from_the_header() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.nav");
        let params = NavParams {
            body: crate::body::AgentBody::MINOS,
            ..NavParams::default()
        };
        let rows = ["#####", "#...#", "#####"];
        let g = MapSpec::ascii(&rows, 0.1).build(params);
        let bytes = encode(&g).unwrap();
        // The arrays are not read: a file cut after its header still gives its parameters.
        let header = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        std::fs::write(&path, &bytes[..PREFIX + header]).unwrap();
        assert_eq!(read_nav_params(&path).unwrap(), g.params);
        assert_eq!(g.params.body, crate::body::AgentBody::MINOS);
        assert!(read_nav(&path).is_err());
        let e = read_nav_params(&dir.path().join("none.nav")).unwrap_err();
        assert!(e.to_string().contains("none.nav"), "{e}");
        std::fs::write(&path, b"something else entirely").unwrap();
        assert!(read_nav_params(&path)
            .unwrap_err()
            .to_string()
            .contains("magic"));
    }

    /// Where the grid's arrays end in a file's bytes (the stored sections follow).
    fn arrays_end(bytes: &[u8], g: &NavGrid) -> usize {
        let header = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        PREFIX
            + header
            + 4 * g.column_start.len()
            + SPAN_BYTES * g.spans.len()
            + 8 * g.span_objects.len()
    }

    #[test]
    fn a_stored_section_that_does_not_check_out_is_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.nav");
        let g = grid();
        let bytes = encode(&g).unwrap();
        let base = arrays_end(&bytes, &g);
        let graph = base + 16 + SQUARES_BYTES * g.spans.len();
        assert!(bytes.len() > graph + 24, "the test grid has a sparse graph");
        let fresh = read_nav(path_with(&path, &bytes)).unwrap();
        assert!(!fresh.baked.sight_squares.is_empty());
        assert!(fresh.baked.sparse_edges.is_some());
        // A flipped byte in the squares or their checksum: the squares are dropped.
        for at in [base + 16 + 5, base + 13] {
            let mut bad = bytes.clone();
            bad[at] ^= 0x10;
            let read = read_nav(path_with(&path, &bad)).unwrap();
            assert_eq!(read, g);
            assert!(read.baked.sight_squares.is_empty());
            assert_eq!(read.baked.sparse_edges, fresh.baked.sparse_edges);
        }
        let e = fresh.baked.sparse_edges.clone().unwrap();
        let labels =
            graph + 24 + graph_bytes(e.marks.len() as u64, e.edges.len() as u64).unwrap() as usize;
        assert!(fresh.baked.sparse_labels.is_some());
        assert_eq!(
            fresh.baked.sparse_labels,
            Geodesic::new(&g).sparse_labels(),
            "stored labels equal a fresh build's"
        );
        // In the graph's records or checksum: the graph is dropped, the labels kept.
        for at in [labels - 7, graph + 17] {
            let mut bad = bytes.clone();
            bad[at] ^= 0x10;
            let read = read_nav(path_with(&path, &bad)).unwrap();
            assert_eq!(read.baked.sight_squares, fresh.baked.sight_squares);
            assert!(read.baked.sparse_edges.is_none());
            assert_eq!(read.baked.sparse_labels, fresh.baked.sparse_labels);
        }
        // In the labels' records or checksum: the labels are dropped, the graph kept.
        for at in [bytes.len() - 7, labels + 35, labels + 40] {
            let mut bad = bytes.clone();
            bad[at] ^= 0x10;
            let read = read_nav(path_with(&path, &bad)).unwrap();
            assert_eq!(read.baked.sparse_edges, fresh.baked.sparse_edges);
            assert!(read.baked.sparse_labels.is_none());
        }
        // An edge to a vertex out of range, with a matching checksum: dropped too.
        assert!(!e.edges.is_empty());
        let mut bad = bytes.clone();
        let at = graph + 24 + 4 * e.first.len();
        bad[at..at + 4].copy_from_slice(&(e.marks.len() as u32).to_le_bytes());
        let sum = checksum(&bad[graph + 24..labels]);
        bad[graph + 16..graph + 24].copy_from_slice(&sum.to_le_bytes());
        assert!(read_nav(path_with(&path, &bad))
            .unwrap()
            .baked
            .sparse_edges
            .is_none());
        // A vertex span out of range, or a zone number beyond the span count, with a
        // matching checksum: the labels are dropped.
        let l = fresh.baked.sparse_labels.clone().unwrap();
        assert!(!l.verts.is_empty());
        for (at, word) in [
            (labels + 40 + 4 * l.area.len(), g.spans.len() as u32),
            (labels + 40, (1 << 31) | g.spans.len() as u32),
        ] {
            let mut bad = bytes.clone();
            bad[at..at + 4].copy_from_slice(&word.to_le_bytes());
            let sum = checksum(&bad[labels + 40..]);
            bad[labels + 32..labels + 40].copy_from_slice(&sum.to_le_bytes());
            let read = read_nav(path_with(&path, &bad)).unwrap();
            assert!(read.baked.sparse_labels.is_none());
            assert_eq!(read.baked.sparse_edges, fresh.baked.sparse_edges);
        }
        // Without the labels section: read, no labels.
        let read = read_nav(path_with(&path, &bytes[..labels])).unwrap();
        assert_eq!(read.baked.sparse_edges, fresh.baked.sparse_edges);
        assert!(read.baked.sparse_labels.is_none());
        // A count that is not the span count, with a matching length.
        let mut bad = bytes[..base].to_vec();
        let n = g.spans.len() - 1;
        bad.extend_from_slice(&(n as u64).to_le_bytes());
        let records = &bytes[base + 16..base + 16 + SQUARES_BYTES * n];
        bad.extend_from_slice(&checksum(records).to_le_bytes());
        bad.extend_from_slice(records);
        let read = read_nav(path_with(&path, &bad)).unwrap();
        assert!(read.baked.sight_squares.is_empty());
        // Without the sections, without the graph: read, nothing (no graph) stored.
        let read = read_nav(path_with(&path, &bytes[..base])).unwrap();
        assert_eq!(read, g);
        assert!(read.baked.sight_squares.is_empty() && read.baked.sparse_edges.is_none());
        let read = read_nav(path_with(&path, &bytes[..graph])).unwrap();
        assert_eq!(read.baked.sight_squares, fresh.baked.sight_squares);
        assert!(read.baked.sparse_edges.is_none());
        // Truncated inside a section: a one-line error.
        for cut in [
            1,
            5,
            bytes.len() - labels - 10,
            bytes.len() - graph - 10,
            bytes.len() - base - 8,
        ] {
            let e = read_nav(path_with(&path, &bytes[..bytes.len() - cut]))
                .unwrap_err()
                .to_string();
            assert!(e.contains("corrupt") && !e.contains('\n'), "{e}");
        }
    }

    /// Writes `bytes` to `path`, returning it.
    fn path_with<'p>(path: &'p Path, bytes: &[u8]) -> &'p Path {
        std::fs::write(path, bytes).unwrap();
        path
    }

    #[test]
    fn old_versions_and_corrupt_files_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.nav");
        let bytes = encode(&grid()).unwrap();
        for v in [1u32, 2, 3, 4] {
            let mut old = bytes.clone();
            old[8..12].copy_from_slice(&v.to_le_bytes());
            std::fs::write(&path, &old).unwrap();
            let e = read_nav(&path).unwrap_err().to_string();
            assert!(
                // The remedy (rebake) is the front door's to say: no command here.
                e.contains(&format!(
                    "version {v}, this minos reads version {FORMAT_VERSION}"
                )) && !e.contains("`minos"),
                "{e}"
            );
            assert!(!e.contains('\n'), "{e}");
        }
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
        let at = arrays_end(&bytes, &g) - 8 * g.span_objects.len() - SPAN_BYTES + 54;
        bad[at] = 7;
        std::fs::write(&path, &bad).unwrap();
        assert!(read_nav(&path)
            .unwrap_err()
            .to_string()
            .contains("bad span"));
    }

    #[test]
    fn the_streamed_checksum_equals_the_whole_one_whatever_the_pieces() {
        let bytes: Vec<u8> = (0..200u32).map(|i| (i * 37 % 251) as u8).collect();
        for cut in [0, 1, 7, 8, 9, 63, 199, 200] {
            for cut2 in [cut, (cut + 3).min(200), 200] {
                let mut c = Checksum::new(200);
                c.update(&bytes[..cut]);
                c.update(&bytes[cut..cut2]);
                c.update(&bytes[cut2..]);
                assert_eq!(c.finish(), checksum(&bytes), "{cut} {cut2}");
            }
        }
    }

    #[test]
    fn bit_flips_and_truncations_of_a_written_grid_are_errors_never_panics() {
        let g = grid();
        let bytes = encode(&g).unwrap();
        let end = arrays_end(&bytes, &g);
        let p = Path::new("g.nav");
        let step = (end / 1500).max(1);
        let mut flips = 0;
        for at in (0..bytes.len()).step_by(step) {
            for bit in [0, 5] {
                let mut b = bytes.clone();
                b[at] ^= 1 << bit;
                let r = std::panic::catch_unwind(|| decode_nav(p, &b));
                let r = r.unwrap_or_else(|_| panic!("panic at byte {at} bit {bit}"));
                if at < end {
                    // In the grid part: always caught.
                    let e = r.expect_err("a flip in the grid is caught").to_string();
                    assert!(e.starts_with("g.nav: ") && !e.contains('\n'), "{e}");
                    flips += 1;
                } else if let Ok(read) = r {
                    // In a derived section: dropped or refused, never wrong.
                    assert_eq!(read, g, "flip at {at}");
                }
            }
        }
        assert!(flips > 1000, "{flips}");
        for len in (0..bytes.len()).step_by(step) {
            let r = std::panic::catch_unwind(|| decode_nav(p, &bytes[..len]).map(|_| ()));
            let r = r.unwrap_or_else(|_| panic!("panic when cut to {len}"));
            if len < end {
                assert!(r.is_err(), "cut to {len}");
            }
        }
    }

    #[test]
    fn a_checksummed_grid_with_a_link_out_of_range_is_refused_naming_the_span() {
        let mut g = grid();
        let s = g.spans.iter().position(|s| s.links[0] != NONE).unwrap();
        g.spans[s].links[0] = g.spans.len() as u32 + 5;
        let bytes = encode(&g).unwrap();
        let e = decode_nav(Path::new("g.nav"), &bytes)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(&format!("g.nav: corrupt: span {s}: link 0 to span")),
            "{e}"
        );
        let mut g = grid();
        g.spans[0].room = 99;
        let e = decode_nav(Path::new("g.nav"), &encode(&g).unwrap())
            .unwrap_err()
            .to_string();
        assert!(e.contains("span 0: room 99 out of range"), "{e}");
    }
}
