//! Host ↔ executor messages.
//!
//! The host opens with a versioned handshake, flashes a plan in chunks, arms and starts it,
//! and may abort; the executor answers with status, trial events, a stamp for every camera
//! frame and probe telemetry. Times named `exec_time_us` / `frame_stamp_us` are in the
//! executor's clock, `ctrl_time_us` in the controller's, `host_time_us` in the host's.

use crate::ctrl::{CtrlState, FaultReport};
use crate::flash::{FlashChunk, FlashHeader, FlashRejectReason, SafetyLimit};
use crate::max_size::{MaxSize, discriminant_bytes, max_of};
use serde::{Deserialize, Serialize};

/// Handshake contents, sent by both sides.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Hello {
    /// Sender's [`crate::PROTOCOL_VERSION`].
    pub protocol_version: u16,
    /// Sender's [`crate::SCHEMA_HASH`].
    pub schema_hash: u32,
}

impl Hello {
    /// The hello of this build of the protocol crate.
    pub const CURRENT: Self =
        Self { protocol_version: crate::PROTOCOL_VERSION, schema_hash: crate::SCHEMA_HASH };

    /// Whether a peer sending `self` speaks exactly our protocol.
    pub fn is_compatible(&self) -> bool {
        *self == Self::CURRENT
    }
}

/// Host → executor.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum HostToExec {
    /// Open the session; the executor answers [`ExecToHost::HelloReply`].
    Hello(Hello),
    /// Begin flashing the plan described by the header. The previous plan stays until the
    /// new one is accepted.
    FlashBegin(FlashHeader),
    /// Next chunk of the image.
    FlashChunk(FlashChunk),
    /// All chunks sent: verify the image and answer accepted or rejected.
    FlashCommit {
        /// Plan being committed.
        plan_id: u32,
    },
    /// Arm the flashed plan (the executor syncs its clock with the controller). The plan's
    /// moves are relative; `start` is where the host's plan says they begin, in the stage's
    /// absolute frame. The executor refuses ([`CommandRejectReason::StartMismatch`]) when the
    /// probe's reported position is farther from it than its configured tolerance.
    Arm {
        /// Plan expected to be flashed.
        plan_id: u32,
        /// The plan's stated start, stage frame.
        start: StagePoint,
    },
    /// Start the armed plan.
    Start {
        /// Plan expected to be armed.
        plan_id: u32,
    },
    /// Stop now; the trial ends as aborted.
    Abort,
    /// Ask for an [`ExecToHost::Status`].
    StatusQuery,
    /// Host is alive; the executor stops a trial if these cease.
    Heartbeat {
        /// Host time at sending, µs in the host's clock.
        host_time_us: u64,
    },
    /// Move the probe to `target` (stage frame) between trials: a straight line (inside the
    /// convex workspace box) at the executor's configured goto speed. Answered by
    /// [`ExecToHost::Motion`] events, or refused.
    Goto {
        /// Where to, stage frame.
        target: StagePoint,
    },
    /// [`HostToExec::Goto`] the executor's configured home (park) position.
    Home,
    /// Stop the probe now, from any state: a running trial ends as aborted, a goto as
    /// stopped; answered by [`ExecToHost::Status`].
    Stop,
}

/// A probe position in the stage's absolute frame (what the controller reports), nm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct StagePoint {
    /// x, nm.
    pub x_nm: i32,
    /// y, nm.
    pub y_nm: i32,
}

/// Executor life cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ExecState {
    /// No plan.
    Idle,
    /// Receiving chunks.
    Flashing,
    /// A verified plan is stored.
    PlanFlashed,
    /// Ready to start; clock synced with the controller.
    Armed,
    /// Streaming the plan.
    Running,
    /// The plan finished.
    Done,
    /// The host aborted.
    Aborted,
    /// A fault stopped the trial.
    Faulted,
    /// A goto (or home) is moving the probe.
    Moving,
}

/// Executor status snapshot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ExecStatus {
    /// When taken, µs in the executor's clock.
    pub exec_time_us: u64,
    /// Life-cycle state.
    pub state: ExecState,
    /// Plan stored, if any.
    pub plan_id: Option<u32>,
    /// Steps in the stored plan.
    pub step_count: u32,
    /// Next step to stream.
    pub step_index: u32,
    /// Why the last trial (or goto) faulted, if it did.
    pub last_fault: Option<TrialFault>,
    /// The probe's absolute position from the controller's latest report, if any.
    pub probe: Option<StagePoint>,
    /// The controller's motion state from its latest status, if any.
    pub ctrl_state: Option<CtrlState>,
}

/// Why the executor refused a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CommandRejectReason {
    /// The command is not valid in the current state.
    WrongState {
        /// State when the command arrived.
        state: ExecState,
    },
    /// The command named another plan than the one stored.
    PlanIdMismatch {
        /// Plan stored, if any.
        stored_plan_id: Option<u32>,
    },
    /// The peer's protocol version or schema hash differs (or no handshake yet).
    Incompatible,
    /// Arming refused: from the probe's current position the plan breaks a safety limit.
    Unsafe {
        /// Offending step; `None` when the probe already is outside the workspace.
        step_index: Option<u32>,
        /// Which limit.
        limit: SafetyLimit,
    },
    /// Arming refused for now: the controller's clock is not synced yet or its probe
    /// position is unknown; retry.
    NotReady {
        /// Clock sync with the controller is established.
        clock_synced: bool,
        /// A controller position report has been received.
        position_known: bool,
        /// The controller is not in its faulted state (the executor has asked it to clear
        /// the fault; retry).
        ctrl_ready: bool,
    },
    /// Arming refused: the probe is not where the plan says it starts.
    StartMismatch {
        /// The probe, from the controller's latest report.
        probe: StagePoint,
        /// The plan's stated start.
        start: StagePoint,
        /// The executor's tolerance, nm.
        tolerance_nm: u32,
    },
    /// A goto target outside the workspace box.
    OutsideWorkspace {
        /// The target.
        target: StagePoint,
        /// The box's smallest corner.
        min: StagePoint,
        /// The box's largest corner.
        max: StagePoint,
    },
}

/// Why a trial stopped on its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum TrialFault {
    /// The controller reported a fault.
    Controller(FaultReport),
    /// No frame from the controller since this executor time.
    ControllerSilent {
        /// Last time the controller was heard, µs in the executor's clock.
        last_heard_exec_time_us: u64,
    },
    /// No frame from the host since this executor time.
    HostLinkLost {
        /// Last time the host was heard, µs in the executor's clock.
        last_heard_exec_time_us: u64,
    },
    /// Clock sync with the controller failed or drifted beyond bounds.
    ClockSyncLost,
    /// The controller queue was about to run dry and the executor could not refill it.
    StreamUnderrun {
        /// Step that could not be streamed in time.
        step_index: u32,
    },
}

/// What happened in a trial.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum TrialEventKind {
    /// The plan started streaming.
    Started,
    /// All steps executed.
    Done,
    /// The host aborted.
    Aborted,
    /// A fault stopped the trial.
    Faulted(TrialFault),
}

/// A trial event with its time and the step reached.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct TrialEvent {
    /// When it happened, µs in the executor's clock.
    pub exec_time_us: u64,
    /// Plan of the trial.
    pub plan_id: u32,
    /// Step being executed at the time.
    pub step_index: u32,
    /// What happened.
    pub kind: TrialEventKind,
}

/// Stamp of one camera frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct FrameStamp {
    /// Camera frame counter; a gap means dropped frames.
    pub frame_seq: u32,
    /// Exposure time, µs in the executor's clock.
    pub frame_stamp_us: u64,
    /// Probe x at exposure, nm.
    pub probe_x_nm: i32,
    /// Probe y at exposure, nm.
    pub probe_y_nm: i32,
}

/// Periodic probe telemetry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ProbeTelemetry {
    /// Executor time of the sample, µs in the executor's clock.
    pub exec_time_us: u64,
    /// Controller time of the sample, µs in the controller's clock.
    pub ctrl_time_us: u64,
    /// Probe x, nm.
    pub probe_x_nm: i32,
    /// Probe y, nm.
    pub probe_y_nm: i32,
    /// Step being executed.
    pub step_index: u32,
    /// Free slots in the controller queue.
    pub ctrl_queue_free_slots: u16,
}

/// What a goto (or home) did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum MotionEventKind {
    /// The move started towards `target`.
    Started {
        /// Where to.
        target: StagePoint,
    },
    /// The move ended; the probe's last reported position.
    Arrived {
        /// Where the probe is.
        at: StagePoint,
    },
    /// A [`HostToExec::Stop`] ended the move.
    Stopped,
    /// A fault stopped the move.
    Faulted(TrialFault),
}

/// A goto or home event with its time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct MotionEvent {
    /// When it happened, µs in the executor's clock.
    pub exec_time_us: u64,
    /// What happened.
    pub kind: MotionEventKind,
}

/// Executor → host.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum ExecToHost {
    /// Handshake answer; `accepted` is false when versions or schemas differ.
    HelloReply {
        /// The executor's hello.
        hello: Hello,
        /// Whether the executor accepts the host's hello.
        accepted: bool,
    },
    /// Chunk stored; `received_bytes` of the image so far.
    FlashProgress {
        /// Plan being flashed.
        plan_id: u32,
        /// Image bytes received so far.
        received_bytes: u32,
    },
    /// Image verified and stored.
    FlashAccepted {
        /// Plan stored.
        plan_id: u32,
        /// Steps in it.
        step_count: u32,
    },
    /// Image refused; the previously accepted plan, if any, stays stored.
    FlashRejected {
        /// Plan refused.
        plan_id: u32,
        /// Why.
        reason: FlashRejectReason,
    },
    /// A command could not be carried out.
    CommandRejected(CommandRejectReason),
    /// Answer to [`HostToExec::StatusQuery`].
    Status(ExecStatus),
    /// Something happened in a trial.
    Trial(TrialEvent),
    /// A camera frame was taken.
    Frame(FrameStamp),
    /// Probe telemetry.
    Telemetry(ProbeTelemetry),
    /// Something happened in a goto or home.
    Motion(MotionEvent),
}

impl MaxSize for Hello {
    const MAX_SIZE: usize = u16::MAX_SIZE + u32::MAX_SIZE;
}

impl MaxSize for StagePoint {
    const MAX_SIZE: usize = 2 * i32::MAX_SIZE;
}

impl MaxSize for HostToExec {
    const MAX_SIZE: usize = discriminant_bytes(12)
        + max_of(&[
            Hello::MAX_SIZE,
            FlashHeader::MAX_SIZE,
            FlashChunk::MAX_SIZE,
            u32::MAX_SIZE + StagePoint::MAX_SIZE,
            u64::MAX_SIZE,
            StagePoint::MAX_SIZE,
        ]);
}

impl MaxSize for ExecState {
    const MAX_SIZE: usize = discriminant_bytes(9);
}

impl MaxSize for ExecStatus {
    const MAX_SIZE: usize = u64::MAX_SIZE
        + ExecState::MAX_SIZE
        + <Option<u32>>::MAX_SIZE
        + 2 * u32::MAX_SIZE
        + <Option<TrialFault>>::MAX_SIZE
        + <Option<StagePoint>>::MAX_SIZE
        + <Option<CtrlState>>::MAX_SIZE;
}

impl MaxSize for CommandRejectReason {
    const MAX_SIZE: usize = discriminant_bytes(7)
        + max_of(&[
            ExecState::MAX_SIZE,
            <Option<u32>>::MAX_SIZE,
            <Option<u32>>::MAX_SIZE + SafetyLimit::MAX_SIZE,
            3 * bool::MAX_SIZE,
            2 * StagePoint::MAX_SIZE + u32::MAX_SIZE,
            3 * StagePoint::MAX_SIZE,
        ]);
}

impl MaxSize for TrialFault {
    const MAX_SIZE: usize =
        discriminant_bytes(5) + max_of(&[FaultReport::MAX_SIZE, u64::MAX_SIZE, u32::MAX_SIZE]);
}

impl MaxSize for TrialEventKind {
    const MAX_SIZE: usize = discriminant_bytes(4) + TrialFault::MAX_SIZE;
}

impl MaxSize for TrialEvent {
    const MAX_SIZE: usize = u64::MAX_SIZE + 2 * u32::MAX_SIZE + TrialEventKind::MAX_SIZE;
}

impl MaxSize for FrameStamp {
    const MAX_SIZE: usize = u32::MAX_SIZE + u64::MAX_SIZE + 2 * i32::MAX_SIZE;
}

impl MaxSize for ProbeTelemetry {
    const MAX_SIZE: usize = 2 * u64::MAX_SIZE + 2 * i32::MAX_SIZE + u32::MAX_SIZE + u16::MAX_SIZE;
}

impl MaxSize for MotionEventKind {
    const MAX_SIZE: usize =
        discriminant_bytes(4) + max_of(&[StagePoint::MAX_SIZE, TrialFault::MAX_SIZE]);
}

impl MaxSize for MotionEvent {
    const MAX_SIZE: usize = u64::MAX_SIZE + MotionEventKind::MAX_SIZE;
}

impl MaxSize for ExecToHost {
    const MAX_SIZE: usize = discriminant_bytes(10)
        + max_of(&[
            Hello::MAX_SIZE + bool::MAX_SIZE,
            2 * u32::MAX_SIZE,
            u32::MAX_SIZE + FlashRejectReason::MAX_SIZE,
            CommandRejectReason::MAX_SIZE,
            ExecStatus::MAX_SIZE,
            TrialEvent::MAX_SIZE,
            FrameStamp::MAX_SIZE,
            ProbeTelemetry::MAX_SIZE,
            MotionEvent::MAX_SIZE,
        ]);
}
