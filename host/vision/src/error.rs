//! The vision crate's one error: bad settings and images (naming the field, the value and
//! what is allowed), frame folders that cannot be read, and cameras that cannot be opened
//! or read (`mesopush_capture`'s errors).

use std::path::PathBuf;

/// Everything rendering, tracking and frame sources can fail with.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Reading or writing a file failed.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        cause: std::io::Error,
    },
    /// A file could not be parsed (CSV, PNG).
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// What is wrong, with a line or field when known.
        message: String,
    },
    /// A frame store could not be read (names the file and the page).
    #[error(transparent)]
    Store(#[from] mesopush_framestore::Error),
    /// An input value is invalid; the message names the value and the rule it breaks.
    #[error("invalid {what}: {message}")]
    Invalid {
        /// The field or object.
        what: &'static str,
        /// The value and the rule it breaks.
        message: String,
    },
    /// A camera could not be opened, configured or read, or a frame not converted.
    #[error(transparent)]
    Capture(#[from] mesopush_capture::Error),
    /// A polygon is not a valid convex polygon.
    #[error("polygon: {0}")]
    Polygon(#[from] mesopush_core::geom::PolygonError),
}

impl Error {
    /// Shorthand for [`Error::Invalid`].
    pub fn invalid(what: &'static str, message: impl Into<String>) -> Self {
        Error::Invalid { what, message: message.into() }
    }

    /// Shorthand for [`Error::Io`].
    pub fn io(path: impl Into<PathBuf>, cause: std::io::Error) -> Self {
        Error::Io { path: path.into(), cause }
    }
}
