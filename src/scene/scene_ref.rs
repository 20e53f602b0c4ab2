//! [`SceneRef`]: how every command and file names a scene, `<scene>` or `<scene>@<variant>`.

use std::fmt;
use std::str::FromStr;

/// A scene, or a named variant of it: written `<scene>` or `<scene>@<variant>`.
///
/// The only place where that text form is split and joined; everything else holds a
/// `SceneRef` or its [`Display`](fmt::Display) form.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct SceneRef {
    /// The dataset's scene id (never contains `@`).
    pub scene: String,
    /// The variant applied on load, if any.
    pub variant: Option<String>,
}

impl SceneRef {
    /// The scene itself, without a variant.
    pub fn base(scene: impl Into<String>) -> Self {
        SceneRef {
            scene: scene.into(),
            variant: None,
        }
    }

    /// Parses `<scene>` or `<scene>@<variant>`; everything after the first `@` is the variant.
    /// Never fails: whether the variant exists (or its name is valid) is the store's question.
    pub fn parse(text: &str) -> Self {
        match text.split_once('@') {
            Some((scene, variant)) => SceneRef {
                scene: scene.to_string(),
                variant: Some(variant.to_string()),
            },
            None => SceneRef::base(text),
        }
    }

    /// The same scene with variant `name` (replacing any variant it had).
    pub fn with_variant(&self, name: Option<&str>) -> Self {
        SceneRef {
            scene: self.scene.clone(),
            variant: name.map(str::to_string),
        }
    }

    /// The same scene without a variant.
    pub fn without_variant(&self) -> Self {
        SceneRef::base(self.scene.clone())
    }
}

impl fmt::Display for SceneRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.variant {
            Some(v) => write!(f, "{}@{v}", self.scene),
            None => f.write_str(&self.scene),
        }
    }
}

impl FromStr for SceneRef {
    type Err = std::convert::Infallible;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(SceneRef::parse(s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_form_round_trips() {
        for text in [
            "0004d52d1aeeb8ae6de39d6bd993e992",
            "house_3@empty",
            "a@b@c",
            "x@",
        ] {
            assert_eq!(SceneRef::parse(text).to_string(), text);
        }
        let r = SceneRef::parse("house_3@empty");
        assert_eq!(r.scene, "house_3");
        assert_eq!(r.variant.as_deref(), Some("empty"));
        assert_eq!(SceneRef::parse("a@b@c").variant.as_deref(), Some("b@c"));
        assert_eq!(SceneRef::parse("x@").variant.as_deref(), Some(""));
        assert_eq!(r.without_variant().to_string(), "house_3");
        assert_eq!(r.with_variant(Some("open")).to_string(), "house_3@open");
    }
}
