//! The trial crate's one error: trial directories that cannot be read or written, and fields a loader refuses (naming the field and the value).

use std::path::PathBuf;

/// Everything the trial crate can fail with.
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
    /// A value does not fit the integer type it is recorded as (µs times).
    #[error(transparent)]
    OutOfRange(#[from] mesopush_protocol::units::OutOfRange),
    /// A shared helper (atomic file, shard set) failed.
    #[error(transparent)]
    Core(#[from] mesopush_core::Error),
    /// The simulator or a model, plan or fixture failed.
    #[error(transparent)]
    Sim(#[from] mesopush_sim::Error),
    /// Rendering, tracking or a frame source failed.
    #[error(transparent)]
    Vision(#[from] mesopush_vision::Error),
    /// The trial's frame store could not be written or read.
    #[error(transparent)]
    FrameStore(#[from] mesopush_framestore::Error),
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

    /// Shorthand for [`Error::Parse`].
    pub fn parse(path: impl Into<PathBuf>, message: impl ToString) -> Self {
        Error::Parse { path: path.into(), message: message.to_string() }
    }
}
