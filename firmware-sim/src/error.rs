//! The one error type of the firmware simulator crate.

use std::fmt;

/// Why a simulator operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SimError {
    /// A configuration field is out of range.
    BadConfig {
        /// Name of the offending field.
        field: &'static str,
    },
}

impl fmt::Display for SimError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::BadConfig { field } => write!(f, "simulator config: `{field}` is out of range"),
        }
    }
}

impl std::error::Error for SimError {}
