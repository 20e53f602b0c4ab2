//! Train/val/test splits of a DATA folder's scenes.
//!
//! Responsible for deciding which scene ids go into which subset — from official id lists
//! ([`split_by_lists`]) or by seeded ratios ([`split_by_ratios`]) — after dropping the scenes
//! that failed to ingest and those a filter expression ([`Expr`], its language in
//! [`SYNTAX_HELP`]) rejects; and for
//! the on-disk form `DATA/splits/<name>/{train,val,test}.txt` ([`write_split`],
//! [`read_split`]). It works on manifest rows already in memory: reading the manifest and
//! reporting to the user are the caller's job.
//!
//! Invariant: a ratio split assigns each id on its own, from `derive_seed(seed, [id, "split"])`,
//! so a scene's subset depends only on the seed, its id and the ratios. Adding or removing
//! other scenes never moves it.

mod expr;
mod files;
mod official;

use crate::file_error::FileError;
use std::collections::{HashMap, HashSet};
use std::str::FromStr;

use crate::seed::derive_seed;
use crate::store::manifest::ManifestRow;

pub use expr::{CmpOp, Expr, ExprError, ExprErrorKind, MAX_DEPTH, SYNTAX_HELP};
pub use files::{parse_list, read_lists, read_split, split_dir, write_split};
pub use official::{official_lists, official_names, resolve_lists};

/// Errors of split computation and split files.
#[derive(Debug, thiserror::Error)]
pub enum SplitError {
    /// Ratios that are not three non-negative numbers summing to 1.
    #[error(
        "ratios must be three non-negative numbers train,val,test summing to 1 \
         (e.g. 0.6,0.2,0.2), got `{0}`"
    )]
    BadRatios(String),
    /// A file or folder could not be read or written (the cause is the error's source).
    #[error(transparent)]
    Io(#[from] FileError),
    /// One id in two subsets of the given lists.
    #[error("id `{id}` is listed in both {first} and {second}")]
    ListedTwice {
        /// The id.
        id: String,
        /// The first subset listing it.
        first: Subset,
        /// The other subset listing it.
        second: Subset,
    },
    /// `--lists` names neither a folder nor built-in lists.
    #[error("`{spec}` is neither a folder of train.txt, val.txt and test.txt nor the name of built-in lists ({official})")]
    NoLists {
        /// What was given.
        spec: String,
        /// The built-in names.
        official: String,
    },
    /// The split is written, but the DATA folder's provenance record could not be.
    #[error("the DATA folder's provenance record")]
    Provenance(#[source] crate::file_error::FileError),
    /// A split name that is not a plain folder name.
    #[error("split name `{0}` must be a plain folder name (not empty, no `/`, `\\`, `.` or `..`)")]
    BadName(String),
}

/// One of the three subsets of a split.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Subset {
    /// Training scenes.
    Train,
    /// Validation scenes.
    Val,
    /// Test scenes.
    Test,
}

impl Subset {
    /// The three subsets in file order.
    pub const ALL: [Subset; 3] = [Subset::Train, Subset::Val, Subset::Test];

    /// The name used for files and reports (`train`, `val`, `test`).
    pub fn name(self) -> &'static str {
        crate::vocab::Vocabulary::term_name(self)
    }
}

impl crate::vocab::Vocabulary for Subset {
    const WHAT: &'static str = "subset";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: Subset::Train,
            name: "train",
            aliases: &[],
            help: "training scenes",
        },
        crate::vocab::Term {
            value: Subset::Val,
            name: "val",
            aliases: &[],
            help: "validation scenes",
        },
        crate::vocab::Term {
            value: Subset::Test,
            name: "test",
            aliases: &[],
            help: "test scenes",
        },
    ];
}

crate::vocab::name_traits!(Subset);

/// The ids of each subset of a split.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SplitLists {
    /// Training ids.
    pub train: Vec<String>,
    /// Validation ids.
    pub val: Vec<String>,
    /// Test ids.
    pub test: Vec<String>,
}

impl SplitLists {
    /// The ids of one subset.
    pub fn get(&self, subset: Subset) -> &[String] {
        match subset {
            Subset::Train => &self.train,
            Subset::Val => &self.val,
            Subset::Test => &self.test,
        }
    }

    fn get_mut(&mut self, subset: Subset) -> &mut Vec<String> {
        match subset {
            Subset::Train => &mut self.train,
            Subset::Val => &mut self.val,
            Subset::Test => &mut self.test,
        }
    }

    /// Every id of the three subsets, sorted, each once (the scenes a command given this
    /// split works on).
    pub fn ids(&self) -> Vec<String> {
        let mut ids: Vec<String> = Subset::ALL
            .iter()
            .flat_map(|&s| self.get(s).iter().cloned())
            .collect();
        ids.sort_unstable();
        ids.dedup();
        ids
    }

    /// Number of ids over all three subsets.
    pub fn total(&self) -> usize {
        Subset::ALL.iter().map(|&s| self.get(s).len()).sum()
    }

    /// Sorts each subset and drops repeated ids.
    pub fn sort(&mut self) {
        for s in Subset::ALL {
            let ids = self.get_mut(s);
            ids.sort_unstable();
            ids.dedup();
        }
    }

    /// The subset of every listed id; an id listed in two subsets is an error (the same id
    /// twice in one subset is not).
    pub fn subset_by_id(&self) -> Result<HashMap<&str, Subset>, SplitError> {
        let mut map = HashMap::with_capacity(self.total());
        for s in Subset::ALL {
            for id in self.get(s) {
                match map.insert(id.as_str(), s) {
                    Some(first) if first != s => {
                        return Err(SplitError::ListedTwice {
                            id: id.clone(),
                            first,
                            second: s,
                        })
                    }
                    _ => {}
                }
            }
        }
        Ok(map)
    }

    /// The listed ids that no row of `rows` has, sorted and distinct.
    pub fn missing_from(&self, rows: &[ManifestRow]) -> Vec<String> {
        let present: HashSet<&str> = rows.iter().map(|r| r.id.as_str()).collect();
        let mut missing: Vec<String> = Subset::ALL
            .iter()
            .flat_map(|&s| self.get(s))
            .filter(|id| !present.contains(id.as_str()))
            .cloned()
            .collect();
        missing.sort_unstable();
        missing.dedup();
        missing
    }
}

/// The outcome of a split: the lists and what was left out of them.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SplitResult {
    /// The ids of each subset, sorted and distinct.
    pub lists: SplitLists,
    /// Rows that loaded but that the filter rejected (for list splits: listed rows only).
    pub filtered_out: usize,
    /// Rows whose scene failed to ingest (for list splits: listed rows only).
    pub failed: usize,
    /// List splits: manifest rows in none of the lists. Always 0 for ratio splits.
    pub unlisted: usize,
    /// List splits: listed ids with no manifest row, sorted. Always empty for ratio splits.
    pub missing: Vec<String>,
}

impl SplitResult {
    /// Puts `row` into `subset` unless it failed or the filter rejects it, counting either.
    fn admit(&mut self, row: &ManifestRow, filter: Option<&Expr>, subset: Subset) {
        if !row.is_ok() {
            self.failed += 1;
        } else if filter.is_some_and(|f| !f.matches(row)) {
            self.filtered_out += 1;
        } else {
            self.lists.get_mut(subset).push(row.id.clone());
        }
    }
}

/// Validated train/val/test fractions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ratios {
    given: [f64; 3],
    /// Cumulative upper bounds of train and val in [0, 1], normalised so that a zero-sized
    /// last subset really receives nothing.
    bounds: [f64; 2],
}

impl Ratios {
    /// Tolerance on the sum of the ratios.
    pub const TOLERANCE: f64 = 1e-6;

    /// Checks that `ratios` are three finite, non-negative numbers summing to 1 (±1e-6).
    pub fn new(ratios: [f64; 3]) -> Result<Ratios, SplitError> {
        let [a, b, c] = ratios;
        let sum = (a + b) + c;
        let valid = ratios.iter().all(|r| r.is_finite() && *r >= 0.0)
            && (sum - 1.0).abs() <= Self::TOLERANCE;
        if !valid {
            return Err(SplitError::BadRatios(format!("{a},{b},{c}")));
        }
        // x / x == 1 exactly, so when the later ratios are 0 the bounds reach 1.
        Ok(Ratios {
            given: ratios,
            bounds: [a / sum, (a + b) / sum],
        })
    }

    /// The ratios as given.
    pub fn values(&self) -> [f64; 3] {
        self.given
    }

    /// The subset of `id` under `seed`: the id's hash as a fraction in [0, 1) compared with
    /// the cumulative ratios.
    pub fn assign(&self, id: &str, seed: u64) -> Subset {
        let hash = derive_seed(seed, &[id, "split"]);
        let fraction = (hash >> 11) as f64 / (1u64 << 53) as f64;
        if fraction < self.bounds[0] {
            Subset::Train
        } else if fraction < self.bounds[1] {
            Subset::Val
        } else {
            Subset::Test
        }
    }
}

impl FromStr for Ratios {
    type Err = SplitError;

    /// Parses `train,val,test`, e.g. `0.6,0.2,0.2`.
    fn from_str(text: &str) -> Result<Ratios, SplitError> {
        let bad = || SplitError::BadRatios(text.to_string());
        let parts: Vec<f64> = text
            .split(',')
            .map(|p| p.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| bad())?;
        let ratios: [f64; 3] = parts.try_into().map_err(|_| bad())?;
        Ratios::new(ratios).map_err(|_| bad())
    }
}

/// Splits the rows that loaded and pass `filter` by `ratios`, each id placed by its own hash
/// under `seed` (see [`Ratios::assign`]).
pub fn split_by_ratios(
    rows: &[ManifestRow],
    filter: Option<&Expr>,
    ratios: Ratios,
    seed: u64,
) -> SplitResult {
    let mut result = SplitResult::default();
    for row in rows {
        result.admit(row, filter, ratios.assign(&row.id, seed));
    }
    result.lists.sort();
    result
}

/// Keeps the listed ids whose rows loaded and pass `filter`, each in the subset that lists it.
/// Listed ids without a row are reported in [`SplitResult::missing`]; an id listed in two
/// subsets is an error.
pub fn split_by_lists(
    rows: &[ManifestRow],
    filter: Option<&Expr>,
    lists: &SplitLists,
) -> Result<SplitResult, SplitError> {
    let subset_by_id = lists.subset_by_id()?;
    let mut result = SplitResult::default();
    for row in rows {
        match subset_by_id.get(row.id.as_str()) {
            Some(&subset) => result.admit(row, filter, subset),
            None => result.unlisted += 1,
        }
    }
    result.lists.sort();
    result.missing = lists.missing_from(rows);
    Ok(result)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ok_row(id: &str, nrooms: u32) -> ManifestRow {
        ManifestRow {
            id: id.into(),
            dataset: "suncg".into(),
            nlevels: 1,
            nrooms,
            ..Default::default()
        }
    }

    fn ids(prefix: &str, n: usize) -> Vec<ManifestRow> {
        (0..n)
            .map(|i| ok_row(&format!("{prefix}{i:05}"), 3))
            .collect()
    }

    fn strings(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    fn ratios(r: [f64; 3]) -> Ratios {
        Ratios::new(r).unwrap()
    }

    #[test]
    fn a_splits_ids_are_its_subsets_sorted_and_distinct() {
        let lists = SplitLists {
            train: strings(&["c", "a"]),
            val: strings(&["b", "a"]),
            test: strings(&["d"]),
        };
        assert_eq!(lists.ids(), strings(&["a", "b", "c", "d"]));
        assert!(SplitLists::default().ids().is_empty());
    }

    #[test]
    fn ratios_are_validated() {
        assert!(Ratios::new([0.6, 0.2, 0.2]).is_ok());
        assert!(Ratios::new([1.0, 0.0, 0.0]).is_ok());
        assert!(
            Ratios::new([0.6, 0.2, 0.2000005]).is_ok(),
            "within tolerance"
        );
        assert!(Ratios::new([0.6, 0.2, 0.21]).is_err());
        assert!(Ratios::new([1.2, -0.2, 0.0]).is_err());
        assert!(Ratios::new([f64::NAN, 0.5, 0.5]).is_err());
        assert_eq!(
            "0.6, 0.2,0.2".parse::<Ratios>().unwrap().values(),
            [0.6, 0.2, 0.2]
        );
        for bad in ["0.6,0.4", "0.5,0.2,0.2,0.1", "a,b,c", "", "0.6;0.2;0.2"] {
            let e = bad.parse::<Ratios>().unwrap_err();
            assert!(e.to_string().contains(&format!("got `{bad}`")), "{e}");
        }
    }

    #[test]
    fn ratio_split_proportions_are_close_over_10k_ids() {
        let rows = ids("h", 10_000);
        let r = split_by_ratios(&rows, None, ratios([0.6, 0.2, 0.2]), 7);
        let (train, val, test) = (r.lists.train.len(), r.lists.val.len(), r.lists.test.len());
        assert_eq!(train + val + test, 10_000);
        // Binomial standard deviation is about 49 for train and 40 for val/test.
        assert!((5_800..6_200).contains(&train), "train {train}");
        assert!((1_850..2_150).contains(&val), "val {val}");
        assert!((1_850..2_150).contains(&test), "test {test}");
        assert!(r.lists.train.windows(2).all(|w| w[0] < w[1]), "sorted");

        // Zero ratios receive nothing.
        let r = split_by_ratios(&rows, None, ratios([0.7, 0.3, 0.0]), 7);
        assert!(r.lists.test.is_empty());
        assert!(!r.lists.val.is_empty());
        let r = split_by_ratios(&rows, None, ratios([0.0, 0.0, 1.0]), 7);
        assert_eq!(r.lists.test.len(), 10_000);
    }

    #[test]
    fn adding_houses_never_moves_existing_ones() {
        let old = ids("old", 2_000);
        let before = split_by_ratios(&old, None, ratios([0.6, 0.2, 0.2]), 3);
        let mut more = ids("new", 3_000);
        // New ids both before and after the old ones in sort and row order.
        more.extend(old.iter().cloned());
        more.extend(ids("a", 500));
        let after = split_by_ratios(&more, None, ratios([0.6, 0.2, 0.2]), 3);
        for s in Subset::ALL {
            let now: HashSet<&String> = after.lists.get(s).iter().collect();
            for id in before.lists.get(s) {
                assert!(now.contains(id), "{id} left {s}");
            }
        }
        assert_eq!(after.lists.total(), 5_500);
        // A different seed does move ids.
        let other = split_by_ratios(&old, None, ratios([0.6, 0.2, 0.2]), 4);
        assert_ne!(other.lists, before.lists);
    }

    #[test]
    fn ratio_split_skips_failed_and_filtered_rows() {
        let mut rows = vec![ok_row("a", 2), ok_row("b", 5), ok_row("c", 2)];
        rows.push(ManifestRow::failed("d", "suncg", "d.json", "boom".into()));
        let filter = Expr::parse("nrooms == 2").unwrap();
        let r = split_by_ratios(&rows, Some(&filter), ratios([1.0, 0.0, 0.0]), 0);
        assert_eq!(r.lists.train, strings(&["a", "c"]));
        assert_eq!((r.filtered_out, r.failed), (1, 1));
        assert_eq!((r.unlisted, r.missing.len()), (0, 0));
    }

    #[test]
    fn list_split_filters_and_reports_missing_ids() {
        let mut rows = vec![
            ok_row("t1", 2),
            ok_row("t2", 5),
            ok_row("v1", 2),
            ok_row("x1", 2),
            ok_row("x2", 2),
        ];
        rows.push(ManifestRow::failed("e1", "suncg", "e1.json", "boom".into()));
        let lists = SplitLists {
            train: strings(&["t2", "t1", "gone2", "t1"]),
            val: strings(&["v1", "e1"]),
            test: strings(&["gone1"]),
        };
        let filter = Expr::parse("nrooms < 3").unwrap();
        let r = split_by_lists(&rows, Some(&filter), &lists).unwrap();
        assert_eq!(r.lists.train, strings(&["t1"]));
        assert_eq!(r.lists.val, strings(&["v1"]));
        assert!(r.lists.test.is_empty());
        assert_eq!(r.filtered_out, 1, "t2 has 5 rooms");
        assert_eq!(r.failed, 1, "e1");
        assert_eq!(r.unlisted, 2, "x1, x2");
        assert_eq!(r.missing, strings(&["gone1", "gone2"]));

        let r = split_by_lists(&rows, None, &lists).unwrap();
        assert_eq!(r.lists.train, strings(&["t1", "t2"]));
        assert_eq!(r.filtered_out, 0);
    }

    #[test]
    fn an_id_in_two_lists_is_an_error() {
        let lists = SplitLists {
            train: strings(&["a", "b"]),
            val: strings(&["c"]),
            test: strings(&["b"]),
        };
        let e = split_by_lists(&[ok_row("a", 1)], None, &lists).unwrap_err();
        assert!(matches!(
            e,
            SplitError::ListedTwice { ref id, first: Subset::Train, second: Subset::Test } if id == "b"
        ));
        assert_eq!(e.to_string(), "id `b` is listed in both train and test");
    }
}
