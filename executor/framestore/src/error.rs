//! The frame store's one error: files that cannot be written or read, store files that are
//! not what this crate writes (naming the page and what is wrong), frames that do not fit.

use std::path::PathBuf;

/// Everything writing and reading a frame store can fail with.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Reading or writing the file failed.
    #[error("{path}: {cause}")]
    Io {
        /// The store file.
        path: PathBuf,
        /// The OS error.
        cause: std::io::Error,
    },
    /// The file is not a readable frame store (not a TIFF, truncated, a page that is not
    /// 8-bit grey, a page description that is not the store's).
    #[error("{path}: {message}")]
    Malformed {
        /// The store file.
        path: PathBuf,
        /// What is wrong, with the page when known.
        message: String,
    },
    /// A frame or a request does not fit the store; the message names the value and the rule.
    #[error("invalid {what}: {message}")]
    Invalid {
        /// The field or object.
        what: &'static str,
        /// The value and the rule it breaks.
        message: String,
    },
}

impl Error {
    pub(crate) fn io(path: &std::path::Path, cause: std::io::Error) -> Self {
        Self::Io { path: path.to_path_buf(), cause }
    }

    pub(crate) fn malformed(path: &std::path::Path, message: impl Into<String>) -> Self {
        Self::Malformed { path: path.to_path_buf(), message: message.into() }
    }

    pub(crate) fn invalid(what: &'static str, message: impl Into<String>) -> Self {
        Self::Invalid { what, message: message.into() }
    }
}
