//! Semantic label taxonomies for per-pixel class images: NYU-40, Matterport3D's mpcat40 and
//! minos's coarse classes (after MINOS/SUNCG's coarse-grained categories), with fixed indices
//! (tables in `data/taxonomy/`), so labels mean the same in every scene.

use std::collections::HashMap;
use std::sync::OnceLock;

use serde::{Deserialize, Serialize};

use super::{Categories, SurfaceKind};

/// A taxonomy of semantic classes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Taxonomy {
    /// NYU-40 (0 = void).
    #[default]
    Nyu40,
    /// Matterport3D mpcat40 (0 = void).
    Mpcat40,
    /// Coarse classes (`data/taxonomy/coarse.csv`, 0 = void): wall, floor, ceiling, door,
    /// window, stairs, chair, table, bed, sofa, cabinet, …, other.
    Coarse,
}

struct Tables {
    nyu40: HashMap<String, u16>,
    mpcat40: HashMap<String, u16>,
    nyu_to_mp: HashMap<String, String>,
    nyu40_names: Vec<String>,
    mpcat40_names: Vec<String>,
    coarse: HashMap<String, u16>,
    coarse_names: Vec<String>,
    /// Object label (normalised) → coarse class.
    coarse_map: HashMap<String, u16>,
}

/// Lower case, with spaces and '-' read as '_' (how coarse_map.csv lists labels).
fn normalise(label: &str) -> String {
    label
        .trim()
        .chars()
        .map(|c| match c {
            ' ' | '-' => '_',
            c => c.to_ascii_lowercase(),
        })
        .collect()
}

fn rows(text: &str) -> impl Iterator<Item = (String, String)> + '_ {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .skip(1)
        .filter_map(|l| {
            l.split_once(',')
                .map(|(a, b)| (a.trim().to_string(), b.trim().to_string()))
        })
}

fn tables() -> &'static Tables {
    static T: OnceLock<Tables> = OnceLock::new();
    T.get_or_init(|| {
        let indexed = |text: &str| -> (HashMap<String, u16>, Vec<String>) {
            let mut map = HashMap::new();
            let mut names = Vec::new();
            for (i, name) in rows(text) {
                if let Ok(i) = i.parse::<u16>() {
                    map.insert(name.clone(), i);
                    if names.len() <= i as usize {
                        names.resize(i as usize + 1, String::new());
                    }
                    names[i as usize] = name;
                }
            }
            (map, names)
        };
        let (nyu40, nyu40_names) = indexed(include_str!("../../data/taxonomy/nyu40.csv"));
        let (mpcat40, mpcat40_names) = indexed(include_str!("../../data/taxonomy/mpcat40.csv"));
        let nyu_to_mp = rows(include_str!("../../data/taxonomy/nyu40_to_mpcat40.csv")).collect();
        let (coarse, coarse_names) = indexed(include_str!("../../data/taxonomy/coarse.csv"));
        let coarse_map = rows(include_str!("../../data/taxonomy/coarse_map.csv"))
            .filter_map(|(label, class)| coarse.get(&class).map(|&i| (normalise(&label), i)))
            .collect();
        Tables {
            nyu40,
            mpcat40,
            nyu_to_mp,
            nyu40_names,
            mpcat40_names,
            coarse,
            coarse_names,
            coarse_map,
        }
    })
}

impl crate::vocab::Vocabulary for Taxonomy {
    const WHAT: &'static str = "taxonomy";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: Taxonomy::Nyu40,
            name: "nyu40",
            aliases: &[],
            help: "NYU-40 classes (0 = void)",
        },
        crate::vocab::Term {
            value: Taxonomy::Mpcat40,
            name: "mpcat40",
            aliases: &[],
            help: "Matterport3D's mpcat40 classes (0 = void)",
        },
        crate::vocab::Term {
            value: Taxonomy::Coarse,
            name: "coarse",
            aliases: &[],
            help: "coarse classes: wall, floor, door, chair, … (0 = void)",
        },
    ];
}

crate::vocab::name_traits!(Taxonomy);

impl Taxonomy {
    /// Class names by index.
    pub fn class_names(self) -> &'static [String] {
        match self {
            Taxonomy::Nyu40 => &tables().nyu40_names,
            Taxonomy::Mpcat40 => &tables().mpcat40_names,
            Taxonomy::Coarse => &tables().coarse_names,
        }
    }

    /// The class of an object (0 when unknown).
    pub fn object_class(self, c: &Categories) -> u16 {
        let t = tables();
        match self {
            Taxonomy::Nyu40 => c
                .nyu40
                .as_deref()
                .and_then(|n| t.nyu40.get(n))
                .copied()
                .unwrap_or(0),
            Taxonomy::Mpcat40 => {
                let direct = c.mpcat40.as_deref().and_then(|n| t.mpcat40.get(n));
                let stairs = c
                    .matches("stairs")
                    .then(|| t.mpcat40.get("stairs"))
                    .flatten();
                let via_nyu = c
                    .nyu40
                    .as_deref()
                    .and_then(|n| t.nyu_to_mp.get(n))
                    .and_then(|m| t.mpcat40.get(m));
                direct.or(stairs).or(via_nyu).copied().unwrap_or(0)
            }
            Taxonomy::Coarse => [&c.coarse, &c.fine, &c.mpcat40, &c.nyu40]
                .into_iter()
                .flatten()
                .find_map(|label| t.coarse_map.get(&normalise(label)))
                .or_else(|| t.coarse.get("other"))
                .copied()
                .unwrap_or(0),
        }
    }

    /// The class of a room surface.
    pub fn surface_class(self, kind: SurfaceKind) -> u16 {
        let name = match kind {
            SurfaceKind::Floor => "floor",
            SurfaceKind::Wall => "wall",
            SurfaceKind::Ceiling => "ceiling",
        };
        let t = tables();
        let map = match self {
            Taxonomy::Nyu40 => &t.nyu40,
            Taxonomy::Mpcat40 => &t.mpcat40,
            Taxonomy::Coarse => &t.coarse,
        };
        map.get(name).copied().unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_indices_of_both_taxonomies() {
        assert_eq!(Taxonomy::Nyu40.surface_class(SurfaceKind::Ceiling), 22);
        assert_eq!(Taxonomy::Mpcat40.surface_class(SurfaceKind::Ceiling), 17);
        let bed = Categories {
            fine: Some("double_bed".into()),
            coarse: Some("bed".into()),
            nyu40: Some("bed".into()),
            mpcat40: None,
        };
        assert_eq!(Taxonomy::Nyu40.object_class(&bed), 4);
        assert_eq!(Taxonomy::Mpcat40.object_class(&bed), 11);
        let stairs = Categories {
            fine: Some("stairs".into()),
            nyu40: Some("floor".into()),
            ..Default::default()
        };
        assert_eq!(Taxonomy::Mpcat40.object_class(&stairs), 16);
        assert_eq!(Taxonomy::Nyu40.class_names()[40], "otherprop");
        assert_eq!(Taxonomy::Mpcat40.class_names().len(), 42);
    }

    #[test]
    fn coarse_classes_from_any_label() {
        let coarse = |fine: &str, coarse: Option<&str>, nyu40: Option<&str>| {
            Taxonomy::Coarse.object_class(&Categories {
                fine: Some(fine.into()),
                coarse: coarse.map(str::to_string),
                nyu40: nyu40.map(str::to_string),
                mpcat40: None,
            })
        };
        let names = Taxonomy::Coarse.class_names();
        let id = |name: &str| names.iter().position(|n| n == name).unwrap() as u16;
        assert_eq!(id("bed"), 9);
        assert_eq!(coarse("double_bed", Some("bed"), Some("bed")), id("bed"));
        // SUNCG coarse class first, then NYU-40 when the coarse label is not listed.
        assert_eq!(
            coarse("wardrobe", Some("wardrobe_cabinet"), None),
            id("cabinet")
        );
        assert_eq!(
            coarse("fridge", Some("zzz"), Some("refridgerator")),
            id("appliance")
        );
        // 3D-FUTURE super-category, compared in lower case.
        assert_eq!(coarse("Lounge Chair", Some("Chair"), None), id("chair"));
        assert_eq!(coarse("vase", Some("vase"), None), id("other"));
        assert_eq!(Taxonomy::Coarse.surface_class(SurfaceKind::Floor), 2);
        assert_eq!(Taxonomy::Coarse.surface_class(SurfaceKind::Ceiling), 3);
        assert_eq!("coarse".parse::<Taxonomy>(), Ok(Taxonomy::Coarse));
        assert_eq!(Taxonomy::Mpcat40.to_string(), "mpcat40");
    }
}
