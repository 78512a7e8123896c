//! The batch crate's one error: batch specs it refuses (naming the field), batch directories it cannot read, write or trust, and the failures of the crates it builds on.

use std::path::PathBuf;

/// Everything the batch crate can fail with.
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
    /// Another process holds the batch directory's lock (`batch.lock`, see [`crate::lock`]).
    #[error(
        "batch directory {path} is in use: locked by {holder}; wait for it to finish or stop \
         it (the lock is released when that process exits, however it exits)"
    )]
    Locked {
        /// The batch directory.
        path: PathBuf,
        /// Who holds it: pid, host, start time, command.
        holder: String,
    },
    /// A shared helper (atomic file, shard set) failed.
    #[error(transparent)]
    Core(#[from] mesopush_core::Error),
    /// The simulator or a model, plan or fixture failed.
    #[error(transparent)]
    Sim(#[from] mesopush_sim::Error),
    /// Rendering, tracking or a frame source failed.
    #[error(transparent)]
    Vision(#[from] mesopush_vision::Error),
    /// A trial log could not be read or written.
    #[error(transparent)]
    Trial(#[from] mesopush_trial::Error),
    /// A figure could not be drawn.
    #[error(transparent)]
    Plot(#[from] mesopush_plot::Error),
    /// Planning or a robustness run failed.
    #[error(transparent)]
    Plan(#[from] mesopush_plan::Error),
    /// The rig (plant, loop or executor client) failed.
    #[error(transparent)]
    Rig(#[from] mesopush_rig::Error),
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
