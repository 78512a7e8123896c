//! The one error type of the executor crate.
//!
//! `no_std` rules out `thiserror`, so `Display` is written by hand. Refusals the host must
//! hear about (bad images, unsafe plans, commands in the wrong state) are not errors of the
//! core but outputs to the host; this enum covers misuse of the core and failures of its I/O
//! traits.

use core::fmt;

/// Why an executor operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ExecError {
    /// A configuration field is out of range.
    BadConfig {
        /// Name of the offending field.
        field: &'static str,
    },
    /// The caller's output buffer had no room for an output the core had to emit.
    OutputFull,
    /// The plan store failed.
    Store(StoreError),
}

/// Why a [`crate::store::PlanStore`] operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum StoreError {
    /// Writing or syncing the plan failed; the previously stored plan is intact.
    WriteFailed,
    /// Reading the stored plan failed.
    ReadFailed,
    /// The stored plan does not verify (wrong length, CRC or header).
    Corrupt,
    /// The stored plan is larger than the buffer it was to be loaded into.
    TooLarge,
}

impl fmt::Display for StoreError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::WriteFailed => write!(f, "writing the plan failed; the old plan is intact"),
            Self::ReadFailed => write!(f, "reading the stored plan failed"),
            Self::Corrupt => write!(f, "the stored plan fails verification"),
            Self::TooLarge => write!(f, "the stored plan exceeds the plan memory"),
        }
    }
}

impl fmt::Display for ExecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::BadConfig { field } => write!(f, "executor config: `{field}` is out of range"),
            Self::OutputFull => write!(f, "output buffer full"),
            Self::Store(e) => write!(f, "plan store: {e}"),
        }
    }
}

impl core::error::Error for ExecError {}
impl core::error::Error for StoreError {}
