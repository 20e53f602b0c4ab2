//! Category and room taxonomies: the vocabulary the model is labelled with (MINOS room classes,
//! category labels, object flags) and the tables that map dataset labels onto it, read from
//! the data files in `data/taxonomy/` compiled into the binary.

use std::collections::HashMap;

use serde::{Deserialize, Serialize};

use crate::invalid::Invalid;

/// The nine MINOS room classes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[repr(u8)]
pub enum RoomClass {
    /// 0: anything else (storage, garage, unlabeled …).
    Other = 0,
    /// 1: bedroom.
    Bedroom = 1,
    /// 2: living room / lounge.
    LivingRoom = 2,
    /// 3: bathroom / toilet.
    Bathroom = 3,
    /// 4: kitchen.
    Kitchen = 4,
    /// 5: dining room.
    DiningRoom = 5,
    /// 6: office / study.
    Office = 6,
    /// 7: hallway / entryway.
    Hallway = 7,
    /// 8: outdoor / balcony.
    Outdoor = 8,
}

impl RoomClass {
    /// All classes in index order.
    pub const ALL: [RoomClass; 9] = [
        RoomClass::Other,
        RoomClass::Bedroom,
        RoomClass::LivingRoom,
        RoomClass::Bathroom,
        RoomClass::Kitchen,
        RoomClass::DiningRoom,
        RoomClass::Office,
        RoomClass::Hallway,
        RoomClass::Outdoor,
    ];

    /// Canonical name (`living_room`).
    pub fn name(self) -> &'static str {
        crate::vocab::Vocabulary::term_name(self)
    }

    /// The class index (0–8).
    pub fn index(self) -> u8 {
        self as u8
    }

    /// Reads a dataset's or a user's room label: a class name or an alias of it (see
    /// [`RoomClass::TERMS`](crate::vocab::Vocabulary::TERMS)), in any case, with spaces for
    /// underscores (`Living Room`, Matterport3D's and MINOS's spelling, reads as
    /// `living_room`).
    pub fn parse_label(label: &str) -> Result<RoomClass, crate::vocab::UnknownName> {
        let name = label.trim().to_ascii_lowercase().replace(' ', "_");
        crate::vocab::Vocabulary::parse_name(&name).map_err(|e: crate::vocab::UnknownName| {
            crate::vocab::UnknownName {
                given: label.to_string(),
                ..e
            }
        })
    }

    /// [`RoomClass::parse_label`], `None` for a label of no class.
    pub fn from_label(label: &str) -> Option<RoomClass> {
        RoomClass::parse_label(label).ok()
    }
}

impl crate::vocab::Vocabulary for RoomClass {
    const WHAT: &'static str = "room class";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: RoomClass::Other,
            name: "other",
            aliases: &[],
            help: "anything else (storage, garage, unlabeled …)",
        },
        crate::vocab::Term {
            value: RoomClass::Bedroom,
            name: "bedroom",
            aliases: &[],
            help: "bedroom",
        },
        crate::vocab::Term {
            value: RoomClass::LivingRoom,
            name: "living_room",
            aliases: &["living", "livingroom", "lounge"],
            help: "living room, lounge",
        },
        crate::vocab::Term {
            value: RoomClass::Bathroom,
            name: "bathroom",
            aliases: &["toilet"],
            help: "bathroom, toilet",
        },
        crate::vocab::Term {
            value: RoomClass::Kitchen,
            name: "kitchen",
            aliases: &[],
            help: "kitchen",
        },
        crate::vocab::Term {
            value: RoomClass::DiningRoom,
            name: "dining_room",
            aliases: &["dining", "diningroom"],
            help: "dining room",
        },
        crate::vocab::Term {
            value: RoomClass::Office,
            name: "office",
            aliases: &["study"],
            help: "office, study",
        },
        crate::vocab::Term {
            value: RoomClass::Hallway,
            name: "hallway",
            aliases: &["hall", "corridor"],
            help: "hallway, entryway, corridor",
        },
        crate::vocab::Term {
            value: RoomClass::Outdoor,
            name: "outdoor",
            aliases: &["balcony"],
            help: "outdoor, balcony",
        },
    ];
}

crate::vocab::name_traits!(RoomClass);

fn csv_rows(text: &str) -> impl Iterator<Item = Vec<&str>> {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .skip(1) // header
        .map(|l| l.split(',').map(str::trim).collect())
}

/// SUNCG raw room types to MINOS classes (`data/taxonomy/suncg_room_types.csv`).
pub struct RoomTypeTable {
    map: HashMap<String, RoomClass>,
}

impl RoomTypeTable {
    /// The SUNCG table compiled into minos.
    pub fn suncg() -> Self {
        let text = include_str!("../../data/taxonomy/suncg_room_types.csv");
        let map = csv_rows(text)
            .filter_map(|r| {
                let class = RoomClass::from_label(r.get(1)?)?;
                Some((r.first()?.to_ascii_lowercase(), class))
            })
            .collect();
        RoomTypeTable { map }
    }

    /// The class of one raw type (`other` when unknown).
    pub fn class_of(&self, raw: &str) -> RoomClass {
        self.map
            .get(&raw.trim().to_ascii_lowercase())
            .copied()
            .unwrap_or(RoomClass::Other)
    }

    /// The class of a room with several raw types: the first that is not `other`.
    pub fn class_of_all<S: AsRef<str>>(&self, raws: &[S]) -> RoomClass {
        raws.iter()
            .map(|r| self.class_of(r.as_ref()))
            .find(|c| *c != RoomClass::Other)
            .unwrap_or(RoomClass::Other)
    }
}

/// Category names that make an object a door, window, arch or stairs
/// (`data/taxonomy/object_flags.csv`).
pub struct FlagTable {
    rows: Vec<(String, String)>,
}

impl FlagTable {
    /// The table compiled into minos.
    pub fn builtin() -> Self {
        let text = include_str!("../../data/taxonomy/object_flags.csv");
        let rows = csv_rows(text)
            .filter_map(|r| Some((r.first()?.to_ascii_lowercase(), r.get(1)?.to_string())))
            .collect();
        FlagTable { rows }
    }

    /// The flags an object with these categories carries.
    pub fn flags_of(&self, cats: &Categories) -> ObjectFlags {
        let mut f = ObjectFlags::default();
        for (category, flag) in &self.rows {
            if cats
                .fine
                .as_deref()
                .is_some_and(|c| c.eq_ignore_ascii_case(category))
                || cats
                    .coarse
                    .as_deref()
                    .is_some_and(|c| c.eq_ignore_ascii_case(category))
            {
                match flag.as_str() {
                    "door" => f.door = true,
                    "window" => f.window = true,
                    "arch" => f.arch = true,
                    "stairs" => f.stairs = true,
                    _ => {}
                }
            }
        }
        f
    }
}

/// SUNCG model id to categories, read from a `ModelCategoryMapping.csv`
/// (`index,model_id,fine_grained_class,coarse_grained_class,empty_struct_obj,nyuv2_40class,…`).
#[derive(Debug, Clone, Default)]
pub struct ModelCategories {
    map: HashMap<String, Categories>,
}

impl ModelCategories {
    /// Parses the CSV text; `source` names the file in errors.
    pub fn parse(text: &str, source: &str) -> Result<Self, Invalid> {
        let mut lines = text.lines().enumerate();
        let header = lines
            .next()
            .map(|(_, h)| h.trim_end_matches('\r'))
            .ok_or_else(|| format!("{source}: empty file"))?;
        let cols: Vec<&str> = header.split(',').map(str::trim).collect();
        let find = |name: &str| cols.iter().position(|c| *c == name);
        let model =
            find("model_id").ok_or_else(|| format!("{source}: line 1: no `model_id` column"))?;
        let fine = find("fine_grained_class");
        let coarse = find("coarse_grained_class");
        let nyu = find("nyuv2_40class");
        let mut map = HashMap::new();
        for (i, line) in lines {
            let line = line.trim_end_matches('\r');
            if line.trim().is_empty() {
                continue;
            }
            let f: Vec<&str> = line.split(',').map(str::trim).collect();
            let id = f
                .get(model)
                .ok_or_else(|| format!("{source}: line {}: missing model_id", i + 1))?;
            let get = |c: Option<usize>| {
                c.and_then(|c| f.get(c))
                    .filter(|v| !v.is_empty() && **v != "-")
                    .map(|v| v.to_string())
            };
            map.insert(
                id.to_string(),
                Categories {
                    fine: get(fine),
                    coarse: get(coarse),
                    nyu40: get(nyu),
                    mpcat40: None,
                },
            );
        }
        Ok(ModelCategories { map })
    }

    /// Categories of a model, if the table lists it.
    pub fn get(&self, model_id: &str) -> Option<&Categories> {
        self.map.get(model_id)
    }

    /// Number of models listed.
    pub fn len(&self) -> usize {
        self.map.len()
    }

    /// True when no model is listed.
    pub fn is_empty(&self) -> bool {
        self.map.is_empty()
    }
}

/// Category labels of an object in the taxonomies the dataset provides.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Categories {
    /// The dataset's fine-grained category (`double_bed`).
    pub fine: Option<String>,
    /// The dataset's coarse category (`bed`).
    pub coarse: Option<String>,
    /// NYU-40 class name (`bed`).
    pub nyu40: Option<String>,
    /// Matterport3D mpcat40 class name.
    pub mpcat40: Option<String>,
}

impl Categories {
    /// The most specific label available, `unknown` when there is none.
    pub fn best(&self) -> &str {
        self.fine
            .as_deref()
            .or(self.coarse.as_deref())
            .or(self.mpcat40.as_deref())
            .or(self.nyu40.as_deref())
            .unwrap_or("unknown")
    }

    /// True when any taxonomy calls the object `name` (case-insensitive).
    pub fn matches(&self, name: &str) -> bool {
        [&self.fine, &self.coarse, &self.nyu40, &self.mpcat40]
            .into_iter()
            .flatten()
            .any(|c| c.eq_ignore_ascii_case(name))
    }
}

/// What kind of architectural element an object is, if any.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ObjectFlags {
    /// A door (open or closed).
    pub door: bool,
    /// A window.
    pub window: bool,
    /// An arch (an opening without a leaf).
    pub arch: bool,
    /// Stairs.
    pub stairs: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suncg_room_types_map_to_minos_classes() {
        let t = RoomTypeTable::suncg();
        assert_eq!(t.class_of("Living_Room"), RoomClass::LivingRoom);
        assert_eq!(t.class_of("toilet"), RoomClass::Bathroom);
        assert_eq!(t.class_of("Balcony"), RoomClass::Outdoor);
        assert_eq!(t.class_of("Garage"), RoomClass::Other);
        assert_eq!(t.class_of("NoSuchType"), RoomClass::Other);
        assert_eq!(t.class_of_all(&["Room", "Kitchen"]), RoomClass::Kitchen);
        assert_eq!(t.class_of_all::<&str>(&[]), RoomClass::Other);
    }

    #[test]
    fn class_names_round_trip() {
        for c in RoomClass::ALL {
            assert_eq!(RoomClass::from_label(c.name()), Some(c));
            assert_eq!(c.to_string().parse::<RoomClass>(), Ok(c));
        }
        assert_eq!(
            RoomClass::from_label(" Living Room "),
            Some(RoomClass::LivingRoom)
        );
        assert_eq!(
            RoomClass::from_label("dining room"),
            Some(RoomClass::DiningRoom)
        );
        assert_eq!(RoomClass::from_label("Corridor"), Some(RoomClass::Hallway));
        // The table is exact; labels are read leniently.
        assert!("Living Room".parse::<RoomClass>().is_err());
        let e = RoomClass::parse_label("Attic").unwrap_err();
        assert_eq!(e.given, "Attic");
        assert_eq!(e.known.len(), 9);
        // Every class is in the table, in index order.
        let named: Vec<RoomClass> = <RoomClass as crate::vocab::Vocabulary>::TERMS
            .iter()
            .map(|t| t.value)
            .collect();
        assert_eq!(named, RoomClass::ALL);
        assert_eq!(RoomClass::ALL[5].index(), 5);
    }

    #[test]
    fn model_categories_and_flags() {
        let csv = "index,model_id,fine_grained_class,coarse_grained_class,empty_struct_obj,nyuv2_40class,wnsynsetid,wnsynsetkey\r\n\
                   26,122,door,door,2,door,n03221720,door.n.01\r\n\
                   652,778,arch,arch,2,door,n02733524,arch.n.04\r\n\
                   9,s__1,double_bed,bed,2,bed,-,-\r\n";
        let t = ModelCategories::parse(csv, "m.csv").unwrap();
        assert_eq!(t.len(), 3);
        let bed = t.get("s__1").unwrap();
        assert_eq!(bed.fine.as_deref(), Some("double_bed"));
        assert_eq!(bed.coarse.as_deref(), Some("bed"));
        let flags = FlagTable::builtin();
        assert!(flags.flags_of(t.get("122").unwrap()).door);
        let arch = flags.flags_of(t.get("778").unwrap());
        assert!(
            arch.arch && !arch.door,
            "nyu40 `door` must not make an arch a door"
        );
        assert_eq!(flags.flags_of(bed), ObjectFlags::default());
    }

    #[test]
    fn model_categories_need_a_model_id_column() {
        let err = ModelCategories::parse("a,b\n1,2\n", "x.csv").unwrap_err();
        assert!(err.to_string().contains("x.csv") && err.to_string().contains("model_id"));
    }
}
