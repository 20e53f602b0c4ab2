//! [`Invalid`]: a value or a record that breaks a rule minos checks — which record it is
//! (from the outermost in) and what is wrong — the one error type of the library's checks
//! (`validate`, `check`) and of its small text parsers (tables, TOML settings), which their
//! callers wrap with the file they read.

use std::fmt;
use std::path::{Path, PathBuf};

/// A value or record that breaks a rule: where (the records leading to it, outermost first:
/// `level 0`, `room 0_3`) and what is wrong. Displays as one line, `level 0: room 0_3: mesh 9
/// out of range for 4 meshes`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Invalid {
    /// The records leading to the problem, outermost first; empty when it is the checked
    /// value itself.
    pub at: Vec<String>,
    /// What is wrong, naming the field and its value where there is one (`cell_size = 2:
    /// larger than 1 m`).
    pub problem: String,
}

impl Invalid {
    /// A problem of the checked value itself.
    pub fn new(problem: impl Into<String>) -> Self {
        Invalid {
            at: Vec::new(),
            problem: problem.into(),
        }
    }

    /// The same problem, inside `record` (prepended to [`Invalid::at`]).
    pub fn at(mut self, record: impl Into<String>) -> Self {
        self.at.insert(0, record.into());
        self
    }

    /// Wraps a problem found inside `record` (for `map_err`).
    pub fn inside(record: impl Into<String>) -> impl FnOnce(Invalid) -> Invalid {
        let record = record.into();
        move |e| e.at(record)
    }
}

impl fmt::Display for Invalid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for record in &self.at {
            write!(f, "{record}: ")?;
        }
        f.write_str(&self.problem)
    }
}

impl std::error::Error for Invalid {}

impl From<String> for Invalid {
    fn from(problem: String) -> Self {
        Invalid::new(problem)
    }
}

impl From<&str> for Invalid {
    fn from(problem: &str) -> Self {
        Invalid::new(problem)
    }
}

/// The one-line message, for the error types that carry a located message (a file's
/// `Parse { path, message }`).
impl From<Invalid> for String {
    fn from(e: Invalid) -> String {
        e.to_string()
    }
}

/// A settings file a user writes (a variant spec, grid parameters: TOML or JSON) that could
/// not be read, or that breaks a rule: the file, and the cause as the error's source.
#[derive(Debug, thiserror::Error)]
pub enum SettingsFileError {
    /// The file could not be read.
    #[error("{}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// `path` names neither one of the settings minos defines nor an existing file (a
    /// mistyped suite name, say).
    #[error("`{}` is neither a {what} ({}) nor a file", path.display(), .names.join(", "))]
    NotNamed {
        /// The name or file as given.
        path: PathBuf,
        /// What the names name.
        what: &'static str,
        /// The names minos defines.
        names: Vec<&'static str>,
    },
    /// The file is not valid TOML or JSON, or breaks a rule.
    #[error("{}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: SettingsCause,
    },
}

/// Why a settings file's text is not usable: its syntax or types (the TOML or JSON parser's
/// error) or a rule it breaks.
#[derive(Debug, thiserror::Error)]
pub enum SettingsCause {
    /// Not TOML, or TOML of the wrong shape.
    #[error(transparent)]
    Toml(Box<TomlError>),
    /// Not JSON, or JSON of the wrong shape (the parser's error names line and column).
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// It parses but breaks a rule.
    #[error(transparent)]
    Invalid(#[from] Invalid),
    /// The defaults the file's values override could not be laid out as TOML to merge them
    /// (a bug: they are plain numbers and names).
    #[error("the defaults as a TOML table")]
    Defaults(#[source] toml::ser::Error),
}

impl From<TomlError> for SettingsCause {
    fn from(e: TomlError) -> Self {
        SettingsCause::Toml(Box::new(e))
    }
}

impl From<crate::vocab::UnknownName> for SettingsCause {
    fn from(e: crate::vocab::UnknownName) -> Self {
        SettingsCause::Invalid(e.into())
    }
}

impl From<String> for SettingsCause {
    fn from(problem: String) -> Self {
        SettingsCause::Invalid(Invalid::new(problem))
    }
}

impl From<&str> for SettingsCause {
    fn from(problem: &str) -> Self {
        SettingsCause::Invalid(Invalid::new(problem))
    }
}

/// The TOML parser's error, with the line it points at: one line, `line N: message (`the
/// line`)` (the parser's own text spans several lines, with a drawing of the place).
#[derive(Debug)]
pub struct TomlError {
    /// The parser's error.
    pub error: toml::de::Error,
    /// The line number and the line's text, trimmed, where the parser located the error in
    /// the text.
    pub line: Option<(usize, String)>,
}

impl TomlError {
    /// Error `error` of the parser on `text`.
    pub fn in_text(error: toml::de::Error, text: &str) -> Self {
        let line = error.span().map(|span| {
            let start = span.start.min(text.len());
            let n = text[..start].matches('\n').count() + 1;
            (n, text.lines().nth(n - 1).unwrap_or("").trim().to_string())
        });
        TomlError { error, line }
    }

    /// Error `error` of the parser on a value built from the text (no place in it to show).
    pub fn in_value(error: toml::de::Error) -> Self {
        TomlError { error, line: None }
    }
}

impl fmt::Display for TomlError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let message = self.error.message().replace('\n', " ");
        match &self.line {
            Some((n, text)) => write!(f, "line {n}: {message} (`{text}`)"),
            None => f.write_str(&message),
        }
    }
}

/// The parser's error is [`TomlError::error`], not a source: its text would repeat the
/// message over several lines.
impl std::error::Error for TomlError {}

/// Reads the settings file `path` and parses its text with `parse`.
pub fn read_settings<T>(
    path: &Path,
    parse: impl FnOnce(&str) -> Result<T, SettingsCause>,
) -> Result<T, SettingsFileError> {
    let text = std::fs::read_to_string(path).map_err(|source| SettingsFileError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    parse(&text).map_err(|source| SettingsFileError::Invalid {
        path: path.to_path_buf(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_files_name_the_file_and_keep_the_cause() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("s.toml");
        let e = read_settings(&file, |_| Ok(())).unwrap_err();
        assert!(matches!(&e, SettingsFileError::Read { path, .. } if *path == file));
        std::fs::write(&file, "x = 1").unwrap();
        assert_eq!(read_settings(&file, |t| Ok(t.len())).unwrap(), 5);
        let e = read_settings(&file, |_| {
            Err::<(), _>(Invalid::new("x = 1: no such key").into())
        })
        .unwrap_err();
        assert_eq!(e.to_string(), file.display().to_string());
        let cause = std::error::Error::source(&e).map(ToString::to_string);
        assert_eq!(cause.as_deref(), Some("x = 1: no such key"));
    }

    #[test]
    fn records_read_outermost_first() {
        let e = Invalid::new("mesh 9 out of range for 4 meshes")
            .at("room 0_3")
            .at("level 0");
        assert_eq!(e.at, ["level 0", "room 0_3"]);
        assert_eq!(
            e.to_string(),
            "level 0: room 0_3: mesh 9 out of range for 4 meshes"
        );
        let wrapped = Err::<(), _>(Invalid::new("not finite")).map_err(Invalid::inside("box"));
        assert_eq!(wrapped.unwrap_err().to_string(), "box: not finite");
    }
}
