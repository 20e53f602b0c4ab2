//! [`Invalid`]: a value or a record that breaks a rule minos checks — which record it is
//! (from the outermost in) and what is wrong — the one error type of the library's checks
//! (`validate`, `check`) and of its small text parsers (tables, TOML settings), which their
//! callers wrap with the file they read.

use std::fmt;

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

#[cfg(test)]
mod tests {
    use super::*;

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
