//! The lookup tables of the 3D-FRONT loader: room types to MINOS classes
//! (`data/taxonomy/3dfront_room_types.csv`, compiled in), 3D-FUTURE model categories (read
//! from the dataset at run time), and what each architecture mesh type becomes.
//!
//! Tables only answer questions; they never touch a scene.

use std::collections::HashMap;

use serde::Deserialize;

use crate::invalid::Invalid;
use crate::scene::{ObjectFlags, SurfaceKind};
use crate::scene::RoomClass;

/// 3D-FRONT room types (`LivingDiningRoom`, `MasterBedroom`, …) to MINOS room classes.
#[derive(Debug, Clone)]
pub struct FrontRoomTypes {
    map: HashMap<String, RoomClass>,
}

impl FrontRoomTypes {
    /// The table compiled into minos (`data/taxonomy/3dfront_room_types.csv`).
    pub fn builtin() -> Self {
        let text = include_str!("../../../../data/taxonomy/3dfront_room_types.csv");
        let map = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with('#'))
            .skip(1) // header
            .filter_map(|l| {
                let (raw, class) = l.split_once(',')?;
                Some((
                    raw.trim().to_ascii_lowercase(),
                    RoomClass::from_label(class)?,
                ))
            })
            .collect();
        FrontRoomTypes { map }
    }

    /// The class of a raw room type (case-insensitive), `None` when the table lacks it.
    pub fn class_of(&self, raw: &str) -> Option<RoomClass> {
        self.map.get(&raw.trim().to_ascii_lowercase()).copied()
    }

}

/// The 3D-FUTURE categories of one model.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FutureCategory {
    /// Fine category (`King-size Bed`).
    pub category: Option<String>,
    /// Super-category (`Bed`).
    pub super_category: Option<String>,
}

/// 3D-FUTURE model id (`jid`) to categories, from a `ModelCategoryMapping.csv`
/// (`model_id,category,super-category`) or the 3D-FUTURE `model_info.json`.
#[derive(Debug, Clone, Default)]
pub struct FutureCategories {
    map: HashMap<String, FutureCategory>,
}

#[derive(Deserialize)]
struct ModelInfo {
    model_id: String,
    #[serde(default)]
    category: Option<String>,
    #[serde(default, rename = "super-category")]
    super_category: Option<String>,
}

fn label(v: Option<&str>) -> Option<String> {
    v.map(str::trim)
        .filter(|v| !v.is_empty() && *v != "-")
        .map(str::to_string)
}

impl FutureCategories {
    /// Parses CSV text with a header naming `model_id`, `category` and `super-category`;
    /// errors name the line (the caller names the file).
    pub fn parse_csv(text: &str) -> Result<Self, Invalid> {
        let mut lines = text.lines().enumerate();
        let header = lines
            .next()
            .map(|(_, h)| h.trim_start_matches('\u{feff}'))
            .ok_or_else(|| Invalid::new("empty file"))?;
        let cols: Vec<&str> = header.split(',').map(str::trim).collect();
        let find = |name: &str| cols.iter().position(|c| c.eq_ignore_ascii_case(name));
        let model =
            find("model_id").ok_or_else(|| Invalid::new("no `model_id` column").at("line 1"))?;
        let category = find("category");
        let super_category = find("super-category").or_else(|| find("super_category"));
        if category.is_none() && super_category.is_none() {
            return Err(Invalid::new("no `category` or `super-category` column").at("line 1"));
        }
        let mut map = HashMap::new();
        for (i, line) in lines {
            if line.trim().is_empty() {
                continue;
            }
            let f: Vec<&str> = line.split(',').collect();
            let id = f
                .get(model)
                .map(|s| s.trim())
                .filter(|s| !s.is_empty())
                .ok_or_else(|| Invalid::new("missing model_id").at(format!("line {}", i + 1)))?;
            let get = |c: Option<usize>| label(c.and_then(|c| f.get(c).copied()));
            map.insert(
                id.to_string(),
                FutureCategory {
                    category: get(category),
                    super_category: get(super_category),
                },
            );
        }
        Ok(FutureCategories { map })
    }

    /// Parses a 3D-FUTURE `model_info.json` (a list of `{model_id, category,
    /// super-category, …}`); the caller names the file in errors.
    pub fn parse_model_info(text: &str) -> Result<Self, Invalid> {
        let text = text.trim_start_matches('\u{feff}');
        let models: Vec<ModelInfo> = serde_json::from_str(text).map_err(|e| {
            Invalid::new(
                e.to_string()
                    .split_whitespace()
                    .collect::<Vec<_>>()
                    .join(" "),
            )
        })?;
        let map = models
            .into_iter()
            .map(|m| {
                (
                    m.model_id,
                    FutureCategory {
                        category: label(m.category.as_deref()),
                        super_category: label(m.super_category.as_deref()),
                    },
                )
            })
            .collect();
        Ok(FutureCategories { map })
    }

    /// Categories of a model, if listed.
    pub fn get(&self, jid: &str) -> Option<&FutureCategory> {
        self.map.get(jid)
    }

    /// Number of models listed.
    #[cfg(feature = "internals")]
    pub fn len(&self) -> usize {
        self.map.len()
    }

    /// True when no model is listed.
    #[cfg(feature = "internals")]
    pub fn is_empty(&self) -> bool {
        self.map.is_empty()
    }
}

/// What an architecture mesh (`mesh[].type`) becomes in the canonical scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArchRole {
    /// Part of the referencing room's floor, ceiling or walls (a world-space surface).
    Surface(SurfaceKind),
    /// An object of its own (filled as a solid by the bake), with a category name and flags.
    Object {
        /// Category given to the object (`door`, `window`, `arch`, …).
        category: &'static str,
        /// Door / window / arch / stairs flags.
        flags: ObjectFlags,
    },
}

const fn flags(door: bool, window: bool, arch: bool, stairs: bool) -> ObjectFlags {
    ObjectFlags {
        door,
        window,
        arch,
        stairs,
    }
}

const NO_FLAGS: ObjectFlags = flags(false, false, false, false);

/// Known architecture mesh types and their role. Types not listed fall back to name rules in
/// [`arch_role`].
const ARCH_TYPES: &[(&str, ArchRole)] = &[
    ("Floor", ArchRole::Surface(SurfaceKind::Floor)),
    ("Ceiling", ArchRole::Surface(SurfaceKind::Ceiling)),
    ("CustomizedCeiling", ArchRole::Surface(SurfaceKind::Ceiling)),
    (
        "SmartCustomizedCeiling",
        ArchRole::Surface(SurfaceKind::Ceiling),
    ),
    (
        "ExtrusionCustomizedCeilingModel",
        ArchRole::Surface(SurfaceKind::Ceiling),
    ),
    ("LightBand", ArchRole::Surface(SurfaceKind::Ceiling)),
    ("SlabBottom", ArchRole::Surface(SurfaceKind::Ceiling)),
    ("WallInner", ArchRole::Surface(SurfaceKind::Wall)),
    ("WallOuter", ArchRole::Surface(SurfaceKind::Wall)),
    ("WallTop", ArchRole::Surface(SurfaceKind::Wall)),
    ("WallBottom", ArchRole::Surface(SurfaceKind::Wall)),
    ("Baseboard", ArchRole::Surface(SurfaceKind::Wall)),
    ("Pocket", ArchRole::Surface(SurfaceKind::Wall)),
    (
        "CustomizedFeatureWall",
        ArchRole::Surface(SurfaceKind::Wall),
    ),
    (
        "ExtrusionCustomizedBackgroundWall",
        ArchRole::Surface(SurfaceKind::Wall),
    ),
    (
        "CustomizedBackgroundModel",
        ArchRole::Surface(SurfaceKind::Wall),
    ),
    ("Customized_wainscot", ArchRole::Surface(SurfaceKind::Wall)),
    ("Front", ArchRole::Surface(SurfaceKind::Wall)),
    ("Back", ArchRole::Surface(SurfaceKind::Wall)),
    ("SlabSide", ArchRole::Surface(SurfaceKind::Wall)),
    ("SlabTop", ArchRole::Surface(SurfaceKind::Wall)),
    ("Beam", ArchRole::Surface(SurfaceKind::Wall)),
    ("Column", ArchRole::Surface(SurfaceKind::Wall)),
    ("Flue", ArchRole::Surface(SurfaceKind::Wall)),
    ("SewerPipe", ArchRole::Surface(SurfaceKind::Wall)),
    ("BayWindow", ArchRole::Surface(SurfaceKind::Wall)),
    (
        "Door",
        ArchRole::Object {
            category: "door",
            flags: flags(true, false, false, false),
        },
    ),
    (
        "Window",
        ArchRole::Object {
            category: "window",
            flags: flags(false, true, false, false),
        },
    ),
    (
        "Hole",
        ArchRole::Object {
            category: "arch",
            flags: flags(false, false, true, false),
        },
    ),
    (
        "Stair",
        ArchRole::Object {
            category: "stairs",
            flags: flags(false, false, false, true),
        },
    ),
    (
        "CustomizedPlatform",
        ArchRole::Object {
            category: "platform",
            flags: NO_FLAGS,
        },
    ),
    (
        "CustomizedFixedFurniture",
        ArchRole::Object {
            category: "fixed_furniture",
            flags: NO_FLAGS,
        },
    ),
    (
        "CustomizedFurniture",
        ArchRole::Object {
            category: "fixed_furniture",
            flags: NO_FLAGS,
        },
    ),
    (
        "CustomizedPersonalizedModel",
        ArchRole::Object {
            category: "fixed_furniture",
            flags: NO_FLAGS,
        },
    ),
    (
        "Cabinet",
        ArchRole::Object {
            category: "cabinet",
            flags: NO_FLAGS,
        },
    ),
    (
        "Cabinet/LightBand",
        ArchRole::Object {
            category: "cabinet",
            flags: NO_FLAGS,
        },
    ),
];

/// The role of an architecture mesh type, and whether the type is a known one.
///
/// Unknown types follow the 3D-FRONT ToolBox's name rules (`…Ceil…` is ceiling, `…Floor…` is
/// floor, `…Wall…` is wall; `…Door…` / `…Window…` become door / window objects); anything else
/// is treated as wall, which never makes floor.
pub fn arch_role(kind: &str) -> (ArchRole, bool) {
    if let Some((_, role)) = ARCH_TYPES
        .iter()
        .find(|(name, _)| name.eq_ignore_ascii_case(kind.trim()))
    {
        return (*role, true);
    }
    let k = kind.to_ascii_lowercase();
    let role = if k.contains("ceil") {
        ArchRole::Surface(SurfaceKind::Ceiling)
    } else if k.contains("floor") {
        ArchRole::Surface(SurfaceKind::Floor)
    } else if k.contains("door") {
        ArchRole::Object {
            category: "door",
            flags: flags(true, false, false, false),
        }
    } else if k.contains("window") {
        ArchRole::Object {
            category: "window",
            flags: flags(false, true, false, false),
        }
    } else {
        ArchRole::Surface(SurfaceKind::Wall)
    };
    (role, false)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn room_types_cover_the_nine_classes_case_insensitively() {
        let t = FrontRoomTypes::builtin();
        assert!(t.map.len() >= 30, "{}", t.map.len());
        assert_eq!(t.class_of("LivingDiningRoom"), Some(RoomClass::LivingRoom));
        assert_eq!(t.class_of("masterbedroom"), Some(RoomClass::Bedroom));
        assert_eq!(t.class_of(" Bathroom "), Some(RoomClass::Bathroom));
        assert_eq!(t.class_of("Kitchen"), Some(RoomClass::Kitchen));
        assert_eq!(t.class_of("DiningRoom"), Some(RoomClass::DiningRoom));
        assert_eq!(t.class_of("Library"), Some(RoomClass::Office));
        assert_eq!(t.class_of("Aisle"), Some(RoomClass::Hallway));
        assert_eq!(t.class_of("Balcony"), Some(RoomClass::Outdoor));
        assert_eq!(t.class_of("StorageRoom"), Some(RoomClass::Other));
        assert_eq!(t.class_of("Spaceship"), None);
    }

    #[test]
    fn future_csv_reads_category_and_super_category() {
        let csv = "index,model_id,category,super-category\r\n\
                   0,a-1,Floor Lamp,Lighting\r\n\
                   1,b-2,,Chair\r\n\r\n";
        let t = FutureCategories::parse_csv(csv).unwrap();
        assert_eq!(t.map.len(), 2);
        let a = t.get("a-1").unwrap();
        assert_eq!(a.category.as_deref(), Some("Floor Lamp"));
        assert_eq!(a.super_category.as_deref(), Some("Lighting"));
        assert_eq!(t.get("b-2").unwrap().category, None);
        let err = FutureCategories::parse_csv("a,b\n").unwrap_err();
        assert_eq!(err.at, ["line 1"]);
        assert!(err.problem.contains("model_id"), "{err}");
    }

    #[test]
    fn model_info_json_reads_categories() {
        let json = r#"[{"model_id": "m1", "category": "Nightstand", "super-category": "Cabinet/Shelf/Desk", "style": "Modern"}]"#;
        let t = FutureCategories::parse_model_info(json).unwrap();
        assert_eq!(
            t.get("m1").unwrap().super_category.as_deref(),
            Some("Cabinet/Shelf/Desk")
        );
        let err = FutureCategories::parse_model_info("{\n").unwrap_err();
        assert!(!err.to_string().contains('\n'), "{err}");
    }

    #[test]
    fn arch_types_map_to_surfaces_and_objects() {
        assert_eq!(
            arch_role("Floor"),
            (ArchRole::Surface(SurfaceKind::Floor), true)
        );
        assert_eq!(
            arch_role("WallOuter").0,
            ArchRole::Surface(SurfaceKind::Wall)
        );
        assert_eq!(
            arch_role("Baseboard").0,
            ArchRole::Surface(SurfaceKind::Wall)
        );
        assert_eq!(
            arch_role("CustomizedCeiling").0,
            ArchRole::Surface(SurfaceKind::Ceiling)
        );
        match arch_role("Door").0 {
            ArchRole::Object { category, flags } => {
                assert_eq!(category, "door");
                assert!(flags.door && !flags.window);
            }
            other => panic!("{other:?}"),
        }
        match arch_role("Hole").0 {
            ArchRole::Object { flags, .. } => assert!(flags.arch && !flags.door),
            other => panic!("{other:?}"),
        }
        // Unknown types: name rules, flagged as unknown.
        assert_eq!(
            arch_role("FancyCeilingThing"),
            (ArchRole::Surface(SurfaceKind::Ceiling), false)
        );
        assert_eq!(
            arch_role("Mystery"),
            (ArchRole::Surface(SurfaceKind::Wall), false)
        );
    }
}
