//! The 3D-FRONT scene JSON as serde reads it, and the byte-level clean-up done before.
//!
//! This file only knows the shape of the file: which keys exist and their JSON types. Every
//! field a real file may omit is optional here; whether a value makes sense (finite numbers,
//! indices in range, a rotation that is a rotation) is checked by `geometry` and `assemble`,
//! which know the record a value belongs to and can name it in the error.

use serde::Deserialize;

use crate::invalid::Invalid;

/// A whole scene file (`<scene uid>.json`).
#[derive(Debug, Deserialize)]
pub(super) struct FrontJson {
    /// The scene uid (normally the file stem).
    #[serde(default)]
    pub uid: Option<String>,
    /// Architecture meshes with inline geometry.
    #[serde(default)]
    pub mesh: Vec<MeshJson>,
    /// Furniture models (3D-FUTURE references).
    #[serde(default)]
    pub furniture: Vec<FurnitureJson>,
    /// Materials the architecture meshes refer to.
    #[serde(default)]
    pub material: Vec<MaterialJson>,
    /// Extra data; only `extension.door[].ref` is read, leniently.
    #[serde(default)]
    pub extension: Option<serde_json::Value>,
    /// The room tree.
    pub scene: SceneJson,
}

/// One architecture mesh (`mesh[]`).
#[derive(Debug, Deserialize)]
pub(super) struct MeshJson {
    #[serde(default)]
    pub uid: Option<String>,
    #[serde(default, rename = "type")]
    pub kind: Option<String>,
    #[serde(default)]
    pub xyz: Option<Vec<Option<f64>>>,
    #[serde(default)]
    pub normal: Option<Vec<Option<f64>>>,
    #[serde(default)]
    pub uv: Option<Vec<Option<f64>>>,
    #[serde(default)]
    pub faces: Option<Vec<i64>>,
    #[serde(default)]
    pub material: Option<String>,
}

/// One furniture model (`furniture[]`).
#[derive(Debug, Deserialize)]
pub(super) struct FurnitureJson {
    #[serde(default)]
    pub uid: Option<String>,
    #[serde(default)]
    pub jid: Option<String>,
    #[serde(default)]
    pub title: Option<String>,
    #[serde(default)]
    pub category: Option<String>,
    /// Model extents as (length x, depth z, height y).
    #[serde(default)]
    pub size: Option<Vec<Option<f64>>>,
    /// Model extents as (x, y, z); a flat triple or a list holding one triple.
    #[serde(default)]
    pub bbox: Option<serde_json::Value>,
    /// `false` (or 0) marks a model the dataset does not provide.
    #[serde(default)]
    pub valid: Option<serde_json::Value>,
}

/// One material (`material[]`).
#[derive(Debug, Deserialize)]
pub(super) struct MaterialJson {
    #[serde(default)]
    pub uid: Option<String>,
    #[serde(default)]
    pub texture: Option<String>,
    /// RGBA in 0–255.
    #[serde(default)]
    pub color: Option<serde_json::Value>,
}

/// The `scene` object.
#[derive(Debug, Deserialize)]
pub(super) struct SceneJson {
    #[serde(default)]
    pub room: Vec<RoomJson>,
}

/// One room (`scene.room[]`).
#[derive(Debug, Deserialize)]
pub(super) struct RoomJson {
    #[serde(default, rename = "type")]
    pub kind: Option<String>,
    #[serde(default)]
    pub instanceid: Option<String>,
    #[serde(default)]
    pub children: Vec<ChildJson>,
}

/// One placed instance of a mesh or a furniture model (`scene.room[].children[]`).
#[derive(Debug, Deserialize)]
pub(super) struct ChildJson {
    #[serde(default, rename = "ref")]
    pub reference: Option<String>,
    #[serde(default)]
    pub instanceid: Option<String>,
    #[serde(default)]
    pub pos: Option<Vec<Option<f64>>>,
    #[serde(default)]
    pub rot: Option<Vec<Option<f64>>>,
    #[serde(default)]
    pub scale: Option<Vec<Option<f64>>>,
}

impl FurnitureJson {
    /// False only when the file says the model is not valid (`valid: false` or `0`).
    pub fn is_valid(&self) -> bool {
        match &self.valid {
            Some(serde_json::Value::Bool(b)) => *b,
            Some(serde_json::Value::Number(n)) => n.as_f64() != Some(0.0),
            _ => true,
        }
    }
}

impl FrontJson {
    /// Parses the file's bytes; the error is `line L column C: what` (one line).
    pub fn parse(bytes: &[u8]) -> Result<FrontJson, Invalid> {
        let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        serde_json::from_slice(&crate::scene::formats::nan_tokens_to_null(bytes))
            .map_err(|e| Invalid::new(crate::scene::formats::json_error_text(&e)))
    }

    /// Every string listed in `extension.door[].ref` (the furniture and meshes of doors).
    pub fn door_refs(&self) -> Vec<String> {
        let Some(doors) = self
            .extension
            .as_ref()
            .and_then(|e| e.get("door"))
            .and_then(|d| d.as_array())
        else {
            return Vec::new();
        };
        doors
            .iter()
            .filter_map(|d| d.get("ref"))
            .flat_map(|r| match r {
                serde_json::Value::Array(a) => a.iter().filter_map(|v| v.as_str()).collect(),
                serde_json::Value::String(s) => vec![s.as_str()],
                _ => Vec::new(),
            })
            .map(str::to_string)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn door_refs_read_strings_and_lists_and_ignore_other_shapes() {
        let j = FrontJson::parse(
            br#"{"scene": {"room": []}, "extension": {"door": [
                {"ref": ["a/model", "m/1", 3]}, {"ref": "b/model"}, {"ref": {"x": 1}}, 7]}}"#,
        )
        .unwrap();
        assert_eq!(j.door_refs(), vec!["a/model", "m/1", "b/model"]);
        let none = FrontJson::parse(br#"{"scene": {}, "extension": "x"}"#).unwrap();
        assert!(none.door_refs().is_empty());
    }

    #[test]
    fn syntax_errors_give_line_and_column_on_one_line() {
        let err = FrontJson::parse(b"{\r\n  \"scene\": {\r\n    \"room\": [}\r\n}").unwrap_err();
        assert!(err.to_string().starts_with("line 3 column "), "{err}");
        assert!(!err.to_string().contains('\n'));
    }

    #[test]
    fn validity_accepts_bools_and_numbers() {
        let f = |v: &str| -> bool {
            let json = format!(r#"{{"uid": "u", "valid": {v}}}"#);
            serde_json::from_str::<FurnitureJson>(&json)
                .unwrap()
                .is_valid()
        };
        assert!(f("true") && f("1") && f("null"));
        assert!(!f("false") && !f("0"));
    }
}
