//! The lookup tables of the Matterport3D loader: region letters → MINOS classes (compiled in
//! from `data/taxonomy/mp3d_region_labels.csv`), and the category tables Matterport publishes
//! (`category_mapping.tsv`, `mpcat40.tsv`), read from the dataset root when present.
//!
//! The category tables are never copied into minos: without them, categories come from the
//! `C` records of each `.house` file (which carry the raw and mpcat40 names). This file only
//! reads tables; [`super`] decides what to do with them.

use crate::file_error::FileError;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::invalid::Invalid;
use crate::scene::RoomClass;

use super::super::LoadError;

/// One region label of the built-in table.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RegionLabel {
    /// Matterport3D's name for the label (`family room`).
    pub name: String,
    /// The MINOS room class.
    pub class: RoomClass,
}

/// Region letters (`a`, `b`, …, `B`, `-`) to labels and MINOS classes.
#[derive(Debug, Clone)]
pub struct RegionLabels {
    map: HashMap<String, RegionLabel>,
}

impl RegionLabels {
    /// The table compiled into minos (`data/taxonomy/mp3d_region_labels.csv`).
    pub fn builtin() -> Self {
        let text = include_str!("../../../../data/taxonomy/mp3d_region_labels.csv");
        let map = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with('#'))
            .skip(1)
            .filter_map(|l| {
                let f: Vec<&str> = l.split(',').map(str::trim).collect();
                let class = RoomClass::from_label(f.get(2)?)?;
                Some((
                    f.first()?.to_string(),
                    RegionLabel {
                        name: f.get(1)?.to_string(),
                        class,
                    },
                ))
            })
            .collect();
        RegionLabels { map }
    }

    /// The label of a region letter (case-sensitive: `s` stairs, `S` spa), if known.
    pub fn get(&self, letter: &str) -> Option<&RegionLabel> {
        self.map.get(letter)
    }

    /// The MINOS class of a region letter (`other` when unknown).
    #[cfg(test)]
    pub(crate) fn class_of(&self, letter: &str) -> RoomClass {
        self.get(letter).map_or(RoomClass::Other, |l| l.class)
    }

}

/// One row of `category_mapping.tsv`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CategoryRow {
    /// The raw annotation text (`dining chair`).
    pub raw: String,
    /// Its cleaned-up category (`category` column), if any.
    pub category: Option<String>,
    /// NYU-40 class name, if any.
    pub nyu40: Option<String>,
    /// mpcat40 index, if any.
    pub mpcat40_index: Option<usize>,
    /// mpcat40 name, if any.
    pub mpcat40: Option<String>,
}

/// `category_mapping.tsv` (rows by their 1-based `index`) and `mpcat40.tsv` (names and
/// colours by mpcat40 index), either of which may be missing.
#[derive(Debug, Clone, Default)]
pub struct CategoryTables {
    rows: HashMap<usize, CategoryRow>,
    mpcat40: Mpcat40Table,
    /// The files read.
    pub sources: Vec<PathBuf>,
}

impl CategoryTables {
    /// Reads `mapping` (a `category_mapping.tsv`) and `mpcat40` (an `mpcat40.tsv`) when given.
    pub fn read(mapping: Option<&Path>, mpcat40: Option<&Path>) -> Result<Self, LoadError> {
        let mut t = CategoryTables::default();
        let read = |p: &Path| {
            std::fs::read_to_string(p).map_err(|source| LoadError::Io(FileError::new(p, source)))
        };
        if let Some(p) = mapping {
            t.rows = parse_category_mapping(&read(p)?).map_err(|m| LoadError::parse(p, m))?;
            t.sources.push(p.to_path_buf());
        }
        if let Some(p) = mpcat40 {
            t.mpcat40 = parse_mpcat40(&read(p)?).map_err(|m| LoadError::parse(p, m))?;
            t.sources.push(p.to_path_buf());
        }
        Ok(t)
    }

    /// The row with this 1-based `index`, when the mapping table was read.
    pub fn row(&self, index: usize) -> Option<&CategoryRow> {
        self.rows.get(&index)
    }

    /// Name of an mpcat40 index, when `mpcat40.tsv` was read.
    pub fn mpcat40_name(&self, index: usize) -> Option<&str> {
        self.mpcat40.get(&index).map(|(n, _)| n.as_str())
    }

    /// Display colour (linear-ish RGB in `[0, 1]`) of an mpcat40 index, when known.
    pub fn mpcat40_color(&self, index: usize) -> Option<[f32; 3]> {
        self.mpcat40.get(&index).and_then(|(_, c)| *c)
    }
}

/// A TSV's rows as `(line number, fields)`.
type Rows<'a> = Vec<(usize, Vec<&'a str>)>;

/// mpcat40 names and colours by index.
pub type Mpcat40Table = HashMap<usize, (String, Option<[f32; 3]>)>;

/// Splits a TSV into its header columns and `(line number, fields)` rows, tolerating `\r\n`.
fn tsv(text: &str) -> Result<(Vec<&str>, Rows<'_>), Invalid> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches(['\r', ' '])));
    let (_, header) = lines
        .by_ref()
        .find(|(_, l)| !l.trim().is_empty())
        .ok_or_else(|| "empty file".to_string())?;
    let cols = header.split('\t').map(str::trim).collect();
    let rows = lines
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(n, l)| (n, l.split('\t').map(str::trim).collect()))
        .collect();
    Ok((cols, rows))
}

fn column(cols: &[&str], name: &str) -> Result<usize, Invalid> {
    cols.iter()
        .position(|c| *c == name)
        .ok_or_else(|| Invalid::new(format!("no `{name}` column")).at("line 1"))
}

fn optional(s: Option<&&str>) -> Option<String> {
    s.filter(|v| !v.is_empty() && **v != "-")
        .map(|v| v.to_string())
}

/// Parses `category_mapping.tsv` text: rows by their `index` column.
pub fn parse_category_mapping(text: &str) -> Result<HashMap<usize, CategoryRow>, Invalid> {
    let (cols, rows) = tsv(text)?;
    let index = column(&cols, "index")?;
    let raw = column(&cols, "raw_category")?;
    let category = cols.iter().position(|c| *c == "category");
    let nyu40 = cols.iter().position(|c| *c == "nyu40class");
    let mp_index = cols.iter().position(|c| *c == "mpcat40index");
    let mp_name = cols.iter().position(|c| *c == "mpcat40");
    let mut out = HashMap::new();
    for (line, f) in rows {
        let i: usize = f
            .get(index)
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| format!("line {line}: `index` is not a non-negative integer"))?;
        let raw = f
            .get(raw)
            .filter(|v| !v.is_empty())
            .ok_or_else(|| format!("line {line}: empty `raw_category`"))?
            .to_string();
        let mpcat40_index = match mp_index.and_then(|c| f.get(c)).filter(|v| !v.is_empty()) {
            Some(v) => Some(
                v.parse()
                    .map_err(|_| format!("line {line}: mpcat40index `{v}` is not an integer"))?,
            ),
            None => None,
        };
        out.insert(
            i,
            CategoryRow {
                raw,
                category: optional(category.and_then(|c| f.get(c))),
                nyu40: optional(nyu40.and_then(|c| f.get(c))),
                mpcat40_index,
                mpcat40: optional(mp_name.and_then(|c| f.get(c))),
            },
        );
    }
    Ok(out)
}

/// Parses `mpcat40.tsv` text: name and `#rrggbb` colour by mpcat40 index.
pub fn parse_mpcat40(text: &str) -> Result<Mpcat40Table, Invalid> {
    let (cols, rows) = tsv(text)?;
    let index = column(&cols, "mpcat40index")?;
    let name = column(&cols, "mpcat40")?;
    let hex = cols.iter().position(|c| *c == "hex");
    let mut out = HashMap::new();
    for (line, f) in rows {
        let i: usize = f
            .get(index)
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| format!("line {line}: `mpcat40index` is not a non-negative integer"))?;
        let n = f
            .get(name)
            .filter(|v| !v.is_empty())
            .ok_or_else(|| format!("line {line}: empty `mpcat40`"))?
            .to_string();
        let color = hex.and_then(|c| f.get(c)).and_then(|h| parse_hex(h));
        out.insert(i, (n, color));
    }
    Ok(out)
}

fn parse_hex(s: &str) -> Option<[f32; 3]> {
    let h = s.strip_prefix('#')?;
    if h.len() != 6 {
        return None;
    }
    let v = u32::from_str_radix(h, 16).ok()?;
    let c = |shift: u32| ((v >> shift) & 0xff) as f32 / 255.0;
    Some([c(16), c(8), c(0)])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_region_letter_of_the_format_has_a_class() {
        let t = RegionLabels::builtin();
        assert_eq!(t.map.len(), 31);
        let expect = [
            ("a", RoomClass::Bathroom),
            ("b", RoomClass::Bedroom),
            ("c", RoomClass::Other),
            ("d", RoomClass::DiningRoom),
            ("e", RoomClass::Hallway),
            ("f", RoomClass::LivingRoom),
            ("k", RoomClass::Kitchen),
            ("l", RoomClass::LivingRoom),
            ("o", RoomClass::Office),
            ("p", RoomClass::Outdoor),
            ("s", RoomClass::Hallway),
            ("S", RoomClass::Bathroom),
            ("t", RoomClass::Bathroom),
            ("y", RoomClass::Outdoor),
            ("i", RoomClass::Office),
            ("B", RoomClass::DiningRoom),
            ("D", RoomClass::DiningRoom),
            ("Z", RoomClass::Other),
            ("-", RoomClass::Other),
        ];
        for (letter, class) in expect {
            assert_eq!(t.class_of(letter), class, "{letter}");
        }
        assert_eq!(t.get("v").map(|l| l.name.as_str()), Some("tv room"));
        assert_eq!(t.get("q"), None);
        assert_eq!(t.class_of("q"), RoomClass::Other);
    }

    #[test]
    fn category_mapping_reads_crlf_rows_by_index() {
        let text = "index\traw_category\tcategory\tcount\tnyuId\tnyu40id\teigen13id\tnyuClass\tnyu40class\tmpcat40index\tmpcat40\r\n\
                    1\twall\twall\t7667\t21\t1\t12\twall\twall\t1\twall\r\n\
                    8\tdoorframe\tdoor frame\t1\t28\t8\t12\tdoor\tdoor\t4\tdoor\r\n";
        let rows = parse_category_mapping(text).unwrap();
        assert_eq!(rows.len(), 2);
        let r = &rows[&8];
        assert_eq!(r.raw, "doorframe");
        assert_eq!(r.category.as_deref(), Some("door frame"));
        assert_eq!(r.nyu40.as_deref(), Some("door"));
        assert_eq!(r.mpcat40_index, Some(4));
        assert_eq!(r.mpcat40.as_deref(), Some("door"));
        let e = parse_category_mapping("index\traw_category\nx\twall\n").unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
        let e = parse_category_mapping("idx\traw\n").unwrap_err();
        assert!(e.to_string().contains("no `index` column"), "{e}");
    }

    #[test]
    fn mpcat40_reads_names_and_colours() {
        let text = "mpcat40index\tmpcat40\thex\twnsynsetkey\tnyu40\tskip\tlabels\n\
                    0\tvoid\t#ffffff\t\tvoid\t\tremove,void\n\
                    2\tfloor\t#708090\tfloor.n.01\tfloor\t\t\n";
        let m = parse_mpcat40(text).unwrap();
        assert_eq!(m[&2].0, "floor");
        let c = m[&2].1.unwrap();
        assert!((c[0] - 0x70 as f32 / 255.0).abs() < 1e-6);
        assert!(parse_mpcat40("mpcat40index\tmpcat40\nzero\tvoid\n").is_err());
    }
}
