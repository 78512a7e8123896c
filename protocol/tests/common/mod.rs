//! Shared test material: one sample of every message variant (the golden vectors and the
//! corruption test start from these) and proptest strategies covering every type.
#![allow(dead_code, unreachable_pub)]

pub mod channel;
pub mod strategies;

use mesopush_protocol::ctrl::{
    CtrlState, CtrlStatus, CtrlToExec, ExecToCtrl, FaultCode, FaultReport, MoveSegment,
    PositionReport,
};
use mesopush_protocol::flash::{FlashChunk, FlashHeader, FlashRejectReason, PlanStep, SafetyLimit};
use mesopush_protocol::host::{
    CommandRejectReason, ExecState, ExecStatus, ExecToHost, FrameStamp, Hello, HostToExec,
    MotionEvent, MotionEventKind, ProbeTelemetry, StagePoint, TrialEvent, TrialEventKind,
    TrialFault,
};
use mesopush_protocol::{FRAME_BUF_LEN, Frame, FrameKind, MaxSize, encode_frame};
use serde::Serialize;

/// A controller fault used inside several samples.
pub fn fault_report() -> FaultReport {
    FaultReport {
        ctrl_time_us: 5_000_123,
        code: FaultCode::Stall,
        segment_id: Some(42),
        x_nm: -12_500,
        y_nm: 800_000,
    }
}

fn flash_header() -> FlashHeader {
    FlashHeader {
        format_version: 1,
        plan_id: 7,
        step_count: 2,
        image_len_bytes: 24,
        image_crc32: 0xDEAD_BEEF,
    }
}

fn flash_chunk() -> FlashChunk {
    let step = PlanStep { dx_nm: 25_000, dy_nm: -3_000, speed_nm_s: 50_000 };
    let mut data = heapless::Vec::new();
    data.extend_from_slice(&step.to_image_bytes()).expect("12 bytes fit");
    FlashChunk { plan_id: 7, offset_bytes: 12, data }
}

/// One sample of every `HostToExec` variant, named.
pub fn host_to_exec() -> Vec<(&'static str, HostToExec)> {
    vec![
        ("host.hello", HostToExec::Hello(Hello::CURRENT)),
        ("host.flash_begin", HostToExec::FlashBegin(flash_header())),
        ("host.flash_chunk", HostToExec::FlashChunk(flash_chunk())),
        ("host.flash_commit", HostToExec::FlashCommit { plan_id: 7 }),
        ("host.arm", HostToExec::Arm { plan_id: 7, start: point() }),
        ("host.start", HostToExec::Start { plan_id: 7 }),
        ("host.abort", HostToExec::Abort),
        ("host.status_query", HostToExec::StatusQuery),
        ("host.heartbeat", HostToExec::Heartbeat { host_time_us: 1_700_000_000_000_000 }),
        ("host.goto", HostToExec::Goto { target: StagePoint { x_nm: -1, y_nm: 3_050_000 } }),
        ("host.home", HostToExec::Home),
        ("host.stop", HostToExec::Stop),
    ]
}

/// A stage position used inside several samples.
pub fn point() -> StagePoint {
    StagePoint { x_nm: 2_950_000, y_nm: -49_000_000 }
}

fn trial(kind: TrialEventKind) -> ExecToHost {
    ExecToHost::Trial(TrialEvent { exec_time_us: 9_876_543, plan_id: 7, step_index: 3, kind })
}

fn all_trial_faults() -> Vec<(&'static str, TrialFault)> {
    vec![
        ("controller", TrialFault::Controller(fault_report())),
        ("ctrl_silent", TrialFault::ControllerSilent { last_heard_exec_time_us: 1_000 }),
        ("host_lost", TrialFault::HostLinkLost { last_heard_exec_time_us: 2_000 }),
        ("clock_sync_lost", TrialFault::ClockSyncLost),
        ("stream_underrun", TrialFault::StreamUnderrun { step_index: 11 }),
    ]
}

fn all_flash_rejects() -> Vec<(&'static str, FlashRejectReason)> {
    use FlashRejectReason as R;
    vec![
        ("version", R::UnsupportedFormatVersion { got: 9 }),
        ("step_count", R::StepCountMismatch { step_count: 3, image_len_bytes: 24 }),
        ("partial_step", R::PartialStep { image_len_bytes: 13 }),
        ("too_large", R::TooLarge { image_len_bytes: 1 << 20, capacity_bytes: 65_536 }),
        ("plan_id", R::PlanIdMismatch { expected_plan_id: 7, got_plan_id: 8 }),
        ("out_of_order", R::OutOfOrderChunk { expected_offset_bytes: 12, got_offset_bytes: 24 }),
        ("length", R::LengthMismatch { expected_len_bytes: 24, received_len_bytes: 12 }),
        ("crc", R::CrcMismatch { expected_crc32: 1, computed_crc32: 2 }),
        ("no_flash", R::NoFlashInProgress),
        ("unsafe.zero_speed", R::Unsafe { step_index: 2, limit: SafetyLimit::ZeroSpeed }),
        ("unsafe.zero_length", R::Unsafe { step_index: 2, limit: SafetyLimit::ZeroLength }),
        ("unsafe.speed", R::Unsafe { step_index: 2, limit: SafetyLimit::Speed }),
        ("unsafe.accel", R::Unsafe { step_index: 3, limit: SafetyLimit::Acceleration }),
        ("unsafe.workspace", R::Unsafe { step_index: 3, limit: SafetyLimit::Workspace }),
        ("not_stored", R::NotStored),
    ]
}

/// One `Status` sample per executor state.
fn exec_statuses() -> Vec<(String, ExecToHost)> {
    let mut out = Vec::new();
    let states = [
        ExecState::Idle,
        ExecState::Flashing,
        ExecState::PlanFlashed,
        ExecState::Armed,
        ExecState::Running,
        ExecState::Done,
        ExecState::Aborted,
        ExecState::Faulted,
        ExecState::Moving,
    ];
    let ctrl_states = [CtrlState::Idle, CtrlState::Moving, CtrlState::Stopped, CtrlState::Faulted];
    for (i, state) in states.into_iter().enumerate() {
        let last_fault = (state == ExecState::Faulted).then_some(TrialFault::ClockSyncLost);
        let status = ExecStatus {
            exec_time_us: 123_456_789,
            state,
            plan_id: (i > 0).then_some(7),
            step_count: 40,
            step_index: i as u32,
            last_fault,
            probe: (i > 0).then_some(point()),
            ctrl_state: (i > 0).then_some(ctrl_states[i % 4]),
        };
        out.push((format!("exec.status.{state:?}").to_lowercase(), ExecToHost::Status(status)));
    }
    out
}

/// One sample of every `ExecToHost` variant (and of every nested enum variant), named.
pub fn exec_to_host() -> Vec<(String, ExecToHost)> {
    let mut out: Vec<(String, ExecToHost)> = vec![
        (
            "exec.hello_reply".into(),
            ExecToHost::HelloReply { hello: Hello::CURRENT, accepted: true },
        ),
        (
            "exec.flash_progress".into(),
            ExecToHost::FlashProgress { plan_id: 7, received_bytes: 12 },
        ),
        ("exec.flash_accepted".into(), ExecToHost::FlashAccepted { plan_id: 7, step_count: 2 }),
    ];
    for (name, reason) in all_flash_rejects() {
        out.push((
            format!("exec.flash_rejected.{name}"),
            ExecToHost::FlashRejected { plan_id: 7, reason },
        ));
    }
    let rejects = [
        ("wrong_state", CommandRejectReason::WrongState { state: ExecState::Running }),
        ("plan_id", CommandRejectReason::PlanIdMismatch { stored_plan_id: Some(6) }),
        ("incompatible", CommandRejectReason::Incompatible),
        (
            "unsafe",
            CommandRejectReason::Unsafe { step_index: Some(4), limit: SafetyLimit::Workspace },
        ),
        (
            "unsafe_start",
            CommandRejectReason::Unsafe { step_index: None, limit: SafetyLimit::Workspace },
        ),
        (
            "not_ready",
            CommandRejectReason::NotReady {
                clock_synced: true,
                position_known: false,
                ctrl_ready: true,
            },
        ),
        (
            "start_mismatch",
            CommandRejectReason::StartMismatch {
                probe: StagePoint { x_nm: 3_050_000, y_nm: 3_050_000 },
                start: point(),
                tolerance_nm: 5_000,
            },
        ),
        (
            "outside_workspace",
            CommandRejectReason::OutsideWorkspace {
                target: point(),
                min: StagePoint { x_nm: 0, y_nm: 0 },
                max: StagePoint { x_nm: 10_000_000, y_nm: 10_000_000 },
            },
        ),
    ];
    for (name, reason) in rejects {
        out.push((format!("exec.command_rejected.{name}"), ExecToHost::CommandRejected(reason)));
    }
    out.extend(exec_statuses());
    out.push(("exec.trial.started".into(), trial(TrialEventKind::Started)));
    out.push(("exec.trial.done".into(), trial(TrialEventKind::Done)));
    out.push(("exec.trial.aborted".into(), trial(TrialEventKind::Aborted)));
    for (name, fault) in all_trial_faults() {
        out.push((format!("exec.trial.faulted.{name}"), trial(TrialEventKind::Faulted(fault))));
    }
    let motions = [
        ("started", MotionEventKind::Started { target: point() }),
        ("arrived", MotionEventKind::Arrived { at: point() }),
        ("stopped", MotionEventKind::Stopped),
        ("faulted", MotionEventKind::Faulted(TrialFault::Controller(fault_report()))),
    ];
    for (name, kind) in motions {
        let event = MotionEvent { exec_time_us: 4_200_000, kind };
        out.push((format!("exec.motion.{name}"), ExecToHost::Motion(event)));
    }
    out.push((
        "exec.frame".into(),
        ExecToHost::Frame(FrameStamp {
            frame_seq: 301,
            frame_stamp_us: 10_033_333,
            probe_x_nm: -250_000,
            probe_y_nm: 125_000,
        }),
    ));
    out.push((
        "exec.telemetry".into(),
        ExecToHost::Telemetry(ProbeTelemetry {
            exec_time_us: 10_000_000,
            ctrl_time_us: 4_999_000,
            probe_x_nm: -250_000,
            probe_y_nm: 125_000,
            step_index: 3,
            ctrl_queue_free_slots: 28,
        }),
    ));
    out
}

/// One sample of every `ExecToCtrl` variant, named.
pub fn exec_to_ctrl() -> Vec<(&'static str, ExecToCtrl)> {
    vec![
        (
            "ctrl_cmd.move",
            ExecToCtrl::Move(MoveSegment {
                segment_id: 42,
                start_ctrl_time_us: 5_010_000,
                target_x_nm: -12_500,
                target_y_nm: 800_000,
                speed_nm_s: 100_000,
            }),
        ),
        ("ctrl_cmd.stop", ExecToCtrl::Stop),
        ("ctrl_cmd.clock_sync_query", ExecToCtrl::ClockSyncQuery { query_id: 17 }),
        ("ctrl_cmd.status_query", ExecToCtrl::StatusQuery),
        ("ctrl_cmd.heartbeat", ExecToCtrl::Heartbeat { exec_time_us: 10_000_000 }),
        ("ctrl_cmd.clear_fault", ExecToCtrl::ClearFault),
    ]
}

/// One sample of every `CtrlToExec` variant (every fault code and state too), named.
pub fn ctrl_to_exec() -> Vec<(String, CtrlToExec)> {
    let mut out = vec![(
        "ctrl.position".to_string(),
        CtrlToExec::Position(PositionReport {
            ctrl_time_us: 5_000_000,
            x_nm: -12_000,
            y_nm: 799_000,
            active_segment_id: Some(41),
        }),
    )];
    for state in [CtrlState::Idle, CtrlState::Moving, CtrlState::Stopped, CtrlState::Faulted] {
        let status = CtrlStatus {
            ctrl_time_us: 5_000_500,
            state,
            queue_free_slots: 30,
            queue_len: 2,
            last_done_segment_id: Some(40),
        };
        out.push((format!("ctrl.status.{state:?}").to_lowercase(), CtrlToExec::Status(status)));
    }
    out.push((
        "ctrl.clock_sync_reply".into(),
        CtrlToExec::ClockSyncReply { query_id: 17, ctrl_time_us: 5_000_250 },
    ));
    out.push(("ctrl.heartbeat".into(), CtrlToExec::Heartbeat { ctrl_time_us: 5_001_000 }));
    let codes = [
        FaultCode::Stall,
        FaultCode::LimitSwitch,
        FaultCode::Reboot,
        FaultCode::QueueOverflow,
        FaultCode::QueueUnderrun,
        FaultCode::BadSegment,
        FaultCode::SegmentLate,
        FaultCode::ExecutorSilent,
        FaultCode::NeedleOverload,
        FaultCode::Other(0x1234),
        FaultCode::MoveIgnored,
    ];
    for code in codes {
        let fault = FaultReport { code, ..fault_report() };
        out.push((format!("ctrl.fault.{code:?}").to_lowercase(), CtrlToExec::Fault(fault)));
    }
    out
}

/// Sender session of every sample frame.
pub const SENDER_SESSION: u16 = 0x0102;
/// Receiver session of every sample frame.
pub const RECEIVER_SESSION: Option<u16> = Some(300);

/// A data frame between the sample sessions.
pub fn data<M>(seq: u16, ack: u16, msg: M) -> Frame<M> {
    Frame {
        sender_session: SENDER_SESSION,
        receiver_session: RECEIVER_SESSION,
        ack,
        kind: FrameKind::Data { seq, msg },
    }
}

/// Encodes `msg` as a data frame between the sample sessions.
pub fn data_frame<M: Serialize + MaxSize>(seq: u16, ack: u16, msg: M) -> Vec<u8> {
    let mut buf = [0u8; FRAME_BUF_LEN];
    let bytes = encode_frame(&data(seq, ack, msg), &mut buf).expect("sample fits");
    bytes.to_vec()
}

/// Every sample, encoded as a frame, named: all message variants plus bare ack and nack.
pub fn all_sample_frames() -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for (name, msg) in host_to_exec() {
        out.push((name.to_string(), data_frame(1, 2, msg)));
    }
    for (name, msg) in exec_to_host() {
        out.push((name, data_frame(300, 65_535, msg)));
    }
    for (name, msg) in exec_to_ctrl() {
        out.push((name.to_string(), data_frame(65_535, 0, msg)));
    }
    for (name, msg) in ctrl_to_exec() {
        out.push((name, data_frame(5, 6, msg)));
    }
    let mut buf = [0u8; FRAME_BUF_LEN];
    let fresh =
        Frame::<()> { sender_session: 7, receiver_session: None, ack: 0, kind: FrameKind::Ack };
    let ack = Frame::<()> { ack: 513, ..data(0, 0, ()) };
    let ack = Frame { kind: FrameKind::Ack, ..ack };
    let nack = Frame::<()> { ack: 7, kind: FrameKind::Nack, ..data(0, 0, ()) };
    for (name, frame) in [("link.ack", ack), ("link.nack", nack), ("link.ack_fresh", fresh)] {
        let bytes = encode_frame(&frame, &mut buf).expect("control frame fits");
        out.push((name.to_string(), bytes.to_vec()));
    }
    out
}
