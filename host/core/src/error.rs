//! The core crate's error: files that cannot be read, written or parsed, values outside what
//! their field allows, and shard sets that do not make a whole run.

use std::path::PathBuf;

/// Everything the shared helpers can fail with.
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
    /// A file could not be parsed or serialised (JSON).
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// What is wrong, with a line or field when known.
        message: String,
    },
    /// An input value is outside what its field allows ([`crate::check`]).
    #[error("invalid {field} = {value}: allowed {allowed}")]
    Invalid {
        /// The field (file key, option name), with an index where it has one.
        field: String,
        /// The value given.
        value: String,
        /// What is allowed (a range with its unit).
        allowed: String,
    },
    /// A shard specification is not `I/N` with 0 ≤ I < N.
    #[error("invalid shard {text:?}: expected I/N with 0 ≤ I < N (e.g. 0/4)")]
    ShardSpec {
        /// What was given.
        text: String,
    },
    /// A set of shard files is not every shard of one split exactly once.
    #[error("{what}: {message}")]
    ShardSet {
        /// The merge (`batch merge`, `robustness merge`, ...).
        what: &'static str,
        /// The file and what is wrong with it.
        message: String,
    },
}

impl Error {
    /// Shorthand for [`Error::Io`].
    pub fn io(path: impl Into<PathBuf>, cause: std::io::Error) -> Self {
        Error::Io { path: path.into(), cause }
    }

    /// Shorthand for [`Error::Invalid`].
    pub fn invalid(field: &str, value: impl ToString, allowed: impl ToString) -> Self {
        Error::Invalid {
            field: field.to_string(),
            value: value.to_string(),
            allowed: allowed.to_string(),
        }
    }

    /// Shorthand for [`Error::Parse`].
    pub fn parse(path: impl Into<PathBuf>, message: impl ToString) -> Self {
        Error::Parse { path: path.into(), message: message.to_string() }
    }
}
