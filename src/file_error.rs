//! [`FileError`]: a file system error and the file or folder it happened on — the one
//! path-and-cause error of the library. Every error type with a file system failure holds it
//! (`Io(FileError)`), so callers match one shape (`FileError { source, .. }`) and the message
//! is the same everywhere: the path, then the cause (`escape::error_line`).

use std::io;
use std::path::PathBuf;

/// A file system error on `path`. Displays the path; the I/O error is its `source()`.
#[derive(Debug, thiserror::Error)]
#[error("{}", path.display())]
pub struct FileError {
    /// The file or folder.
    pub path: PathBuf,
    /// What the file system said.
    #[source]
    pub source: io::Error,
}

impl FileError {
    /// `source`, which happened on `path`.
    pub fn new(path: impl Into<PathBuf>, source: io::Error) -> Self {
        FileError {
            path: path.into(),
            source,
        }
    }

    /// Whether the file or folder does not exist.
    pub fn not_found(&self) -> bool {
        self.source.kind() == io::ErrorKind::NotFound
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shows_the_path_and_keeps_the_cause_as_its_source() {
        let e = FileError::new(
            "DATA/houses.parquet",
            io::Error::from(io::ErrorKind::NotFound),
        );
        assert_eq!(e.to_string(), "DATA/houses.parquet");
        assert!(e.not_found());
        let line = crate::escape::error_line(&e);
        assert!(line.starts_with("DATA/houses.parquet: "), "{line}");
        assert_eq!(
            line,
            format!(
                "DATA/houses.parquet: {}",
                io::Error::from(io::ErrorKind::NotFound)
            )
        );
        let denied = FileError::new(
            PathBuf::from("x"),
            io::Error::from(io::ErrorKind::PermissionDenied),
        );
        assert!(!denied.not_found());
    }
}
