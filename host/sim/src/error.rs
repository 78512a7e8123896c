//! The sim crate's one error: bad models, plans and fixtures (naming the field, the value and
//! what is allowed), files that cannot be read, and steps the simulator cannot take.

use std::path::PathBuf;

/// Everything the simulator and its loaders can fail with.
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
    /// A file could not be parsed (TOML, CSV, JSON).
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// What is wrong, with a line or field when known.
        message: String,
    },
    /// An input value is invalid; the message names the value and the rule it breaks.
    #[error("invalid {what}: {message}")]
    Invalid {
        /// The field or object.
        what: &'static str,
        /// The value and the rule it breaks.
        message: String,
    },
    /// A value does not fit the wire's integer type.
    #[error(transparent)]
    OutOfRange(#[from] mesopush_protocol::units::OutOfRange),
    /// A complementarity solve found no verified answer.
    #[error("LCP: {0}")]
    Lcp(#[from] mesopush_lcp::Error),
    /// The simulated peg cannot follow the probe (wedged between probe and fixture).
    #[error("stuck: {0}")]
    Stuck(String),
    /// A polygon is not a valid convex polygon.
    #[error("polygon: {0}")]
    Polygon(#[from] mesopush_core::geom::PolygonError),
    /// A shared helper (atomic file, shard set) failed.
    #[error(transparent)]
    Core(#[from] mesopush_core::Error),
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
