//! The host library's error type: one enum for the crate, each variant naming what went wrong
//! and where, so the CLI can print it as it is.

use std::path::PathBuf;

/// Everything the host library can fail with.
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
    /// A file could not be parsed (TOML, CSV, JSON, Siconos data...).
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// What is wrong, with a line or field when known.
        message: String,
    },
    /// An input value is invalid; the message names the field and the rule it breaks.
    #[error("invalid {what}: {message}")]
    Invalid {
        /// The field or object.
        what: &'static str,
        /// The rule it breaks.
        message: String,
    },
    /// A value does not fit the wire's integer type.
    #[error("{quantity} = {value} {unit} does not fit the wire format")]
    OutOfRange {
        /// The quantity's name.
        quantity: &'static str,
        /// The value, in host units.
        value: f64,
        /// The host unit.
        unit: &'static str,
    },
    /// A complementarity solve found no verified answer.
    #[error("LCP: {0}")]
    Lcp(#[from] crate::lcp::LcpFailure),
    /// The simulated peg cannot follow the probe (wedged between probe and fixture).
    #[error("stuck: {0}")]
    Stuck(String),
    /// A camera could not be opened, configured or read.
    #[error("camera {device}: {message}")]
    Camera {
        /// The device (e.g. `/dev/video0`) or source name.
        device: String,
        /// What went wrong.
        message: String,
    },
    /// A polygon is not a valid convex polygon.
    #[error("polygon: {0}")]
    Polygon(#[from] crate::geom::PolygonError),
}

impl Error {
    /// Shorthand for [`Error::Invalid`].
    pub fn invalid(what: &'static str, message: impl Into<String>) -> Self {
        Error::Invalid { what, message: message.into() }
    }

    /// Shorthand for [`Error::Io`].
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io { path: path.into(), cause: source }
    }
}
