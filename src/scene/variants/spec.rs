//! What a variant is: a small, named description of changes applied to a scene on load.
//!
//! Variants are written as TOML tables, one per variant name:
//!
//! ```toml
//! [empty]
//! empty = true
//!
//! [no-chairs]
//! remove = ["chair", "candle"]
//! hide = ["person", "plant"]
//!
//! [open]
//! open_doors = true
//! doors = { "0_12" = "closed" }
//!
//! [tex-train]
//! retexture = { seed = 7, texture_set = "train" }
//! ```

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::invalid::{Invalid, SettingsCause, TomlError};

/// `keep_only = "arch"`: the MINOS `archOnly` keyword.
pub const ARCH_ONLY: &str = "arch";

/// One of the three texture sets materials are partitioned into.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TextureSet {
    /// Materials for training scenes.
    Train,
    /// Materials for validation scenes.
    Val,
    /// Materials for test scenes.
    Test,
}

impl TextureSet {
    /// All sets in order.
    pub const ALL: [TextureSet; 3] = [TextureSet::Train, TextureSet::Val, TextureSet::Test];

    /// The set's name.
    pub fn name(self) -> &'static str {
        crate::vocab::Vocabulary::term_name(self)
    }
}

impl crate::vocab::Vocabulary for TextureSet {
    const WHAT: &'static str = "texture set";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: TextureSet::Train,
            name: "train",
            aliases: &[],
            help: "materials for training scenes",
        },
        crate::vocab::Term {
            value: TextureSet::Val,
            name: "val",
            aliases: &[],
            help: "materials for validation scenes",
        },
        crate::vocab::Term {
            value: TextureSet::Test,
            name: "test",
            aliases: &[],
            help: "materials for test scenes",
        },
    ];
}

crate::vocab::name_traits!(TextureSet);

/// The state a door is put in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DoorState {
    /// Passable.
    Open,
    /// Blocking.
    Closed,
}

/// `keep_only`: either the `arch` keyword or a list of categories.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum KeepOnly {
    /// `"arch"` (MINOS `archOnly`) or a single category.
    One(String),
    /// Categories to keep (architecture is always kept).
    Many(Vec<String>),
}

impl KeepOnly {
    /// The rule a list of names gives: none for an empty list, one name (`arch` or a
    /// category) as [`KeepOnly::One`], several as [`KeepOnly::Many`].
    pub fn from_names(names: Vec<String>) -> Option<KeepOnly> {
        match names.len() {
            0 => None,
            1 => names.into_iter().next().map(KeepOnly::One),
            _ => Some(KeepOnly::Many(names)),
        }
    }

    /// The categories named, lower-cased.
    pub fn names(&self) -> Vec<String> {
        match self {
            KeepOnly::One(s) => vec![s.to_ascii_lowercase()],
            KeepOnly::Many(v) => v.iter().map(|s| s.to_ascii_lowercase()).collect(),
        }
    }
}

/// `retexture = { seed = 7, texture_set = "train" }`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Retexture {
    /// Seed of the draws (combined with the scene id, the instance id and the slot).
    pub seed: u64,
    /// The texture set materials are drawn from.
    pub texture_set: TextureSet,
}

/// A variant: clutter, door and material changes, in that order.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VariantSpec {
    /// Categories (any taxonomy: fine, coarse, NYU-40, mpcat40) whose instances are removed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub remove: Vec<String>,
    /// Keep only these categories (or `"arch"`: doors, windows, arches, stairs, columns) besides
    /// the rooms' walls, floors and ceilings.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub keep_only: Option<KeepOnly>,
    /// MINOS `emptyRoom`: only doors, arches and windows remain besides the rooms' surfaces.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub empty: bool,
    /// Categories hidden (MINOS's `hide`, default person and plant there): removed like `remove`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub hide: Vec<String>,
    /// Open every closed door.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub open_doors: bool,
    /// Per-door state by object instance id; applied after `open_doors`.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub doors: BTreeMap<String, DoorState>,
    /// Redraw every material slot from its category's material statistics.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub retexture: Option<Retexture>,
}

impl VariantSpec {
    /// Parses one variant's table (the format of `DATA/variants/<name>.toml`).
    pub fn from_toml(text: &str) -> Result<Self, SettingsCause> {
        let spec: VariantSpec = toml::from_str(text).map_err(|e| TomlError::in_text(e, text))?;
        spec.validate()?;
        Ok(spec)
    }

    /// The variant's table as TOML.
    pub fn to_toml(&self) -> String {
        // A struct of strings, lists, maps and numbers always serialises.
        toml::to_string(self).unwrap_or_default()
    }

    /// Checks the fields that serde cannot.
    pub fn validate(&self) -> Result<(), Invalid> {
        if self.empty && self.keep_only.is_some() {
            return Err("`empty` and `keep_only` exclude each other".into());
        }
        let lists = [("remove", &self.remove), ("hide", &self.hide)];
        for (field, list) in lists {
            if let Some(bad) = list.iter().find(|c| c.trim().is_empty()) {
                return Err(format!("{field}: empty category name {bad:?}").into());
            }
        }
        if let Some(k) = &self.keep_only {
            if k.names().iter().any(|c| c.trim().is_empty()) || k.names().is_empty() {
                return Err("keep_only: empty category list or name".into());
            }
        }
        Ok(())
    }

    /// True when the variant changes geometry (so navigation grids must be baked for it).
    pub fn changes_geometry(&self) -> bool {
        !self.remove.is_empty()
            || !self.hide.is_empty()
            || self.keep_only.is_some()
            || self.empty
            || self.open_doors
            || !self.doors.is_empty()
    }
}

/// Parses a spec file of named variants: one top-level table per variant.
pub fn parse_spec_file(text: &str) -> Result<Vec<(String, VariantSpec)>, SettingsCause> {
    let table: toml::Table = text.parse().map_err(|e| TomlError::in_text(e, text))?;
    for (name, value) in &table {
        validate_name(name)?;
        if !value.is_table() {
            return Err(format!("{name}: expected a table `[{name}]` of variant fields").into());
        }
    }
    if table.is_empty() {
        return Err("no variants defined (expected tables such as `[empty]`)".into());
    }
    let specs: std::collections::BTreeMap<String, VariantSpec> =
        toml::from_str(text).map_err(|e| TomlError::in_text(e, text))?;
    specs
        .into_iter()
        .map(|(name, spec)| match spec.validate() {
            Ok(()) => Ok((name, spec)),
            Err(e) => Err(SettingsCause::Invalid(e.at(format!("[{name}]")))),
        })
        .collect()
}

/// Checks a variant name: letters, digits, `-` and `_` (it becomes part of file names and ids).
pub fn validate_name(name: &str) -> Result<(), Invalid> {
    let ok = !name.is_empty()
        && name.len() <= 64
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    if ok {
        Ok(())
    } else {
        Err(format!("variant name {name:?}: use 1–64 letters, digits, `-` or `_`").into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_sets_are_named_alike_in_files_and_on_the_command_line() {
        use crate::vocab::Vocabulary;
        for set in TextureSet::ALL {
            let in_files = toml::Value::try_from(set).unwrap();
            assert_eq!(in_files.as_str(), Some(set.name()));
            assert_eq!(TextureSet::parse_name(set.name()), Ok(set));
        }
        assert_eq!(TextureSet::names(), vec!["train", "val", "test"]);
    }

    #[test]
    fn keep_only_lists_become_one_name_or_many() {
        let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert_eq!(KeepOnly::from_names(vec![]), None);
        assert_eq!(
            KeepOnly::from_names(names(&["arch"])),
            Some(KeepOnly::One("arch".into()))
        );
        assert_eq!(
            KeepOnly::from_names(names(&["chair", "bed"])),
            Some(KeepOnly::Many(names(&["chair", "bed"])))
        );
    }

    #[test]
    fn spec_file_parses_every_field() {
        let text = r#"
            [empty]
            empty = true
            [tidy]
            remove = ["chair", "Candle"]
            hide = ["person"]
            keep_only = ["table"]
            [open]
            open_doors = true
            doors = { "0_12" = "closed" }
            [tex]
            retexture = { seed = 7, texture_set = "val" }
        "#;
        let v = parse_spec_file(text).unwrap();
        let names: Vec<&str> = v.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["empty", "open", "tex", "tidy"]);
        assert!(v[0].1.empty && v[0].1.changes_geometry());
        assert_eq!(v[1].1.doors["0_12"], DoorState::Closed);
        assert_eq!(
            v[2].1.retexture,
            Some(Retexture {
                seed: 7,
                texture_set: TextureSet::Val
            })
        );
        assert!(!v[2].1.changes_geometry());
        assert_eq!(v[3].1.keep_only.as_ref().unwrap().names(), ["table"]);
        // A variant survives its own file format.
        for (_, spec) in &v {
            assert_eq!(&VariantSpec::from_toml(&spec.to_toml()).unwrap(), spec);
        }
    }

    #[test]
    fn bad_specs_say_what_is_wrong() {
        let e = parse_spec_file("[a]\nremove = 3\n").unwrap_err();
        assert!(
            e.to_string().starts_with("line 2:") && e.to_string().contains("remove = 3"),
            "{e}"
        );
        let e = parse_spec_file("[a]\nempty = true\nkeep_only = \"arch\"\n").unwrap_err();
        assert!(e.to_string().contains("exclude"), "{e}");
        let e =
            parse_spec_file("[a]\nretexture = { seed = 1, texture_set = \"x\" }\n").unwrap_err();
        assert!(
            e.to_string().contains("texture_set") || e.to_string().contains("unknown variant"),
            "{e}"
        );
        let e = parse_spec_file("[a]\nclutter = 1\n").unwrap_err();
        assert!(e.to_string().contains("clutter"), "{e}");
        assert!(parse_spec_file("[\"a@b\"]\nempty = true\n")
            .unwrap_err()
            .to_string()
            .contains("a@b"));
        assert!(parse_spec_file("").is_err());
    }
}
