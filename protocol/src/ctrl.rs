//! Executor ↔ motion-controller messages.
//!
//! The executor schedules every move ahead in the controller's clock (`ctrl_time_us`), as
//! Klipper does, so the controller only queues and executes; controller reports carry the
//! controller's clock and the queue's free slots so the executor can run flow control and
//! clock sync. Positions are in nm (`i32`), speeds in nm/s (`u32`), times in µs (`u64`).

use crate::max_size::{MaxSize, discriminant_bytes, max_of};
use serde::{Deserialize, Serialize};

/// One queued straight-line move of the probe.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct MoveSegment {
    /// Executor-chosen id, increasing by one per segment; echoed in reports and faults.
    pub segment_id: u32,
    /// Controller time at which the move starts, µs in the controller's clock.
    pub start_ctrl_time_us: u64,
    /// Absolute target x of the probe, nm.
    pub target_x_nm: i32,
    /// Absolute target y of the probe, nm.
    pub target_y_nm: i32,
    /// Speed along the move, nm/s.
    pub speed_nm_s: u32,
}

/// Executor → controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ExecToCtrl {
    /// Queue a move segment.
    Move(MoveSegment),
    /// Stop now and flush the queue.
    Stop,
    /// Ask for the controller's clock; answered by [`CtrlToExec::ClockSyncReply`]. The executor
    /// keeps its own send time under `query_id`.
    ClockSyncQuery {
        /// Id echoed in the reply.
        query_id: u32,
    },
    /// Ask for a [`CtrlToExec::Status`].
    StatusQuery,
    /// Executor is alive; the controller stops if these cease.
    Heartbeat {
        /// Executor time at sending, µs in the executor's clock.
        exec_time_us: u64,
    },
    /// Acknowledge a fault and return the controller to idle.
    ClearFault,
}

/// Controller motion state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CtrlState {
    /// Queue empty, probe at rest.
    Idle,
    /// Executing queued segments.
    Moving,
    /// Stopped on request; queue flushed.
    Stopped,
    /// Stopped by a fault; needs [`ExecToCtrl::ClearFault`].
    Faulted,
}

/// Probe position at a controller time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct PositionReport {
    /// When the position was sampled, µs in the controller's clock.
    pub ctrl_time_us: u64,
    /// Probe x, nm.
    pub x_nm: i32,
    /// Probe y, nm.
    pub y_nm: i32,
    /// Segment being executed, if any.
    pub active_segment_id: Option<u32>,
}

/// Controller state and queue occupancy, for flow control.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct CtrlStatus {
    /// When the status was taken, µs in the controller's clock.
    pub ctrl_time_us: u64,
    /// Motion state.
    pub state: CtrlState,
    /// Segments that can still be queued.
    pub queue_free_slots: u16,
    /// Segments queued and not yet finished.
    pub queue_len: u16,
    /// Last segment completed, if any.
    pub last_done_segment_id: Option<u32>,
}

/// What went wrong in the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FaultCode {
    /// The stage stalled (following error too large).
    Stall,
    /// A limit switch tripped.
    LimitSwitch,
    /// The controller rebooted; its clock and queue restarted.
    Reboot,
    /// A segment arrived with the queue full.
    QueueOverflow,
    /// The queue ran dry while moving.
    QueueUnderrun,
    /// A segment was invalid (zero or excessive speed, target out of range).
    BadSegment,
    /// A segment's start time had already passed when it was dequeued.
    SegmentLate,
    /// The executor's heartbeats stopped.
    ExecutorSilent,
    /// The needle's measured deflection exceeded the controller's limit (the peg wedged or
    /// the plan pushes too hard).
    NeedleOverload,
    /// A code this schema does not name.
    Other(u16),
    /// A point-to-point controller did not execute a move it was sent (the stage stayed
    /// where it was; a Sutter ignores moves shorter than its resolution without a word).
    MoveIgnored,
}

/// A controller fault; the controller stops and enters [`CtrlState::Faulted`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct FaultReport {
    /// When the fault was detected, µs in the controller's clock.
    pub ctrl_time_us: u64,
    /// What happened.
    pub code: FaultCode,
    /// Segment being executed or rejected, if any.
    pub segment_id: Option<u32>,
    /// Probe x at the fault, nm.
    pub x_nm: i32,
    /// Probe y at the fault, nm.
    pub y_nm: i32,
}

/// Controller → executor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CtrlToExec {
    /// Periodic probe position.
    Position(PositionReport),
    /// State and queue occupancy (periodic and on [`ExecToCtrl::StatusQuery`]).
    Status(CtrlStatus),
    /// Answer to [`ExecToCtrl::ClockSyncQuery`].
    ClockSyncReply {
        /// Id of the query.
        query_id: u32,
        /// Controller time when the query was handled, µs in the controller's clock.
        ctrl_time_us: u64,
    },
    /// Controller is alive.
    Heartbeat {
        /// Controller time at sending, µs in the controller's clock.
        ctrl_time_us: u64,
    },
    /// A fault stopped the controller.
    Fault(FaultReport),
}

impl MaxSize for MoveSegment {
    const MAX_SIZE: usize = u32::MAX_SIZE + u64::MAX_SIZE + 2 * i32::MAX_SIZE + u32::MAX_SIZE;
}

impl MaxSize for ExecToCtrl {
    const MAX_SIZE: usize = discriminant_bytes(6)
        + max_of(&[MoveSegment::MAX_SIZE, 0, u32::MAX_SIZE, 0, u64::MAX_SIZE, 0]);
}

impl MaxSize for CtrlState {
    const MAX_SIZE: usize = discriminant_bytes(4);
}

impl MaxSize for PositionReport {
    const MAX_SIZE: usize = u64::MAX_SIZE + 2 * i32::MAX_SIZE + <Option<u32>>::MAX_SIZE;
}

impl MaxSize for CtrlStatus {
    const MAX_SIZE: usize =
        u64::MAX_SIZE + CtrlState::MAX_SIZE + 2 * u16::MAX_SIZE + <Option<u32>>::MAX_SIZE;
}

impl MaxSize for FaultCode {
    const MAX_SIZE: usize = discriminant_bytes(11) + u16::MAX_SIZE;
}

impl MaxSize for FaultReport {
    const MAX_SIZE: usize =
        u64::MAX_SIZE + FaultCode::MAX_SIZE + <Option<u32>>::MAX_SIZE + 2 * i32::MAX_SIZE;
}

impl MaxSize for CtrlToExec {
    const MAX_SIZE: usize = discriminant_bytes(5)
        + max_of(&[
            PositionReport::MAX_SIZE,
            CtrlStatus::MAX_SIZE,
            u32::MAX_SIZE + u64::MAX_SIZE,
            u64::MAX_SIZE,
            FaultReport::MAX_SIZE,
        ]);
}
