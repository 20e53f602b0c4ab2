//! Category text for glTF scenes: HM3D `.semantic.txt` tables ([`SemanticTable`]), Habitat
//! category-mapping TSVs such as `hm3dsem_category_mappings.tsv` ([`CategoryMap`]), and the
//! rule that reads an object category out of a node or template name ([`category_from_name`]).
//!
//! Text files may have a byte-order mark, CRLF line ends and trailing whitespace. Where this
//! module's job ends: it parses and names; tying semantic ids to geometry is the loader's.

use crate::file_error::FileError;
use std::collections::{BTreeSet, HashMap, HashSet};
use std::path::Path;

use crate::invalid::Invalid;
use crate::scene::{Categories, SurfaceKind};

use super::super::LoadError;

/// One line of a `.semantic.txt`: `id,HEXRGB,"category",regionId`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SemanticEntry {
    /// Semantic id.
    pub id: u32,
    /// The id's colour in the semantic mesh (8-bit RGB).
    pub color: [u8; 3],
    /// Raw category as annotated (`chair`, `floor /otherroom`).
    pub category: String,
    /// Region (room) id; negative when the object has none.
    pub region: i64,
    /// 1-based line in the file.
    pub line: usize,
}

/// A parsed `.semantic.txt`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SemanticTable {
    /// Entries in file order.
    pub entries: Vec<SemanticEntry>,
}

impl SemanticTable {
    /// Parses the text of `path`. A first line that does not start with a digit is a title
    /// (`HM3D Semantic Annotations`); blank lines are skipped; every other line must be a
    /// record, and ids must be unique. Errors name the file and the line.
    pub fn parse(text: &str, path: &Path) -> Result<Self, LoadError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut entries: Vec<SemanticEntry> = Vec::new();
        let mut seen: HashMap<u32, usize> = HashMap::new();
        for (i, raw) in text.lines().enumerate() {
            let line = raw.trim();
            if line.is_empty() {
                continue;
            }
            if i == 0 && !line.starts_with(|c: char| c.is_ascii_digit()) {
                continue;
            }
            let entry = parse_record(line, i + 1).map_err(|m| {
                LoadError::parse(
                    path,
                    format!(
                        "line {}: {m} (expected `id,HEXRGB,\"category\",regionId`, got `{}`)",
                        i + 1,
                        clip(line)
                    ),
                )
            })?;
            if let Some(first) = seen.insert(entry.id, i + 1) {
                return Err(LoadError::parse(
                    path,
                    format!(
                        "line {}: semantic id {} already defined on line {first}",
                        i + 1,
                        entry.id
                    ),
                ));
            }
            entries.push(entry);
        }
        Ok(SemanticTable { entries })
    }

    /// Reads and parses a `.semantic.txt`.
    pub fn read(path: &Path) -> Result<Self, LoadError> {
        let text = std::fs::read_to_string(path).map_err(|source| LoadError::Io(FileError::new(path, source)))?;
        Self::parse(&text, path)
    }

    /// Entry index by colour (the first entry wins when two share a colour).
    pub fn by_color(&self) -> HashMap<[u8; 3], usize> {
        let mut map = HashMap::new();
        for (i, e) in self.entries.iter().enumerate() {
            map.entry(e.color).or_insert(i);
        }
        map
    }

    /// The distinct non-negative region ids.
    pub fn regions(&self) -> BTreeSet<i64> {
        self.entries
            .iter()
            .map(|e| e.region)
            .filter(|r| *r >= 0)
            .collect()
    }
}

fn clip(s: &str) -> String {
    if s.chars().count() > 80 {
        format!("{}…", s.chars().take(80).collect::<String>())
    } else {
        s.to_string()
    }
}

fn parse_record(line: &str, number: usize) -> Result<SemanticEntry, Invalid> {
    let (id, rest) = line.split_once(',').ok_or("no comma")?;
    let (hex, rest) = rest.split_once(',').ok_or("missing colour or category")?;
    let id: u32 = id
        .trim()
        .parse()
        .map_err(|_| format!("id `{}` is not a non-negative integer", id.trim()))?;
    let hex = hex.trim();
    let digits = hex.strip_prefix('#').unwrap_or(hex);
    if digits.len() != 6 || !digits.chars().all(|c| c.is_ascii_hexdigit()) {
        return Err(format!("colour `{hex}` is not 6 hex digits").into());
    }
    let v = u32::from_str_radix(digits, 16).map_err(|_| format!("colour `{hex}`"))?;
    let color = [(v >> 16) as u8, (v >> 8) as u8, v as u8];
    let rest = rest.trim_start();
    let (category, region) = if let Some(quoted) = rest.strip_prefix('"') {
        // A quoted category may hold commas; `""` is a quote.
        let mut category = String::new();
        let mut chars = quoted.char_indices().peekable();
        let mut end = None;
        while let Some((i, c)) = chars.next() {
            if c == '"' {
                if chars.peek().is_some_and(|(_, n)| *n == '"') {
                    category.push('"');
                    chars.next();
                } else {
                    end = Some(i + 1);
                    break;
                }
            } else {
                category.push(c);
            }
        }
        let end = end.ok_or("category quote not closed")?;
        let after = quoted[end..].trim_start();
        let region = after
            .strip_prefix(',')
            .ok_or("missing region id after the category")?;
        (category, region)
    } else {
        rest.rsplit_once(',')
            .map(|(c, r)| (c.trim().to_string(), r))
            .ok_or("missing region id")?
    };
    let region = region.trim();
    let region: i64 = region
        .parse()
        .map_err(|_| format!("region id `{region}` is not an integer"))?;
    Ok(SemanticEntry {
        id,
        color,
        category: category.trim().to_string(),
        region,
        line: number,
    })
}

/// What a category-mapping table says about one raw category.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MappedCategory {
    /// The cleaned category (`armchair` for `aemchair`).
    pub category: String,
    /// Its mpcat40 class, if the table has the column.
    pub mpcat40: Option<String>,
    /// Its NYU-40 class, if the table has the column.
    pub nyu40: Option<String>,
}

/// A Habitat category-mapping TSV: tab-separated, a header naming `raw_category` and
/// `category`, optionally `mpcat40` and `nyu40class`. Lookups are case-insensitive.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CategoryMap {
    map: HashMap<String, MappedCategory>,
    cleaned: HashSet<String>,
}

fn key(s: &str) -> String {
    s.trim().to_ascii_lowercase()
}

impl CategoryMap {
    /// Parses the text of `path`; errors name the file and the line.
    pub fn parse(text: &str, path: &Path) -> Result<Self, LoadError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let Some((_, header)) = lines.next() else {
            return Err(LoadError::parse(path, "empty category table"));
        };
        let columns: Vec<String> = header.trim_end().split('\t').map(key).collect();
        let col = |name: &str| columns.iter().position(|c| c == name);
        let (Some(raw), Some(category)) = (col("raw_category"), col("category")) else {
            return Err(LoadError::parse(
                path,
                format!(
                    "line 1: header `{}` needs tab-separated `raw_category` and `category` columns",
                    clip(header.trim())
                ),
            ));
        };
        let mpcat40 = col("mpcat40");
        let nyu40 = col("nyu40class");
        let needed = [Some(raw), Some(category), mpcat40, nyu40]
            .into_iter()
            .flatten()
            .max()
            .unwrap_or(0);
        let mut map = HashMap::new();
        for (i, line) in lines {
            let fields: Vec<&str> = line.trim_end_matches(['\r', '\n']).split('\t').collect();
            if fields.len() <= needed {
                return Err(LoadError::parse(
                    path,
                    format!(
                        "line {}: {} tab-separated fields, the header needs {}",
                        i + 1,
                        fields.len(),
                        needed + 1
                    ),
                ));
            }
            let get = |c: Option<usize>| {
                c.map(|c| fields[c].trim().to_string())
                    .filter(|s| !s.is_empty())
            };
            let Some(cat) = get(Some(category)) else {
                continue;
            };
            map.entry(key(fields[raw])).or_insert(MappedCategory {
                category: cat,
                mpcat40: get(mpcat40),
                nyu40: get(nyu40),
            });
        }
        let cleaned = map.values().map(|m| key(&m.category)).collect();
        Ok(CategoryMap { map, cleaned })
    }

    /// Reads and parses a category-mapping TSV.
    pub fn read(path: &Path) -> Result<Self, LoadError> {
        let text = std::fs::read_to_string(path).map_err(|source| LoadError::Io(FileError::new(path, source)))?;
        Self::parse(&text, path)
    }

    /// The mapping of a raw category.
    pub fn get(&self, raw: &str) -> Option<&MappedCategory> {
        self.map.get(&key(raw))
    }

    /// True when `name` is a raw or cleaned category of the table.
    fn knows(&self, name: &str) -> bool {
        let k = key(name);
        self.map.contains_key(&k) || self.cleaned.contains(&k)
    }

    /// The labels of an object whose raw category is `raw`: fine = `raw`, coarse / mpcat40 /
    /// NYU-40 from the table when it knows `raw`.
    pub fn categories(&self, raw: &str) -> Categories {
        let raw = raw.trim();
        let mapped = self.get(raw);
        Categories {
            fine: Some(raw.to_string()),
            coarse: mapped.map(|m| m.category.clone()),
            nyu40: mapped.and_then(|m| m.nyu40.clone()),
            mpcat40: mapped.and_then(|m| m.mpcat40.clone()),
        }
    }
}

/// NYU-40 class names (as in Matterport3D's mapping table).
const NYU40: [&str; 40] = [
    "wall",
    "floor",
    "cabinet",
    "bed",
    "chair",
    "sofa",
    "table",
    "door",
    "window",
    "bookshelf",
    "picture",
    "counter",
    "blinds",
    "desk",
    "shelves",
    "curtain",
    "dresser",
    "pillow",
    "mirror",
    "floor mat",
    "clothes",
    "ceiling",
    "books",
    "refridgerator",
    "television",
    "paper",
    "towel",
    "shower curtain",
    "box",
    "whiteboard",
    "person",
    "night stand",
    "toilet",
    "sink",
    "lamp",
    "bathtub",
    "bag",
    "otherstructure",
    "otherfurniture",
    "otherprop",
];

/// mpcat40 class names (without `void`, `misc`, `objects` and `unlabeled`, which name no
/// object).
const MPCAT40: [&str; 36] = [
    "wall",
    "floor",
    "chair",
    "door",
    "table",
    "picture",
    "cabinet",
    "cushion",
    "window",
    "sofa",
    "bed",
    "curtain",
    "chest_of_drawers",
    "plant",
    "sink",
    "stairs",
    "ceiling",
    "toilet",
    "stool",
    "towel",
    "mirror",
    "tv_monitor",
    "shower",
    "column",
    "bathtub",
    "counter",
    "fireplace",
    "lighting",
    "beam",
    "railing",
    "shelving",
    "blinds",
    "gym_equipment",
    "seating",
    "board_panel",
    "furniture",
];

/// A few common object words the class lists spell differently.
const EXTRA_WORDS: [&str; 12] = [
    "lamp",
    "tv",
    "fridge",
    "refrigerator",
    "bookcase",
    "wardrobe",
    "armchair",
    "stove",
    "oven",
    "microwave",
    "plant",
    "rug",
];

/// The architectural surface a category names, if any (`floor`, `wall`, `ceiling` in the
/// fine, coarse or mpcat40 label).
pub fn structural_kind(c: &Categories) -> Option<SurfaceKind> {
    let first_word = |s: &str| {
        s.split(|ch: char| ch == '/' || ch.is_whitespace())
            .find(|w| !w.is_empty())
            .map(str::to_ascii_lowercase)
    };
    let of = |s: &str| match s.trim().to_ascii_lowercase().as_str() {
        "floor" | "floors" => Some(SurfaceKind::Floor),
        "wall" | "walls" => Some(SurfaceKind::Wall),
        "ceiling" | "ceilings" => Some(SurfaceKind::Ceiling),
        _ => None,
    };
    if let Some(m) = c.mpcat40.as_deref() {
        return of(m);
    }
    [c.coarse.as_deref(), c.fine.as_deref()]
        .into_iter()
        .flatten()
        .find_map(|s| of(s).or_else(|| first_word(s).and_then(|w| of(&w))))
}

/// The object category a node or template name spells, if any: the name lowercased, instance
/// suffixes dropped (`chair_1`, `Chair.001`, `chair 2`), then the longest `_`/space-separated
/// tail of it that is a known category (NYU-40, mpcat40, a few common words, or `map`'s raw and
/// cleaned categories). `frl_apartment_chair_01` → `chair`; `Cube.004` → none. Structural
/// names (floor, wall, ceiling) give none: such geometry stays a surface.
pub fn category_from_name(name: &str, map: &CategoryMap) -> Option<String> {
    let mut base = name.trim().to_ascii_lowercase();
    loop {
        let trimmed = base
            .trim_end_matches(|c: char| c.is_ascii_digit())
            .trim_end_matches(['_', '.', '-', '#', ' ']);
        if trimmed.len() == base.len() || trimmed.is_empty() {
            break;
        }
        base = trimmed.to_string();
    }
    let words: Vec<&str> = base
        .split(['_', ' ', '-', '.'])
        .filter(|w| !w.is_empty())
        .collect();
    let known = |c: &str| {
        let spaced = c.replace('_', " ");
        let under = c.replace(' ', "_");
        NYU40.contains(&spaced.as_str())
            || MPCAT40.contains(&under.as_str())
            || EXTRA_WORDS.contains(&c)
            || map.knows(&spaced)
            || map.knows(&under)
    };
    for start in 0..words.len() {
        let candidate = words[start..].join(" ");
        if known(&candidate) {
            let cats = Categories {
                fine: Some(candidate.clone()),
                ..Default::default()
            };
            if structural_kind(&cats).is_some() {
                return None;
            }
            return Some(candidate.replace(' ', "_"));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn semantic_lines_parse_with_quotes_commas_and_crlf() {
        let text = "HM3D Semantic Annotations\r\n1,9A8A8A,\"wall\",0\r\n2,#c4d8b1,\"chair, folding\",3  \r\n\r\n3,ABCDEF,rug,-1\r\n";
        let t = SemanticTable::parse(text, Path::new("x.semantic.txt")).unwrap();
        assert_eq!(t.entries.len(), 3);
        assert_eq!(t.entries[0].color, [0x9a, 0x8a, 0x8a]);
        assert_eq!(t.entries[1].category, "chair, folding");
        assert_eq!(t.entries[1].region, 3);
        assert_eq!(t.entries[2].category, "rug");
        assert_eq!(t.entries[2].region, -1);
        assert_eq!(t.regions().into_iter().collect::<Vec<_>>(), vec![0, 3]);
    }

    #[test]
    fn bad_semantic_lines_name_the_line() {
        let e = SemanticTable::parse("1,FFFFFF,\"a\",0\n2,GGGGGG,\"b\",0\n", Path::new("s.txt"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("s.txt: line 2: colour `GGGGGG`"), "{e}");
        let dup = SemanticTable::parse("1,FFFFFF,\"a\",0\n1,000000,\"b\",0\n", Path::new("s.txt"))
            .unwrap_err()
            .to_string();
        assert!(
            dup.contains("line 2: semantic id 1 already defined on line 1"),
            "{dup}"
        );
    }

    #[test]
    fn names_give_categories_but_not_structure() {
        let map = CategoryMap::default();
        assert_eq!(
            category_from_name("chair_1", &map).as_deref(),
            Some("chair")
        );
        assert_eq!(
            category_from_name("Chair.001", &map).as_deref(),
            Some("chair")
        );
        assert_eq!(
            category_from_name("frl_apartment_chair_01", &map).as_deref(),
            Some("chair")
        );
        assert_eq!(
            category_from_name("night_stand_2", &map).as_deref(),
            Some("night_stand")
        );
        assert_eq!(category_from_name("Cube.004", &map), None);
        assert_eq!(category_from_name("Floor", &map), None);
        assert_eq!(category_from_name("wall_3", &map), None);
    }

    #[test]
    fn category_tsv_maps_raw_names() {
        let text = "raw_category\tcategory\tmpcat40\r\naemchair\tarmchair\tchair\r\nfloor mat\tfloor mat\tfloor\r\n";
        let map = CategoryMap::parse(text, Path::new("m.tsv")).unwrap();
        let c = map.categories("Aemchair");
        assert_eq!(c.coarse.as_deref(), Some("armchair"));
        assert_eq!(c.mpcat40.as_deref(), Some("chair"));
        assert_eq!(
            structural_kind(&map.categories("floor mat")),
            Some(SurfaceKind::Floor)
        );
        let bad = CategoryMap::parse("raw_category category\n", Path::new("m.tsv"))
            .unwrap_err()
            .to_string();
        assert!(bad.contains("line 1"), "{bad}");
    }
}
