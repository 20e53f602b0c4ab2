//! The Matterport3D `.house` text format (`ASCII 1.1`), parsed completely into plain records.
//!
//! This file only turns text into records and checks the file's own consistency: field counts
//! and numbers, record indices counting up from 0, the counts announced by the `H` record, and
//! cross-references (a region's level, an object's category, …). It keeps the file's z-up
//! coordinates and knows nothing of the scene model; [`super`] converts to y-up and builds
//! geometry.
//!
//! Record layouts (after the `ASCII 1.1` line; `#` stands for a space in names and `-` for
//! "no label"):
//!
//! ```text
//! H name label #images #panoramas #vertices #surfaces #segments #objects #categories #regions #portals #levels  0 0 0 0 0  xlo ylo zlo xhi yhi zhi  0 0 0 0 0
//! L level_index #regions label  px py pz  xlo ylo zlo xhi yhi zhi  0 0 0 0 0
//! R region_index level_index 0 0 label  px py pz  xlo ylo zlo xhi yhi zhi  height  0 0 0 0
//! P portal_index region0_index region1_index label  xlo ylo zlo xhi yhi zhi  0 0 0 0
//! S surface_index region_index 0 label px py pz  nx ny nz  xlo ylo zlo xhi yhi zhi  0 0 0 0 0
//! V vertex_index surface_index label  px py pz  nx ny nz  0 0 0
//! P name  panorama_index region_index 0  px py pz  0 0 0 0 0
//! I image_index panorama_index  name camera_index yaw_index e00 … e33  i00 … i22  width height  px py pz  0 0 0 0 0
//! C category_index category_mapping_index category_mapping_name mpcat40_index mpcat40_name 0 0 0 0 0
//! O object_index region_index category_index px py pz  a0x a0y a0z  a1x a1y a1z  r0 r1 r2  0 0 0 0 0 0 0 0
//! E segment_index object_index id area px py pz xlo ylo zlo xhi yhi zhi  0 0 0 0 0
//! ```
//!
//! Both portals and panoramas are `P` records: the first `#portals` of them (as the `H` record
//! announces) are portals, the rest panoramas. Indices that may be absent (`-1`) are kept as
//! `Option`. Windows line endings, trailing whitespace and blank lines are tolerated; fields
//! after the documented ones (the trailing zeros) are ignored.

use std::fmt;

/// Largest magnitude accepted for a number (metres, pixels): far beyond any building, small
/// enough that geometry built from it stays finite and bounded in size.
pub const MAX_MAGNITUDE: f64 = 1e6;

/// A problem in a `.house` file: the 1-based line and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("line {line}: {message}")]
pub struct HouseError {
    /// 1-based line number.
    pub line: usize,
    /// What is wrong (one line).
    pub message: String,
}

impl HouseError {
    fn new(line: usize, message: impl Into<String>) -> Self {
        HouseError {
            line,
            message: message.into(),
        }
    }
}

/// An axis-aligned box as the file writes it (z-up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FileBox {
    /// `(xlo, ylo, zlo)`.
    pub lo: [f64; 3],
    /// `(xhi, yhi, zhi)`.
    pub hi: [f64; 3],
}

/// The counts the `H` record announces.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counts {
    /// `I` records.
    pub images: usize,
    /// Panorama `P` records.
    pub panoramas: usize,
    /// `V` records.
    pub vertices: usize,
    /// `S` records.
    pub surfaces: usize,
    /// `E` records.
    pub segments: usize,
    /// `O` records.
    pub objects: usize,
    /// `C` records.
    pub categories: usize,
    /// `R` records.
    pub regions: usize,
    /// Portal `P` records.
    pub portals: usize,
    /// `L` records.
    pub levels: usize,
}

/// The `H` record.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// Line of the record.
    pub line: usize,
    /// House name (`None` for `-`).
    pub name: Option<String>,
    /// House label (`None` for `-`).
    pub label: Option<String>,
    /// Announced record counts.
    pub counts: Counts,
    /// Box of the whole house.
    pub bbox: FileBox,
}

/// An `L` record: one level (storey).
#[derive(Debug, Clone, PartialEq)]
pub struct LevelRecord {
    /// Line of the record.
    pub line: usize,
    /// Number of regions the record says refer to it (often 0 in real files; not checked).
    pub nregions: usize,
    /// Label (`None` for `-`).
    pub label: Option<String>,
    /// Representative position.
    pub position: [f64; 3],
    /// Box.
    pub bbox: FileBox,
}

/// An `R` record: one region (room).
#[derive(Debug, Clone, PartialEq)]
pub struct RegionRecord {
    /// Line of the record.
    pub line: usize,
    /// Index of its level (`None` for `-1`).
    pub level: Option<usize>,
    /// Region label: one letter (`k` kitchen, `-` none, …).
    pub label: String,
    /// Representative position.
    pub position: [f64; 3],
    /// Box.
    pub bbox: FileBox,
    /// Height above its floor (metres).
    pub height: f64,
}

/// A portal `P` record: an opening between two regions.
#[derive(Debug, Clone, PartialEq)]
pub struct PortalRecord {
    /// Line of the record.
    pub line: usize,
    /// The two regions it joins (`None` for `-1`).
    pub regions: [Option<usize>; 2],
    /// Label (`None` for `-`).
    pub label: Option<String>,
    /// Box of the opening.
    pub bbox: FileBox,
}

/// An `S` record: a surface (a region's floor outline when its label is `F`).
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceRecord {
    /// Line of the record.
    pub line: usize,
    /// Its region (`None` for `-1`).
    pub region: Option<usize>,
    /// Label (`F` for floors).
    pub label: String,
    /// Representative position.
    pub position: [f64; 3],
    /// Normal.
    pub normal: [f64; 3],
    /// Box.
    pub bbox: FileBox,
}

/// A `V` record: one vertex of a surface outline, in order.
#[derive(Debug, Clone, PartialEq)]
pub struct VertexRecord {
    /// Line of the record.
    pub line: usize,
    /// Its surface.
    pub surface: usize,
    /// Label.
    pub label: String,
    /// Position.
    pub position: [f64; 3],
    /// Normal.
    pub normal: [f64; 3],
}

/// A panorama `P` record: a camera position (about 1.5 m above the floor).
#[derive(Debug, Clone, PartialEq)]
pub struct PanoramaRecord {
    /// Line of the record.
    pub line: usize,
    /// Panorama name (the image id used by R2R connectivity files).
    pub name: String,
    /// Its region (`None` for `-1`).
    pub region: Option<usize>,
    /// Camera position.
    pub position: [f64; 3],
}

/// An `I` record: one image of a panorama.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageRecord {
    /// Line of the record.
    pub line: usize,
    /// Its panorama.
    pub panorama: usize,
    /// Image name.
    pub name: String,
    /// Camera index (0–5).
    pub camera_index: i64,
    /// Yaw index (0–2).
    pub yaw_index: i64,
    /// Row-major 4×4 extrinsic matrix.
    pub extrinsics: [f64; 16],
    /// Row-major 3×3 intrinsic matrix.
    pub intrinsics: [f64; 9],
    /// Image width in pixels.
    pub width: i64,
    /// Image height in pixels.
    pub height: i64,
    /// Camera position.
    pub position: [f64; 3],
}

/// A `C` record: an object category.
#[derive(Debug, Clone, PartialEq)]
pub struct CategoryRecord {
    /// Line of the record.
    pub line: usize,
    /// Row index in `category_mapping.tsv` (1-based there; `None` for `-1`).
    pub mapping_index: Option<usize>,
    /// Raw category name (`#` turned into spaces; `None` for `-`).
    pub mapping_name: Option<String>,
    /// mpcat40 index (`None` for `-1`).
    pub mpcat40_index: Option<usize>,
    /// mpcat40 name (`None` for `-`).
    pub mpcat40_name: Option<String>,
}

/// An `O` record: an object as an oriented box.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectRecord {
    /// Line of the record.
    pub line: usize,
    /// Its region (`None` for `-1`).
    pub region: Option<usize>,
    /// Its category (`None` for `-1`).
    pub category: Option<usize>,
    /// Box centre.
    pub center: [f64; 3],
    /// First box axis.
    pub axis0: [f64; 3],
    /// Second box axis (the third is `axis0 × axis1`).
    pub axis1: [f64; 3],
    /// Half sizes along the three axes.
    pub radii: [f64; 3],
}

/// An `E` record: a mesh segment and the object it belongs to.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentRecord {
    /// Line of the record.
    pub line: usize,
    /// Its object (`None` for `-1`).
    pub object: Option<usize>,
    /// Segment id as used by the mesh's per-face `segment_id`.
    pub id: i64,
    /// Area (m²).
    pub area: f64,
    /// Representative position.
    pub position: [f64; 3],
    /// Box.
    pub bbox: FileBox,
}

/// A whole parsed `.house` file (z-up, as written).
#[derive(Debug, Clone, PartialEq)]
pub struct HouseFile {
    /// The version after `ASCII` (`1.1`).
    pub version: String,
    /// The `H` record.
    pub header: Header,
    /// `L` records.
    pub levels: Vec<LevelRecord>,
    /// `R` records.
    pub regions: Vec<RegionRecord>,
    /// Portal `P` records.
    pub portals: Vec<PortalRecord>,
    /// `S` records.
    pub surfaces: Vec<SurfaceRecord>,
    /// `V` records.
    pub vertices: Vec<VertexRecord>,
    /// Panorama `P` records.
    pub panoramas: Vec<PanoramaRecord>,
    /// `I` records.
    pub images: Vec<ImageRecord>,
    /// `C` records.
    pub categories: Vec<CategoryRecord>,
    /// `O` records.
    pub objects: Vec<ObjectRecord>,
    /// `E` records.
    pub segments: Vec<SegmentRecord>,
    /// Number of lines in the file.
    pub lines: usize,
}

/// The record kinds, for messages and counting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Header,
    Level,
    Region,
    Portal,
    Surface,
    Vertex,
    Panorama,
    Image,
    Category,
    Object,
    Segment,
}

impl Kind {
    const ALL: [Kind; 10] = [
        Kind::Level,
        Kind::Region,
        Kind::Portal,
        Kind::Surface,
        Kind::Vertex,
        Kind::Panorama,
        Kind::Image,
        Kind::Category,
        Kind::Object,
        Kind::Segment,
    ];

    fn letter(self) -> char {
        match self {
            Kind::Header => 'H',
            Kind::Level => 'L',
            Kind::Region => 'R',
            Kind::Portal | Kind::Panorama => 'P',
            Kind::Surface => 'S',
            Kind::Vertex => 'V',
            Kind::Image => 'I',
            Kind::Category => 'C',
            Kind::Object => 'O',
            Kind::Segment => 'E',
        }
    }

    fn plural(self) -> &'static str {
        match self {
            Kind::Header => "headers",
            Kind::Level => "levels",
            Kind::Region => "regions",
            Kind::Portal => "portals",
            Kind::Surface => "surfaces",
            Kind::Vertex => "vertices",
            Kind::Panorama => "panoramas",
            Kind::Image => "images",
            Kind::Category => "categories",
            Kind::Object => "objects",
            Kind::Segment => "segments",
        }
    }

    /// Fields (the record letter included) the documented layout has.
    fn fields(self) -> usize {
        match self {
            Kind::Header => 29,
            Kind::Level => 18,
            Kind::Region => 20,
            Kind::Portal => 15,
            Kind::Surface => 22,
            Kind::Vertex => 13,
            Kind::Panorama => 13,
            Kind::Image => 41,
            Kind::Category => 11,
            Kind::Object => 24,
            Kind::Segment => 19,
        }
    }

    fn announced(self, c: &Counts) -> usize {
        match self {
            Kind::Header => 1,
            Kind::Level => c.levels,
            Kind::Region => c.regions,
            Kind::Portal => c.portals,
            Kind::Surface => c.surfaces,
            Kind::Vertex => c.vertices,
            Kind::Panorama => c.panoramas,
            Kind::Image => c.images,
            Kind::Category => c.categories,
            Kind::Object => c.objects,
            Kind::Segment => c.segments,
        }
    }
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self {
            Kind::Portal => "portal P",
            Kind::Panorama => "panorama P",
            other => return write!(f, "{}", other.letter()),
        };
        f.write_str(name)
    }
}

/// The whitespace-separated fields of one record, with typed accessors that name the field in
/// their errors.
struct Fields<'a> {
    line: usize,
    kind: Kind,
    parts: Vec<&'a str>,
}

impl<'a> Fields<'a> {
    fn err(&self, message: impl Into<String>) -> HouseError {
        HouseError::new(
            self.line,
            format!("{} record: {}", self.kind, message.into()),
        )
    }

    fn raw(&self, i: usize, what: &str) -> Result<&'a str, HouseError> {
        self.parts
            .get(i)
            .copied()
            .ok_or_else(|| self.err(format!("field {i} ({what}) is missing")))
    }

    fn f64(&self, i: usize, what: &str) -> Result<f64, HouseError> {
        let s = self.raw(i, what)?;
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() && v.abs() <= MAX_MAGNITUDE => Ok(v),
            Ok(v) if v.is_finite() => Err(self.err(format!(
                "field {i} ({what}) is {v}, beyond ±{MAX_MAGNITUDE}"
            ))),
            Ok(_) => Err(self.err(format!(
                "field {i} ({what}) is `{}`, not a finite number",
                clip(s)
            ))),
            Err(_) => Err(self.err(format!("field {i} ({what}) is `{}`, not a number", clip(s)))),
        }
    }

    fn vec3(&self, i: usize, what: &str) -> Result<[f64; 3], HouseError> {
        Ok([
            self.f64(i, what)?,
            self.f64(i + 1, what)?,
            self.f64(i + 2, what)?,
        ])
    }

    fn bbox(&self, i: usize) -> Result<FileBox, HouseError> {
        let lo = self.vec3(i, "box minimum")?;
        let hi = self.vec3(i + 3, "box maximum")?;
        Ok(FileBox { lo, hi })
    }

    fn int(&self, i: usize, what: &str) -> Result<i64, HouseError> {
        let s = self.raw(i, what)?;
        s.parse::<i64>().map_err(|_| {
            self.err(format!(
                "field {i} ({what}) is `{}`, not an integer",
                clip(s)
            ))
        })
    }

    /// A count or index that must be ≥ 0.
    fn count(&self, i: usize, what: &str) -> Result<usize, HouseError> {
        let v = self.int(i, what)?;
        usize::try_from(v)
            .map_err(|_| self.err(format!("field {i} ({what}) is {v}, expected 0 or more")))
    }

    /// An index where `-1` means "none".
    fn opt_index(&self, i: usize, what: &str) -> Result<Option<usize>, HouseError> {
        match self.int(i, what)? {
            -1 => Ok(None),
            v => usize::try_from(v)
                .map(Some)
                .map_err(|_| self.err(format!("field {i} ({what}) is {v}, expected -1 or more"))),
        }
    }

    /// A name with `#` standing for a space.
    fn name(&self, i: usize, what: &str) -> Result<String, HouseError> {
        Ok(self.raw(i, what)?.replace('#', " "))
    }

    /// A name where `-` means "none".
    fn opt_name(&self, i: usize, what: &str) -> Result<Option<String>, HouseError> {
        let s = self.name(i, what)?;
        Ok((s != "-").then_some(s))
    }
}

/// At most 40 characters of `s`, for messages.
fn clip(s: &str) -> String {
    if s.chars().count() <= 40 {
        s.to_string()
    } else {
        format!("{}…", s.chars().take(40).collect::<String>())
    }
}

/// Parses a whole `.house` file from its bytes.
pub fn parse(bytes: &[u8]) -> Result<HouseFile, HouseError> {
    let mut p = Parser::default();
    let mut last = 0;
    // A final newline ends the last line; it does not start another.
    let body = bytes.strip_suffix(b"\n").unwrap_or(bytes);
    for (i, raw) in body.split(|&b| b == b'\n').enumerate() {
        let line = i + 1;
        last = line;
        let text = std::str::from_utf8(raw).map_err(|e| {
            HouseError::new(line, format!("not UTF-8 text (byte {})", e.valid_up_to()))
        })?;
        p.line(line, text.trim_end())?;
    }
    p.finish(last.max(1))
}

/// Parses a whole `.house` file from text.
#[cfg(test)]
pub(crate) fn parse_str(text: &str) -> Result<HouseFile, HouseError> {
    parse(text.as_bytes())
}

#[derive(Default)]
struct Parser {
    version: Option<String>,
    header: Option<Header>,
    levels: Vec<LevelRecord>,
    regions: Vec<RegionRecord>,
    portals: Vec<PortalRecord>,
    surfaces: Vec<SurfaceRecord>,
    vertices: Vec<VertexRecord>,
    panoramas: Vec<PanoramaRecord>,
    images: Vec<ImageRecord>,
    categories: Vec<CategoryRecord>,
    objects: Vec<ObjectRecord>,
    segments: Vec<SegmentRecord>,
}

impl Parser {
    fn count_of(&self, kind: Kind) -> usize {
        match kind {
            Kind::Header => usize::from(self.header.is_some()),
            Kind::Level => self.levels.len(),
            Kind::Region => self.regions.len(),
            Kind::Portal => self.portals.len(),
            Kind::Surface => self.surfaces.len(),
            Kind::Vertex => self.vertices.len(),
            Kind::Panorama => self.panoramas.len(),
            Kind::Image => self.images.len(),
            Kind::Category => self.categories.len(),
            Kind::Object => self.objects.len(),
            Kind::Segment => self.segments.len(),
        }
    }

    fn line(&mut self, line: usize, text: &str) -> Result<(), HouseError> {
        if text.trim().is_empty() {
            return Ok(());
        }
        let parts: Vec<&str> = text.split_whitespace().collect();
        if self.version.is_none() {
            return self.version_line(line, text, &parts);
        }
        let letter = parts[0];
        if letter == "H" {
            if let Some(h) = &self.header {
                return Err(HouseError::new(
                    line,
                    format!("second H record (the first is on line {})", h.line),
                ));
            }
            self.header = Some(header(line, parts)?);
            return Ok(());
        }
        let Some(header) = &self.header else {
            return Err(HouseError::new(
                line,
                format!("`{}` record before the H record", clip(letter)),
            ));
        };
        let counts = header.counts;
        let header_line = header.line;
        let kind = match letter {
            "L" => Kind::Level,
            "R" => Kind::Region,
            "P" if self.portals.len() < counts.portals => Kind::Portal,
            "P" => Kind::Panorama,
            "S" => Kind::Surface,
            "V" => Kind::Vertex,
            "I" => Kind::Image,
            "C" => Kind::Category,
            "O" => Kind::Object,
            "E" => Kind::Segment,
            other => {
                return Err(HouseError::new(
                    line,
                    format!(
                        "unknown record type `{}` (expected one of H L R P S V I C O E)",
                        clip(other)
                    ),
                ))
            }
        };
        let f = Fields { line, kind, parts };
        if f.parts.len() < kind.fields() {
            return Err(f.err(format!(
                "{} fields, expected {}",
                f.parts.len(),
                kind.fields()
            )));
        }
        let ordinal = self.count_of(kind);
        let announced = kind.announced(&counts);
        if ordinal >= announced {
            return Err(f.err(format!(
                "one more than the {announced} {} the H record (line {header_line}) announces",
                kind.plural()
            )));
        }
        // Panoramas carry their index in field 2 (after the name); every other record in 1.
        let index_field = if kind == Kind::Panorama { 2 } else { 1 };
        let index = f.count(index_field, "index")?;
        if index != ordinal {
            return Err(f.err(format!(
                "index {index}, expected {ordinal} (indices count up from 0 in file order)"
            )));
        }
        match kind {
            // H records are handled before the dispatch above.
            Kind::Header => {}
            Kind::Level => self.levels.push(LevelRecord {
                line,
                nregions: f.count(2, "#regions")?,
                label: f.opt_name(3, "label")?,
                position: f.vec3(4, "position")?,
                bbox: f.bbox(7)?,
            }),
            Kind::Region => self.regions.push(RegionRecord {
                line,
                level: f.opt_index(2, "level_index")?,
                label: f.name(5, "label")?,
                position: f.vec3(6, "position")?,
                bbox: f.bbox(9)?,
                height: f.f64(15, "height")?,
            }),
            Kind::Portal => self.portals.push(PortalRecord {
                line,
                regions: [
                    f.opt_index(2, "region0_index")?,
                    f.opt_index(3, "region1_index")?,
                ],
                label: f.opt_name(4, "label")?,
                bbox: f.bbox(5)?,
            }),
            Kind::Surface => self.surfaces.push(SurfaceRecord {
                line,
                region: f.opt_index(2, "region_index")?,
                label: f.name(4, "label")?,
                position: f.vec3(5, "position")?,
                normal: f.vec3(8, "normal")?,
                bbox: f.bbox(11)?,
            }),
            Kind::Vertex => self.vertices.push(VertexRecord {
                line,
                surface: f.count(2, "surface_index")?,
                label: f.name(3, "label")?,
                position: f.vec3(4, "position")?,
                normal: f.vec3(7, "normal")?,
            }),
            Kind::Panorama => self.panoramas.push(PanoramaRecord {
                line,
                name: f.name(1, "name")?,
                region: f.opt_index(3, "region_index")?,
                position: f.vec3(5, "position")?,
            }),
            Kind::Image => {
                let mut extrinsics = [0.0; 16];
                for (k, e) in extrinsics.iter_mut().enumerate() {
                    *e = f.f64(6 + k, "extrinsic matrix")?;
                }
                let mut intrinsics = [0.0; 9];
                for (k, e) in intrinsics.iter_mut().enumerate() {
                    *e = f.f64(22 + k, "intrinsic matrix")?;
                }
                self.images.push(ImageRecord {
                    line,
                    panorama: f.count(2, "panorama_index")?,
                    name: f.name(3, "name")?,
                    camera_index: f.int(4, "camera_index")?,
                    yaw_index: f.int(5, "yaw_index")?,
                    extrinsics,
                    intrinsics,
                    width: f.int(31, "width")?,
                    height: f.int(32, "height")?,
                    position: f.vec3(33, "position")?,
                })
            }
            Kind::Category => self.categories.push(CategoryRecord {
                line,
                mapping_index: f.opt_index(2, "category_mapping_index")?,
                mapping_name: f.opt_name(3, "category_mapping_name")?,
                mpcat40_index: f.opt_index(4, "mpcat40_index")?,
                mpcat40_name: f.opt_name(5, "mpcat40_name")?,
            }),
            Kind::Object => {
                let radii = f.vec3(13, "radii")?;
                if let Some(r) = radii.iter().find(|r| **r < 0.0) {
                    return Err(f.err(format!("negative box radius {r}")));
                }
                self.objects.push(ObjectRecord {
                    line,
                    region: f.opt_index(2, "region_index")?,
                    category: f.opt_index(3, "category_index")?,
                    center: f.vec3(4, "centre")?,
                    axis0: f.vec3(7, "axis 0")?,
                    axis1: f.vec3(10, "axis 1")?,
                    radii,
                })
            }
            Kind::Segment => self.segments.push(SegmentRecord {
                line,
                object: f.opt_index(2, "object_index")?,
                id: f.int(3, "id")?,
                area: f.f64(4, "area")?,
                position: f.vec3(5, "position")?,
                bbox: f.bbox(8)?,
            }),
        }
        Ok(())
    }

    fn version_line(&mut self, line: usize, text: &str, parts: &[&str]) -> Result<(), HouseError> {
        match parts {
            ["ASCII", version, ..] if version.starts_with("1.") || *version == "1" => {
                self.version = Some(version.to_string());
                Ok(())
            }
            ["ASCII", version, ..] => Err(HouseError::new(
                line,
                format!(
                    "unsupported .house version `{}` (expected 1.1)",
                    clip(version)
                ),
            )),
            _ => Err(HouseError::new(
                line,
                format!(
                    "expected the `ASCII 1.1` line that starts a .house file, found `{}`",
                    clip(text)
                ),
            )),
        }
    }

    fn finish(self, last_line: usize) -> Result<HouseFile, HouseError> {
        let Some(version) = self.version.clone() else {
            return Err(HouseError::new(
                last_line,
                "empty file (expected `ASCII 1.1` and an H record)",
            ));
        };
        let Some(header) = self.header.clone() else {
            return Err(HouseError::new(last_line, "file ends without an H record"));
        };
        for kind in Kind::ALL {
            let (have, want) = (self.count_of(kind), kind.announced(&header.counts));
            if have < want {
                return Err(HouseError::new(
                    last_line,
                    format!(
                        "file ends with {have} of the {want} {} ({} records) the H record (line {}) announces: the file is truncated",
                        kind.plural(),
                        kind,
                        header.line
                    ),
                ));
            }
        }
        let house = HouseFile {
            version,
            header,
            levels: self.levels,
            regions: self.regions,
            portals: self.portals,
            surfaces: self.surfaces,
            vertices: self.vertices,
            panoramas: self.panoramas,
            images: self.images,
            categories: self.categories,
            objects: self.objects,
            segments: self.segments,
            lines: last_line,
        };
        house.check_references()?;
        Ok(house)
    }
}

fn header(line: usize, parts: Vec<&str>) -> Result<Header, HouseError> {
    let f = Fields {
        line,
        kind: Kind::Header,
        parts,
    };
    if f.parts.len() < Kind::Header.fields() {
        return Err(f.err(format!(
            "{} fields, expected {}",
            f.parts.len(),
            Kind::Header.fields()
        )));
    }
    let counts = Counts {
        images: f.count(3, "#images")?,
        panoramas: f.count(4, "#panoramas")?,
        vertices: f.count(5, "#vertices")?,
        surfaces: f.count(6, "#surfaces")?,
        segments: f.count(7, "#segments")?,
        objects: f.count(8, "#objects")?,
        categories: f.count(9, "#categories")?,
        regions: f.count(10, "#regions")?,
        portals: f.count(11, "#portals")?,
        levels: f.count(12, "#levels")?,
    };
    Ok(Header {
        line,
        name: f.opt_name(1, "name")?,
        label: f.opt_name(2, "label")?,
        counts,
        bbox: f.bbox(18)?,
    })
}

impl HouseFile {
    /// Checks that every index a record holds points at an existing record.
    fn check_references(&self) -> Result<(), HouseError> {
        let check =
            |line: usize, what: &str, index: Option<usize>, len: usize, of: &str| match index {
                Some(i) if i >= len => Err(HouseError::new(
                    line,
                    format!("{what} {i} out of range (the file has {len} {of})"),
                )),
                _ => Ok(()),
            };
        let (nl, nr, ns, np, nc, no) = (
            self.levels.len(),
            self.regions.len(),
            self.surfaces.len(),
            self.panoramas.len(),
            self.categories.len(),
            self.objects.len(),
        );
        for r in &self.regions {
            check(r.line, "R record: level_index", r.level, nl, "levels")?;
        }
        for p in &self.portals {
            for idx in p.regions {
                check(p.line, "portal P record: region index", idx, nr, "regions")?;
            }
        }
        for s in &self.surfaces {
            check(s.line, "S record: region_index", s.region, nr, "regions")?;
        }
        for v in &self.vertices {
            check(
                v.line,
                "V record: surface_index",
                Some(v.surface),
                ns,
                "surfaces",
            )?;
        }
        for p in &self.panoramas {
            check(
                p.line,
                "panorama P record: region_index",
                p.region,
                nr,
                "regions",
            )?;
        }
        for i in &self.images {
            check(
                i.line,
                "I record: panorama_index",
                Some(i.panorama),
                np,
                "panoramas",
            )?;
        }
        for o in &self.objects {
            check(o.line, "O record: region_index", o.region, nr, "regions")?;
            check(
                o.line,
                "O record: category_index",
                o.category,
                nc,
                "categories",
            )?;
        }
        for e in &self.segments {
            check(e.line, "E record: object_index", e.object, no, "objects")?;
        }
        Ok(())
    }

    /// The outline vertices of each surface, in file order (index = surface index).
    pub fn surface_outlines(&self) -> Vec<Vec<&VertexRecord>> {
        let mut out = vec![Vec::new(); self.surfaces.len()];
        for v in &self.vertices {
            if let Some(list) = out.get_mut(v.surface) {
                list.push(v);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small complete file: 1 level, 2 regions, 1 portal, 2 surfaces with 4 vertices each,
    /// 1 panorama with 1 image, 2 categories, 2 objects, 2 segments.
    pub(crate) fn sample() -> String {
        [
            "ASCII 1.1",
            "H  house#1  -  1 1 8 2 2 2 2 2 1  1  0 0 0 0 0  0 0 0  8 4 3  0 0 0 0 0",
            "L  0  2  -  2 2 0  0 0 0  8 4 3  0 0 0 0 0",
            "R  0 0  0 0  k  2 2 0  0 0 0  4 4 2.5  2.5  0 0 0 0",
            "R  1 0  0 0  l  6 2 0  4 0 0  8 4 2.5  2.5  0 0 0 0",
            "P  0 0 1  -  3.9 1 0  4.1 2 2  0 0 0 0",
            "S  0 0  0  F  2 2 0  0 0 1  0 0 0  4 4 0  0 0 0 0 0",
            "S  1 1  0  F  6 2 0  0 0 1  4 0 0  8 4 0  0 0 0 0 0",
            "V  0 0  F  0 0 0  0 0 1  0 0 0",
            "V  1 0  F  4 0 0  0 0 1  0 0 0",
            "V  2 0  F  4 4 0  0 0 1  0 0 0",
            "V  3 0  F  0 4 0  0 0 1  0 0 0",
            "V  4 1  F  4 0 0  0 0 1  0 0 0",
            "V  5 1  F  8 0 0  0 0 1  0 0 0",
            "V  6 1  F  8 4 0  0 0 1  0 0 0",
            "V  7 1  F  4 4 0  0 0 1  0 0 0",
            "P  pano0  0 0  0  2 2 1.5  0 0 0 0 0",
            "I  0 0   pano0_i0  0 0  1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1  1000 0 640 0 1000 512 0 0 1  1280 1024  2 2 1.5  0 0 0 0 0",
            "C  0  1 wall  1 wall  0 0 0 0 0",
            "C  1  25 dining#chair  3 chair  0 0 0 0 0",
            "O  0 0 1  1 1 0.5  1 0 0  0 1 0  0.3 0.3 0.5  0 0 0 0 0 0 0 0",
            "O  1 -1 -1  6 2 1  0 0 1  1 0 0  1 0.2 0.2  0 0 0 0 0 0 0 0",
            "E  0 0 17  0.5  1 1 0.5  0.7 0.7 0  1.3 1.3 1  0 0 0 0 0",
            "E  1 -1 18  0.5  6 2 1  5 1.8 0.8  7 2.2 1.2  0 0 0 0 0",
        ]
        .join("\n")
            + "\n"
    }

    fn replace_line(text: &str, line: usize, with: &str) -> String {
        text.lines()
            .enumerate()
            .map(|(i, l)| if i + 1 == line { with } else { l })
            .collect::<Vec<_>>()
            .join("\n")
            + "\n"
    }

    fn err_of(text: &str) -> HouseError {
        parse_str(text).expect_err("must fail")
    }

    #[test]
    fn sample_parses_every_record_type() {
        let h = parse_str(&sample()).unwrap();
        assert_eq!(h.version, "1.1");
        assert_eq!(h.header.name.as_deref(), Some("house 1"));
        assert_eq!(h.header.label, None);
        assert_eq!(h.header.counts.regions, 2);
        assert_eq!(h.levels.len(), 1);
        assert_eq!(h.levels[0].nregions, 2);
        assert_eq!(h.regions[1].label, "l");
        assert_eq!(h.regions[1].level, Some(0));
        assert_eq!(h.regions[0].height, 2.5);
        assert_eq!(h.regions[1].bbox.lo, [4.0, 0.0, 0.0]);
        assert_eq!(h.portals.len(), 1);
        assert_eq!(h.portals[0].regions, [Some(0), Some(1)]);
        assert_eq!(h.surfaces[1].region, Some(1));
        assert_eq!(h.surfaces[1].label, "F");
        assert_eq!(h.vertices[6].position, [8.0, 4.0, 0.0]);
        assert_eq!(h.vertices[6].surface, 1);
        assert_eq!(h.panoramas[0].name, "pano0");
        assert_eq!(h.panoramas[0].position, [2.0, 2.0, 1.5]);
        assert_eq!(h.images[0].panorama, 0);
        assert_eq!(h.images[0].width, 1280);
        assert_eq!(h.images[0].intrinsics[2], 640.0);
        assert_eq!(h.categories[1].mapping_index, Some(25));
        assert_eq!(
            h.categories[1].mapping_name.as_deref(),
            Some("dining chair")
        );
        assert_eq!(h.categories[1].mpcat40_index, Some(3));
        assert_eq!(h.objects[0].category, Some(1));
        assert_eq!(h.objects[0].radii, [0.3, 0.3, 0.5]);
        assert_eq!(h.objects[1].region, None);
        assert_eq!(h.objects[1].axis0, [0.0, 0.0, 1.0]);
        assert_eq!(h.segments[0].id, 17);
        assert_eq!(h.segments[1].object, None);
        let outlines = h.surface_outlines();
        assert_eq!(outlines[0].len(), 4);
        assert_eq!(outlines[1][0].position, [4.0, 0.0, 0.0]);
    }

    #[test]
    fn windows_line_endings_and_trailing_whitespace_are_tolerated() {
        let crlf = sample().replace('\n', "  \t\r\n");
        let h = parse_str(&crlf).unwrap();
        assert_eq!(h.segments.len(), 2);
        assert_eq!(h.segments[1].bbox.hi, [7.0, 2.2, 1.2]);
    }

    #[test]
    fn header_line_and_version_are_checked() {
        let e = err_of(&sample().replacen("ASCII 1.1", "PLY 1.1", 1));
        assert_eq!(e.line, 1);
        assert!(e.message.contains("ASCII 1.1"), "{e}");
        let e = err_of(&sample().replacen("ASCII 1.1", "ASCII 2.0", 1));
        assert!(e.line == 1 && e.message.contains("version `2.0`"), "{e}");
        let e = err_of("");
        assert!(e.message.contains("empty file"), "{e}");
        let e = err_of("ASCII 1.1\n");
        assert!(e.message.contains("without an H record"), "{e}");
    }

    #[test]
    fn h_record_errors_name_the_line_and_field() {
        let s = sample();
        let e = err_of(&replace_line(&s, 2, "H - - 1 1 8"));
        assert_eq!(e.line, 2);
        assert!(e.message.contains("H record: 6 fields, expected 29"), "{e}");
        let e = err_of(&s.replacen("H  house#1  -  1 1 8", "H  house#1  -  1 x 8", 1));
        assert!(e.line == 2 && e.message.contains("#panoramas"), "{e}");
        let e = err_of(&s.replacen("H  house#1  -  1 1 8", "H  house#1  -  1 -1 8", 1));
        assert!(e.message.contains("expected 0 or more"), "{e}");
        let e = err_of(&s.replacen("H  ", "R 0 0 0 0 k 0 0 0 0 0 0 1 1 1 1 0 0 0 0\nH  ", 1));
        assert!(
            e.line == 2 && e.message.contains("`R` record before the H record"),
            "{e}"
        );
        let twice = s.replacen(
            "L  0",
            "H  -  -  1 1 8 2 2 2 2 2 1  1  0 0 0 0 0  0 0 0  8 4 3  0 0 0 0 0\nL  0",
            1,
        );
        let e = err_of(&twice);
        assert!(e.line == 3 && e.message.contains("second H record"), "{e}");
    }

    #[test]
    fn l_record_errors() {
        let s = sample();
        let e = err_of(&replace_line(&s, 3, "L  0  2  -  2 2 0  0 0 0  8 4"));
        assert!(
            e.line == 3 && e.message.contains("L record: 12 fields, expected 18"),
            "{e}"
        );
        let e = err_of(&replace_line(
            &s,
            3,
            "L  0  2  -  2 2 nan  0 0 0  8 4 3  0 0 0 0 0",
        ));
        assert!(
            e.line == 3 && e.message.contains("not a finite number"),
            "{e}"
        );
        let e = err_of(&replace_line(
            &s,
            3,
            "L  1  2  -  2 2 0  0 0 0  8 4 3  0 0 0 0 0",
        ));
        assert!(e.message.contains("index 1, expected 0"), "{e}");
    }

    #[test]
    fn r_record_errors() {
        let s = sample();
        let e = err_of(&replace_line(
            &s,
            4,
            "R  0 3  0 0  k  2 2 0  0 0 0  4 4 2.5  2.5  0 0 0 0",
        ));
        assert!(
            e.line == 4
                && e.message
                    .contains("level_index 3 out of range (the file has 1 levels)"),
            "{e}"
        );
        let e = err_of(&replace_line(
            &s,
            4,
            "R  0 0  0 0  k  2 2 0  0 0 0  4 4 2.5  tall  0 0 0 0",
        ));
        assert!(
            e.line == 4 && e.message.contains("field 15 (height) is `tall`"),
            "{e}"
        );
        let e = err_of(&replace_line(
            &s,
            5,
            "R  0 0  0 0  l  6 2 0  4 0 0  8 4 2.5  2.5  0 0 0 0",
        ));
        assert!(
            e.line == 5 && e.message.contains("index 0, expected 1"),
            "{e}"
        );
    }

    #[test]
    fn portal_and_panorama_p_record_errors() {
        let s = sample();
        let e = err_of(&replace_line(
            &s,
            6,
            "P  0 0 7  -  3.9 1 0  4.1 2 2  0 0 0 0",
        ));
        assert!(
            e.line == 6 && e.message.contains("region index 7 out of range"),
            "{e}"
        );
        let e = err_of(&replace_line(&s, 6, "P  0 0 1  -  3.9 1 0  4.1 2"));
        assert!(
            e.line == 6
                && e.message
                    .contains("portal P record: 10 fields, expected 15"),
            "{e}"
        );
        let e = err_of(&replace_line(
            &s,
            17,
            "P  pano0  0 5  0  2 2 1.5  0 0 0 0 0",
        ));
        assert!(
            e.line == 17 && e.message.contains("panorama P record: region_index 5"),
            "{e}"
        );
        let e = err_of(&replace_line(
            &s,
            17,
            "P  pano0  3 0  0  2 2 1.5  0 0 0 0 0",
        ));
        assert!(
            e.message.contains("panorama P record: index 3, expected 0"),
            "{e}"
        );
        // No portals announced: the first P record is a panorama.
        let no_portal = replace_line(&s, 6, "").replacen("2 2 2 2 2 1  1", "2 2 2 2 2 0  1", 1);
        let h = parse_str(&no_portal).unwrap();
        assert!(h.portals.is_empty() && h.panoramas.len() == 1);
    }

    #[test]
    fn s_and_v_record_errors() {
        let s = sample();
        let e = err_of(&replace_line(
            &s,
            7,
            "S  0 9  0  F  2 2 0  0 0 1  0 0 0  4 4 0  0 0 0 0 0",
        ));
        assert!(
            e.line == 7 && e.message.contains("S record: region_index 9"),
            "{e}"
        );
        let e = err_of(&replace_line(&s, 9, "V  0 4  F  0 0 0  0 0 1  0 0 0"));
        assert!(
            e.line == 9
                && e.message
                    .contains("V record: surface_index 4 out of range (the file has 2 surfaces)"),
            "{e}"
        );
        let e = err_of(&replace_line(&s, 9, "V  0 -1  F  0 0 0  0 0 1  0 0 0"));
        assert!(
            e.line == 9 && e.message.contains("expected 0 or more"),
            "{e}"
        );
        let e = err_of(&replace_line(&s, 10, "V  1 0  F  4 inf 0  0 0 1  0 0 0"));
        assert!(
            e.line == 10 && e.message.contains("not a finite number"),
            "{e}"
        );
    }

    #[test]
    fn i_c_o_e_record_errors() {
        let s = sample();
        let e = err_of(&replace_line(&s, 18, "I  0 2   pano0_i0  0 0  1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1  1000 0 640 0 1000 512 0 0 1  1280 1024  2 2 1.5  0 0 0 0 0"));
        assert!(
            e.line == 18 && e.message.contains("I record: panorama_index 2"),
            "{e}"
        );
        let e = err_of(&replace_line(&s, 18, "I  0 0   pano0_i0  0 0  1 0 0 0"));
        assert!(
            e.line == 18 && e.message.contains("I record: 10 fields, expected 41"),
            "{e}"
        );
        let e = err_of(&replace_line(
            &s,
            20,
            "C  1  x dining#chair  3 chair  0 0 0 0 0",
        ));
        assert!(
            e.line == 20 && e.message.contains("category_mapping_index"),
            "{e}"
        );
        let e = err_of(&replace_line(
            &s,
            21,
            "O  0 0 5  1 1 0.5  1 0 0  0 1 0  0.3 0.3 0.5  0 0 0 0 0 0 0 0",
        ));
        assert!(
            e.line == 21
                && e.message
                    .contains("O record: category_index 5 out of range"),
            "{e}"
        );
        let e = err_of(&replace_line(
            &s,
            21,
            "O  0 0 1  1 1 0.5  1 0 0  0 1 0  0.3 -0.3 0.5  0 0 0 0 0 0 0 0",
        ));
        assert!(
            e.line == 21 && e.message.contains("negative box radius"),
            "{e}"
        );
        let e = err_of(&replace_line(
            &s,
            23,
            "E  0 4 17  0.5  1 1 0.5  0.7 0.7 0  1.3 1.3 1  0 0 0 0 0",
        ));
        assert!(
            e.line == 23 && e.message.contains("E record: object_index 4"),
            "{e}"
        );
        let e = err_of(&replace_line(
            &s,
            23,
            "E  0 0 17.5  0.5  1 1 0.5  0.7 0.7 0  1.3 1.3 1  0 0 0 0 0",
        ));
        assert!(
            e.message.contains("field 3 (id) is `17.5`, not an integer"),
            "{e}"
        );
    }

    #[test]
    fn counts_are_checked_against_the_header() {
        let s = sample();
        // One E record missing: the file is truncated.
        let cut: String = s.lines().take(23).collect::<Vec<_>>().join("\n") + "\n";
        let e = err_of(&cut);
        assert_eq!(e.line, 23);
        assert!(
            e.message.contains("1 of the 2 segments (E records)")
                && e.message.contains("line 2")
                && e.message.contains("truncated"),
            "{e}"
        );
        // One O record too many.
        let extra = s.replacen(
            "E  0",
            "O  2 0 1  1 1 0.5  1 0 0  0 1 0  0.3 0.3 0.5  0 0 0 0 0 0 0 0\nE  0",
            1,
        );
        let e = err_of(&extra);
        assert!(
            e.line == 23 && e.message.contains("one more than the 2 objects"),
            "{e}"
        );
    }

    #[test]
    fn unknown_records_and_bad_bytes_are_errors() {
        let s = sample();
        let e = err_of(&replace_line(&s, 4, "X 1 2 3"));
        assert!(
            e.line == 4 && e.message.contains("unknown record type `X`"),
            "{e}"
        );
        let mut bytes = sample().into_bytes();
        let at = bytes.iter().position(|&b| b == b'k').unwrap();
        bytes[at] = 0xff;
        let e = parse(&bytes).unwrap_err();
        assert!(e.line == 4 && e.message.contains("not UTF-8"), "{e}");
    }

    #[test]
    fn blank_lines_are_skipped_and_line_numbers_stay_true() {
        let s = sample().replacen("\nR  1", "\n\n   \nR  1", 1);
        let h = parse_str(&s).unwrap();
        assert_eq!(h.regions[1].line, 7);
        let bad = s.replacen("R  1 0  0 0  l  6", "R  1 0  0 0  l  z", 1);
        assert_eq!(err_of(&bad).line, 7);
    }
}
