//! What goes into and comes out of the executor core.
//!
//! Inputs are delivered messages (the links in [`crate::endpoint`] or a shell have already
//! made them reliable and ordered), camera frames, link failures and plain ticks; outputs
//! are messages for the host and the controller and log records for the trial recorder. The
//! caller owns the output buffer ([`Outputs`], fixed capacity): the core never allocates.

use crate::camera::{CameraFrame, StampedFrame};
use crate::error::StoreError;
use crate::safety::SafetyViolation;
use mesopush_protocol::ctrl::CtrlToExec;
use mesopush_protocol::flash::FlashRejectReason;
use mesopush_protocol::host::{MotionEvent, TrialEvent};
use mesopush_protocol::{ExecToCtrl, ExecToHost, HostToExec};

/// One input to [`crate::Executor::handle`].
#[derive(Debug, Clone, Copy)]
pub enum Input<'a> {
    /// A message from the host.
    Host(&'a HostToExec),
    /// A message from the controller.
    Ctrl(&'a CtrlToExec),
    /// A camera frame arrived.
    Frame(CameraFrame),
    /// The host link went down (the link gave up retransmitting).
    HostLinkDown,
    /// The controller link went down.
    CtrlLinkDown,
    /// Nothing arrived; time passed (call at [`crate::Executor::next_deadline_us`]).
    Tick,
}

/// Why an upload was refused, in full (the wire carries a summary).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// Header, chunk or image check failed.
    Image(FlashRejectReason),
    /// The plan breaks a safety limit.
    Safety(SafetyViolation),
    /// Storing the plan failed.
    Store(StoreError),
}

/// Records for the trial log (richer than the wire messages).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LogEvent {
    /// A plan was accepted and stored.
    PlanAccepted {
        /// Plan id.
        plan_id: u32,
        /// Steps.
        step_count: u32,
    },
    /// An upload was refused; the previous plan stays.
    PlanRefused {
        /// Plan id of the upload.
        plan_id: u32,
        /// Why.
        refusal: Refusal,
    },
    /// Arming was refused for safety.
    ArmRefused {
        /// Plan id.
        plan_id: u32,
        /// Why.
        violation: SafetyViolation,
    },
    /// A trial event (also sent to the host).
    Trial(TrialEvent),
    /// A goto or home event (also sent to the host).
    Motion(MotionEvent),
    /// A camera frame was stamped (also sent to the host).
    Frame(StampedFrame),
}

/// One output of the core.
#[derive(Debug, Clone, PartialEq)]
pub enum Output {
    /// Send to the host.
    Host(ExecToHost),
    /// Send to the controller.
    Ctrl(ExecToCtrl),
    /// Record in the trial log.
    Log(LogEvent),
}

/// The caller's output buffer.
pub type Outputs<const N: usize> = heapless::Vec<Output, N>;

/// Free output slots [`crate::Executor::handle`] needs besides streamed segments; a buffer
/// must hold at least this many more than the look-ahead queue.
pub const MIN_FREE_OUTPUTS: usize = 8;

impl core::fmt::Display for Refusal {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Image(reason) => write!(f, "{reason}"),
            Self::Safety(violation) => write!(f, "the plan is unsafe: {violation}"),
            Self::Store(e) => write!(f, "{e}"),
        }
    }
}

impl core::fmt::Display for LogEvent {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        use mesopush_protocol::host::TrialEventKind as K;
        match self {
            Self::PlanAccepted { plan_id, step_count } => {
                write!(f, "plan {plan_id:08x} accepted: {step_count} steps")
            }
            Self::PlanRefused { plan_id, refusal } => {
                write!(f, "plan {plan_id:08x} refused: {refusal}")
            }
            Self::ArmRefused { plan_id, violation } => {
                write!(f, "arming plan {plan_id:08x} refused: {violation}")
            }
            Self::Trial(t) => {
                write!(f, "trial of plan {:08x} at step {}: ", t.plan_id, t.step_index)?;
                match t.kind {
                    K::Started => f.write_str("started"),
                    K::Done => f.write_str("done"),
                    K::Aborted => f.write_str("aborted"),
                    K::Faulted(fault) => write!(f, "faulted: {fault}"),
                }
            }
            Self::Motion(m) => write!(f, "goto: {}", m.kind),
            Self::Frame(s) => write!(f, "frame {} stamped", s.stamp.frame_seq),
        }
    }
}
