//! The mesopush executor: receives flashed plans, streams probe moves to the motion
//! controller at a fixed rate, timestamps camera frames and records trials.
//!
//! The core ([`Executor`]) is a sans-IO, allocation-free state machine fed `(now_us,
//! input)` ([`Input`]) that appends [`Output`]s to a caller-owned fixed-capacity buffer;
//! time comes from the caller (a [`clock::Clock`]), plans persist through a
//! [`store::PlanStore`]. Capacities are const generics: plan memory `CAP` bytes, look-ahead
//! queue `LA` segments. Time domains are named: `exec_time_us` (this executor's clock),
//! `ctrl_time_us` (the controller's, reached through [`sync::ClockSync`]), `frame_stamp_us`
//! (camera stamps, executor clock). The crate is `#![no_std]`; the `std` feature (default)
//! adds the std shell ([`shell`]), the file-backed plan store, a monotonic clock and the
//! recording schema ([`recording`]) the host's trial logs build on.
//!
//! May depend on: `mesopush-protocol` only (the std shell also on the leaf crates
//! `mesopush-fsx` and `mesopush-framestore`) — never on host crates or the firmware
//! simulator (which its tests use as a peer).
#![no_std]
#![deny(missing_docs)]

#[cfg(feature = "std")]
extern crate std;

pub mod adapter;
#[cfg(feature = "std")]
pub mod bench;
pub mod camera;
pub mod clock;
pub mod config;
pub mod endpoint;
pub mod error;
pub mod flash;
pub mod io;
pub mod machine;
pub mod plan;
#[cfg(feature = "std")]
pub mod recording;
pub mod safety;
#[cfg(feature = "std")]
pub mod shell;
pub mod store;
pub mod stream;
pub mod sync;

pub use camera::{CameraFrame, FrameStamper, StampedFrame};
pub use clock::{Clock, ManualClock};
pub use config::{ExecutorConfig, Segmenting, Workspace};
pub use error::{ExecError, RtCause, RtStep, StoreError};
pub use io::{Input, LogEvent, MIN_FREE_OUTPUTS, Output, Outputs, Refusal};
pub use machine::Executor;
pub use safety::SafetyViolation;
pub use store::{MemStore, PlanStore};
