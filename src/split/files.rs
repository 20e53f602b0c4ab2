//! Split files: `{train,val,test}.txt` id lists, one id per line.
//!
//! Reading is lenient (blank lines, `#` comments, surrounding white space and CRLF line ends
//! are ignored) so hand-written and official lists work as they are; writing is canonical
//! (sorted, distinct, `\n` after every id) and atomic per file.

use crate::file_error::FileError;
use std::fs;
use std::path::{Path, PathBuf};

use super::{SplitError, SplitLists, Subset};
use crate::atomic::{sweep_stale, write_bytes_atomic};
use crate::store::DataDir;

/// The ids of one list file's text: everything after a `#` is a comment; blank lines are
/// skipped; ids are trimmed. Order and repeats are kept.
pub fn parse_list(text: &str) -> Vec<String> {
    text.lines()
        .map(|line| line.split('#').next().unwrap_or_default().trim())
        .filter(|id| !id.is_empty())
        .map(str::to_string)
        .collect()
}

/// Reads `dir/train.txt`, `dir/val.txt` and `dir/test.txt` (all three must exist; other files
/// in `dir` are ignored).
pub fn read_lists(dir: &Path) -> Result<SplitLists, SplitError> {
    let mut lists = SplitLists::default();
    for s in Subset::ALL {
        let path = list_path(dir, s);
        let text = fs::read_to_string(&path)
            .map_err(|source| SplitError::Io(FileError::new(path, source)))?;
        *lists.get_mut(s) = parse_list(&text);
    }
    Ok(lists)
}

/// The folder of split `name` in `data`: `data/splits/name`. The name must be a plain folder
/// name, so a split can never be written outside `data/splits/`.
pub fn split_dir(data: &DataDir, name: &str) -> Result<PathBuf, SplitError> {
    data.split_dir(name)
        .ok_or_else(|| SplitError::BadName(name.to_string()))
}

/// Writes split `name` into `data/splits/name/{train,val,test}.txt`, each file sorted,
/// distinct and atomically replaced, then the DATA folder's provenance record; returns the
/// folder.
pub fn write_split(data: &DataDir, name: &str, lists: &SplitLists) -> Result<PathBuf, SplitError> {
    let dir = split_dir(data, name)?;
    // What a killed `split` left in the folder.
    sweep_stale(&dir).map_err(|source| SplitError::Io(FileError::new(&dir, source)))?;
    let mut lists = lists.clone();
    lists.sort();
    for s in Subset::ALL {
        let mut text = String::new();
        for id in lists.get(s) {
            text.push_str(id);
            text.push('\n');
        }
        let path = list_path(&dir, s);
        write_bytes_atomic(&path, text.as_bytes())
            .map_err(|source| SplitError::Io(FileError::new(path, source)))?;
    }
    crate::store::provenance::write_data_record(data).map_err(SplitError::Provenance)?;
    Ok(dir)
}

/// Reads split `name` of `data` (written by [`write_split`]).
pub fn read_split(data: &DataDir, name: &str) -> Result<SplitLists, SplitError> {
    read_lists(&split_dir(data, name)?)
}

fn list_path(dir: &Path, subset: Subset) -> PathBuf {
    dir.join(format!("{}.txt", subset.name()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strings(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn lists_ignore_comments_blanks_space_and_crlf() {
        let text = "# official list\r\n a1 \r\n\r\n  \nb2 # trailing comment\nc3\r\n#d4\n";
        assert_eq!(parse_list(text), strings(&["a1", "b2", "c3"]));
        assert!(parse_list("").is_empty());
    }

    #[test]
    fn write_then_read_round_trips_sorted_and_distinct() {
        let dir = tempfile::tempdir().unwrap();
        let lists = SplitLists {
            train: strings(&["b", "a", "b"]),
            val: strings(&["c"]),
            test: Vec::new(),
        };
        let out = write_split(&DataDir::new(dir.path()), "mine", &lists).unwrap();
        assert_eq!(out, dir.path().join("splits/mine"));
        assert_eq!(fs::read_to_string(out.join("train.txt")).unwrap(), "a\nb\n");
        assert_eq!(fs::read_to_string(out.join("val.txt")).unwrap(), "c\n");
        assert_eq!(fs::read_to_string(out.join("test.txt")).unwrap(), "");
        let back = read_split(&DataDir::new(dir.path()), "mine").unwrap();
        assert_eq!(back.train, strings(&["a", "b"]));
        assert_eq!(back.val, strings(&["c"]));
        assert!(back.test.is_empty());
        // Only the three lists, no temporary files left behind.
        assert_eq!(fs::read_dir(&out).unwrap().count(), 3);
    }

    #[test]
    fn split_names_cannot_escape_the_splits_folder() {
        let data = &DataDir::new("DATA");
        for bad in ["", ".", "..", "a/b", "..\\x", "a\nb"] {
            assert!(
                matches!(split_dir(data, bad), Err(SplitError::BadName(_))),
                "{bad:?}"
            );
        }
        assert_eq!(
            split_dir(data, "mp3d-v1.2").unwrap(),
            Path::new("DATA/splits/mp3d-v1.2")
        );
    }

    #[test]
    fn missing_list_file_names_its_path() {
        let dir = tempfile::tempdir().unwrap();
        fs::write(dir.path().join("train.txt"), "a\n").unwrap();
        fs::write(dir.path().join("val.txt"), "b\n").unwrap();
        let e = read_lists(dir.path()).unwrap_err();
        assert!(e.to_string().ends_with("test.txt"), "{e}");
        let cause = std::error::Error::source(&e).map(ToString::to_string);
        assert!(
            cause.is_some_and(|c| !c.is_empty()),
            "the io error is the source"
        );
    }

    #[test]
    fn shipped_lists_have_the_minos_sizes() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("splits");
        let mp3d = read_lists(&root.join("mp3d")).unwrap();
        assert_eq!(
            [mp3d.train.len(), mp3d.val.len(), mp3d.test.len()],
            [61, 11, 18]
        );
        let suncg = read_lists(&root.join("suncg-multiroom")).unwrap();
        assert_eq!(
            [suncg.train.len(), suncg.val.len(), suncg.test.len()],
            [207, 76, 77]
        );
        assert!(suncg.subset_by_id().is_ok(), "subsets are disjoint");
    }
}
