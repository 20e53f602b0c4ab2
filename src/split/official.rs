//! The official split lists minos ships (`splits/` of the source tree), compiled into the
//! binary so that `split --lists NAME` works from any folder and without the repository:
//! `mp3d` (Matterport3D's scenes split as Habitat and MINOS use them) and `suncg-multiroom`
//! (the MINOS paper's SUNCG multi-room split).

use std::path::Path;

use super::{parse_list, read_lists, SplitError, SplitLists, Subset};

/// The built-in lists: name and the text of train.txt, val.txt and test.txt.
const OFFICIAL: &[(&str, [&str; 3])] = &[
    (
        "mp3d",
        [
            include_str!("../../splits/mp3d/train.txt"),
            include_str!("../../splits/mp3d/val.txt"),
            include_str!("../../splits/mp3d/test.txt"),
        ],
    ),
    (
        "suncg-multiroom",
        [
            include_str!("../../splits/suncg-multiroom/train.txt"),
            include_str!("../../splits/suncg-multiroom/val.txt"),
            include_str!("../../splits/suncg-multiroom/test.txt"),
        ],
    ),
];

/// The names of the built-in split lists.
pub fn official_names() -> impl Iterator<Item = &'static str> {
    OFFICIAL.iter().map(|(name, _)| *name)
}

/// The built-in split lists called `name`, if any.
pub fn official_lists(name: &str) -> Option<SplitLists> {
    let (_, texts) = OFFICIAL.iter().find(|(n, _)| *n == name)?;
    let mut lists = SplitLists::default();
    for (subset, text) in Subset::ALL.into_iter().zip(texts) {
        *lists.get_mut(subset) = parse_list(text);
    }
    Some(lists)
}

/// The lists `spec` names: a folder holding train.txt, val.txt and test.txt when it is one;
/// otherwise the built-in lists named by its last component (`suncg-multiroom`, or
/// `splits/suncg-multiroom` as the repository lays them out, from any folder).
pub fn resolve_lists(spec: &Path) -> Result<SplitLists, SplitError> {
    if spec.is_dir() {
        return read_lists(spec);
    }
    let name = spec.file_name().and_then(|n| n.to_str()).unwrap_or("");
    official_lists(name).ok_or_else(|| SplitError::NoLists {
        spec: spec.display().to_string(),
        official: official_names().collect::<Vec<_>>().join(", "),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_in_lists_equal_the_repository_files_and_resolve_by_name_or_path() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("splits");
        for name in official_names() {
            let from_files = read_lists(&root.join(name)).unwrap();
            assert_eq!(official_lists(name).unwrap(), from_files, "{name}");
            assert!(from_files.total() > 0);
            // By name, and by the repository's relative path from a folder that lacks it.
            assert_eq!(resolve_lists(Path::new(name)).unwrap(), from_files);
            let relative = Path::new("no-such-folder/splits").join(name);
            assert_eq!(resolve_lists(&relative).unwrap(), from_files);
        }
        let e = resolve_lists(Path::new("nope")).unwrap_err().to_string();
        assert!(
            e.contains("`nope`") && e.contains("mp3d, suncg-multiroom"),
            "{e}"
        );
    }
}
