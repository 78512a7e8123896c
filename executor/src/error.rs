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
    /// The OS refused a real-time set-up step of the std shell (`shell::rt`).
    RealTime {
        /// Which step.
        step: RtStep,
        /// Why.
        cause: RtCause,
    },
}

/// A real-time set-up step of the std shell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RtStep {
    /// `mlockall` (no page faults in the loop).
    LockMemory,
    /// Pinning the loop thread to a CPU.
    PinCpu {
        /// The CPU asked for.
        cpu: usize,
    },
    /// `SCHED_FIFO` at a priority.
    FifoPriority {
        /// The priority asked for.
        priority: i32,
    },
}

/// Why a real-time step was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RtCause {
    /// The OS said no (errno; e.g. 1 = no `CAP_SYS_NICE`, 12 = memlock limit).
    Os(i32),
    /// The value asked for is outside what the OS accepts (`allowed` names the range).
    OutOfRange {
        /// The accepted range, e.g. `1..=99`.
        allowed: &'static str,
    },
    /// Not available on this operating system (Linux only).
    Unsupported,
}

impl fmt::Display for RtStep {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::LockMemory => write!(f, "mlockall"),
            Self::PinCpu { cpu } => write!(f, "pin to CPU {cpu}"),
            Self::FifoPriority { priority } => write!(f, "SCHED_FIFO priority {priority}"),
        }
    }
}

impl fmt::Display for RtCause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Os(errno) => write!(f, "refused by the OS (errno {errno})"),
            Self::OutOfRange { allowed } => write!(f, "out of range (allowed: {allowed})"),
            Self::Unsupported => write!(f, "only on Linux"),
        }
    }
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
            Self::RealTime { step, cause } => write!(f, "{step}: {cause}"),
        }
    }
}

impl core::error::Error for ExecError {}
impl core::error::Error for StoreError {}
