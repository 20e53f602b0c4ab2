//! Environment statistics of a set of scenes, as in the MINOS paper's table: houses, levels,
//! rooms, floor area, objects and triangles per house, which room classes houses contain, and
//! the most common object categories.
//!
//! Responsible for computing [`Stats`] from manifest rows ([`compute`], [`compute_split`]) and
//! rendering them as a plain-text table ([`render_table`]). Pure: no files, no printing; the
//! numbers come from the manifest only, never from compiled scenes.

use std::collections::{BTreeSet, HashMap, HashSet};
use std::fmt::Write as _;

use serde::Serialize;

use crate::scene::RoomClass;
use crate::split::{SplitLists, Subset};
use crate::store::manifest::ManifestRow;

/// How many categories [`render_table`] lists.
pub const TOP_CATEGORIES: usize = 20;

/// Summary of one per-house quantity over the houses that loaded.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Arithmetic mean.
    pub mean: f64,
    /// Middle value (mean of the two middle values for an even count).
    pub median: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// Sum over all houses.
    pub total: f64,
}

impl Summary {
    /// The summary of `values`; `None` when there are none.
    pub fn of(values: &[f64]) -> Option<Summary> {
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        let (first, last) = (*sorted.first()?, *sorted.last()?);
        let total: f64 = sorted.iter().sum();
        let median = if n % 2 == 1 {
            sorted[n / 2]
        } else {
            (sorted[n / 2 - 1] + sorted[n / 2]) / 2.0
        };
        Some(Summary {
            mean: total / n as f64,
            median,
            min: first,
            max: last,
            total,
        })
    }
}

/// A name and how many houses have it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct NamedCount {
    /// Room class or object category.
    pub name: String,
    /// Number of houses containing at least one.
    pub houses: usize,
}

/// Statistics of one set of scenes. Per-house summaries cover the houses that loaded and are
/// `None` when none did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stats {
    /// Houses that loaded.
    pub houses: usize,
    /// Houses that failed to ingest.
    pub failed: usize,
    /// Levels per house.
    pub levels: Option<Summary>,
    /// Rooms per house.
    pub rooms: Option<Summary>,
    /// Floor area per house, m².
    pub floor_area: Option<Summary>,
    /// Objects per house.
    pub objects: Option<Summary>,
    /// Triangles per house.
    pub triangles: Option<Summary>,
    /// Houses containing each of the nine MINOS room classes, in class order.
    pub room_classes: Vec<NamedCount>,
    /// Houses containing each object category (fine categories), most common first, ties by
    /// name.
    pub categories: Vec<NamedCount>,
}

/// The statistics of one named set of scenes (`all`, `train`, …).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StatsColumn {
    /// The set's name.
    pub name: String,
    /// Its statistics.
    pub stats: Stats,
}

/// The statistics of `rows`.
pub fn compute(rows: &[ManifestRow]) -> Stats {
    compute_refs(rows.iter())
}

/// One column per subset of `lists` (rows whose id the subset lists) and a `total` column over
/// all listed rows. Listed ids without a row are not counted.
pub fn compute_split(rows: &[ManifestRow], lists: &SplitLists) -> Vec<StatsColumn> {
    let column = |name: &str, ids: HashSet<&str>| StatsColumn {
        name: name.to_string(),
        stats: compute_refs(rows.iter().filter(|r| ids.contains(r.id.as_str()))),
    };
    let ids_of = |s: Subset| lists.get(s).iter().map(String::as_str);
    let mut columns: Vec<StatsColumn> = Subset::ALL
        .iter()
        .map(|&s| column(s.name(), ids_of(s).collect()))
        .collect();
    columns.push(column(
        "total",
        Subset::ALL.into_iter().flat_map(ids_of).collect(),
    ));
    columns
}

fn compute_refs<'a>(rows: impl Iterator<Item = &'a ManifestRow>) -> Stats {
    let mut failed = 0;
    let mut ok: Vec<&ManifestRow> = Vec::new();
    for row in rows {
        if row.is_ok() {
            ok.push(row);
        } else {
            failed += 1;
        }
    }
    let summary =
        |f: fn(&ManifestRow) -> f64| Summary::of(&ok.iter().map(|r| f(r)).collect::<Vec<_>>());

    let mut class_houses = [0usize; RoomClass::ALL.len()];
    let mut category_houses: HashMap<&str, usize> = HashMap::new();
    for row in &ok {
        let classes: BTreeSet<RoomClass> = row
            .room_classes
            .iter()
            .filter_map(|n| RoomClass::from_label(n))
            .collect();
        for c in classes {
            class_houses[usize::from(c.index())] += 1;
        }
        let categories: BTreeSet<&str> = row.categories.iter().map(String::as_str).collect();
        for c in categories {
            *category_houses.entry(c).or_default() += 1;
        }
    }
    let room_classes = RoomClass::ALL
        .iter()
        .zip(class_houses)
        .map(|(c, houses)| NamedCount {
            name: c.name().to_string(),
            houses,
        })
        .collect();
    let mut categories: Vec<NamedCount> = category_houses
        .into_iter()
        .map(|(name, houses)| NamedCount {
            name: name.to_string(),
            houses,
        })
        .collect();
    categories.sort_by(|a, b| b.houses.cmp(&a.houses).then_with(|| a.name.cmp(&b.name)));

    Stats {
        houses: ok.len(),
        failed,
        levels: summary(|r| f64::from(r.nlevels)),
        rooms: summary(|r| f64::from(r.nrooms)),
        floor_area: summary(|r| r.floor_area),
        objects: summary(|r| f64::from(r.nobjects)),
        triangles: summary(|r| r.ntriangles as f64),
        room_classes,
        categories,
    }
}

/// A per-house row of the table: label, which summary, which of its values, decimals.
type SummaryRow = (
    &'static str,
    fn(&Stats) -> Option<&Summary>,
    fn(&Summary) -> f64,
    usize,
);

#[rustfmt::skip]
const SUMMARY_ROWS: [SummaryRow; 10] = [
    ("levels (total)",             |s| s.levels.as_ref(),     |v| v.total,  0),
    ("rooms (total)",              |s| s.rooms.as_ref(),      |v| v.total,  0),
    ("rooms per house (mean)",     |s| s.rooms.as_ref(),      |v| v.mean,   1),
    ("rooms per house (min)",      |s| s.rooms.as_ref(),      |v| v.min,    0),
    ("rooms per house (max)",      |s| s.rooms.as_ref(),      |v| v.max,    0),
    ("floor area m² (mean)",       |s| s.floor_area.as_ref(), |v| v.mean,   1),
    ("floor area m² (median)",     |s| s.floor_area.as_ref(), |v| v.median, 1),
    ("floor area m² (total)",      |s| s.floor_area.as_ref(), |v| v.total,  1),
    ("objects per house (mean)",   |s| s.objects.as_ref(),    |v| v.mean,   1),
    ("triangles per house (mean)", |s| s.triangles.as_ref(),  |v| v.mean,   0),
];

/// One line of the table: a section heading or a labelled row of cells.
enum Line {
    Heading(String),
    Row(String, Vec<String>),
}

/// Renders `columns` side by side: a label column, then one right-aligned column each. The
/// category section lists the [`TOP_CATEGORIES`] most common categories of the last column
/// (the total), with every column's count for them.
pub fn render_table(columns: &[StatsColumn]) -> String {
    let mut lines = Vec::new();
    let row = |label: &str, cell: &dyn Fn(&Stats) -> String| {
        Line::Row(
            label.to_string(),
            columns.iter().map(|c| cell(&c.stats)).collect(),
        )
    };
    lines.push(Line::Row(
        String::new(),
        columns.iter().map(|c| c.name.clone()).collect(),
    ));
    lines.push(row("houses", &|s| s.houses.to_string()));
    lines.push(row("  failed to ingest", &|s| s.failed.to_string()));
    for (label, pick, value, decimals) in SUMMARY_ROWS {
        lines.push(row(label, &|s| {
            pick(s).map_or("-".to_string(), |v| format!("{:.decimals$}", value(v)))
        }));
    }

    lines.push(Line::Heading("houses containing a room class".into()));
    for class in RoomClass::ALL {
        lines.push(row(class.name(), &|s| {
            count_of(&s.room_classes, class.name())
        }));
    }

    let top: Vec<&str> = columns
        .last()
        .map(|c| &c.stats.categories)
        .into_iter()
        .flatten()
        .take(TOP_CATEGORIES)
        .map(|c| c.name.as_str())
        .collect();
    lines.push(Line::Heading(format!(
        "houses containing an object category (top {TOP_CATEGORIES})"
    )));
    if top.is_empty() {
        lines.push(Line::Heading("  (no categories)".into()));
    }
    for name in top {
        lines.push(row(name, &|s| count_of(&s.categories, name)));
    }
    layout(&lines, columns.len())
}

fn count_of(counts: &[NamedCount], name: &str) -> String {
    counts
        .iter()
        .find(|c| c.name == name)
        .map_or(0, |c| c.houses)
        .to_string()
}

/// Pads labels to one width and each column of cells to its own.
fn layout(lines: &[Line], ncolumns: usize) -> String {
    let width = |s: &str| s.chars().count();
    let mut label_w = 0;
    let mut cell_w = vec![0; ncolumns];
    for line in lines {
        if let Line::Row(label, cells) = line {
            label_w = label_w.max(width(label));
            for (w, c) in cell_w.iter_mut().zip(cells) {
                *w = (*w).max(width(c));
            }
        }
    }
    let mut out = String::new();
    for line in lines {
        match line {
            Line::Heading(h) => {
                let _ = write!(out, "\n{h}");
            }
            Line::Row(label, cells) => {
                let _ = write!(out, "{label:<label_w$}");
                for (w, c) in cell_w.iter().zip(cells) {
                    let _ = write!(out, "  {c:>w$}");
                }
            }
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn house(id: &str, nrooms: u32, area: f64, classes: &[&str], cats: &[&str]) -> ManifestRow {
        ManifestRow {
            id: id.into(),
            dataset: "suncg".into(),
            nlevels: 1,
            nrooms,
            nobjects: nrooms * 10,
            floor_area: area,
            ntriangles: u64::from(nrooms) * 1000,
            room_classes: classes.iter().map(|s| s.to_string()).collect(),
            categories: cats.iter().map(|s| s.to_string()).collect(),
            ..Default::default()
        }
    }

    fn rows() -> Vec<ManifestRow> {
        let mut b = house("b", 4, 100.0, &["bedroom", "kitchen"], &["chair", "sofa"]);
        b.nlevels = 2;
        vec![
            house("a", 2, 40.0, &["bedroom"], &["chair"]),
            b,
            house("c", 6, 70.0, &["kitchen", "living_room"], &["chair", "bed"]),
            ManifestRow::failed("d", "suncg", "d.json", "boom".into()),
        ]
    }

    fn count(counts: &[NamedCount], name: &str) -> usize {
        counts
            .iter()
            .find(|c| c.name == name)
            .map_or(0, |c| c.houses)
    }

    #[test]
    fn numbers_of_a_hand_made_set() {
        let s = compute(&rows());
        assert_eq!((s.houses, s.failed), (3, 1));
        // Rooms 2, 4, 6: mean 4, median 4, total 12.
        let rooms = s.rooms.unwrap();
        assert_eq!(
            (rooms.mean, rooms.median, rooms.min, rooms.max, rooms.total),
            (4.0, 4.0, 2.0, 6.0, 12.0)
        );
        // Areas 40, 100, 70: mean 70, median 70, total 210.
        let area = s.floor_area.unwrap();
        assert_eq!((area.mean, area.median, area.total), (70.0, 70.0, 210.0));
        // Levels 1, 2, 1.
        let levels = s.levels.unwrap();
        assert_eq!((levels.total, levels.max), (4.0, 2.0));
        assert_eq!(s.objects.unwrap().mean, 40.0);
        assert_eq!(s.triangles.unwrap().mean, 4000.0);
        // Room classes: bedroom a, b; kitchen b, c; living_room c; the rest none.
        let classes: Vec<(&str, usize)> = s
            .room_classes
            .iter()
            .map(|c| (c.name.as_str(), c.houses))
            .collect();
        assert_eq!(
            classes,
            [
                ("other", 0),
                ("bedroom", 2),
                ("living_room", 1),
                ("bathroom", 0),
                ("kitchen", 2),
                ("dining_room", 0),
                ("office", 0),
                ("hallway", 0),
                ("outdoor", 0)
            ]
        );
        // Categories: chair in 3 houses, then bed and sofa (1 each) by name.
        let cats: Vec<(&str, usize)> = s
            .categories
            .iter()
            .map(|c| (c.name.as_str(), c.houses))
            .collect();
        assert_eq!(cats, [("chair", 3), ("bed", 1), ("sofa", 1)]);
    }

    #[test]
    fn even_count_median_is_the_mean_of_the_middle_two() {
        let mut r = rows();
        r.push(house("e", 1, 10.0, &[], &[]));
        // Areas 10, 40, 70, 100.
        let area = compute(&r).floor_area.unwrap();
        assert_eq!((area.median, area.mean), (55.0, 55.0));
    }

    #[test]
    fn a_house_counts_once_per_class_and_category() {
        let r = vec![house(
            "a",
            3,
            1.0,
            &["bedroom", "bedroom", "lounge"],
            &["chair", "chair"],
        )];
        let s = compute(&r);
        assert_eq!(count(&s.room_classes, "bedroom"), 1);
        assert_eq!(
            count(&s.room_classes, "living_room"),
            1,
            "alias read as its class"
        );
        assert_eq!(count(&s.categories, "chair"), 1);
    }

    #[test]
    fn empty_set_has_no_summaries() {
        let s = compute(&[ManifestRow::failed("x", "mp3d", "x.house", "bad".into())]);
        assert_eq!((s.houses, s.failed), (0, 1));
        assert!(s.rooms.is_none() && s.floor_area.is_none());
        assert!(render_table(&[StatsColumn {
            name: "all".into(),
            stats: s
        }])
        .contains("-"));
    }

    #[test]
    fn split_columns_select_listed_rows() {
        let lists = SplitLists {
            train: vec!["a".into(), "b".into()],
            val: vec!["c".into()],
            test: vec!["nowhere".into()],
        };
        let cols = compute_split(&rows(), &lists);
        let names: Vec<&str> = cols.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["train", "val", "test", "total"]);
        assert_eq!(cols[0].stats.houses, 2);
        assert_eq!(cols[0].stats.floor_area.as_ref().unwrap().total, 140.0);
        assert_eq!(cols[1].stats.houses, 1);
        assert_eq!(cols[2].stats.houses, 0);
        assert_eq!(cols[3].stats.houses, 3);
        assert_eq!(cols[3].stats.failed, 0, "d is listed nowhere");
    }

    #[test]
    fn table_aligns_columns_and_lists_top_categories() {
        let lists = SplitLists {
            train: vec!["a".into(), "b".into()],
            val: vec!["c".into()],
            test: Vec::new(),
        };
        let table = render_table(&compute_split(&rows(), &lists));
        let lines: Vec<&str> = table.lines().collect();
        let header: Vec<&str> = lines[0].split_whitespace().collect();
        assert_eq!(header, ["train", "val", "test", "total"], "{table}");
        let find = |label: &str| {
            lines
                .iter()
                .find(|l| l.starts_with(label))
                .unwrap_or_else(|| panic!("no `{label}` in\n{table}"))
                .split_whitespace()
                .rev()
                .take(4)
                .collect::<Vec<_>>()
        };
        // Cells in reverse: total, test, val, train.
        assert_eq!(find("houses "), ["3", "0", "1", "2"]);
        assert_eq!(
            find("floor area m² (median)"),
            ["70.0", "-", "70.0", "70.0"]
        );
        assert_eq!(find("bedroom"), ["2", "0", "0", "2"]);
        assert_eq!(find("chair"), ["3", "0", "1", "2"]);
        // The header and every row have the same width.
        let widths: BTreeSet<usize> = lines
            .iter()
            .filter(|l| l.ends_with(char::is_numeric) || l.ends_with('-') || l.ends_with("total"))
            .map(|l| l.chars().count())
            .collect();
        assert_eq!(widths.len(), 1, "{table}");
    }

    #[test]
    fn json_has_every_field() {
        let v = serde_json::to_value(compute(&rows())).unwrap();
        assert_eq!(v["houses"], 3);
        assert_eq!(v["floor_area"]["median"], 70.0);
        assert_eq!(v["room_classes"][1]["name"], "bedroom");
        assert_eq!(v["categories"][0]["houses"], 3);
    }
}
