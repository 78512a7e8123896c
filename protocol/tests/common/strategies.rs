//! proptest strategies for every wire type, over the full range of every field.

use mesopush_protocol::ctrl::{
    CtrlState, CtrlStatus, CtrlToExec, ExecToCtrl, FaultCode, FaultReport, MoveSegment,
    PositionReport,
};
use mesopush_protocol::flash::{
    FLASH_CHUNK_MAX_BYTES, FlashChunk, FlashHeader, FlashRejectReason, SafetyLimit,
};
use mesopush_protocol::host::{
    CommandRejectReason, ExecState, ExecStatus, ExecToHost, FrameStamp, Hello, HostToExec,
    MotionEvent, MotionEventKind, ProbeTelemetry, StagePoint, TrialEvent, TrialEventKind,
    TrialFault,
};
use proptest::collection::vec;
use proptest::prelude::*;

pub fn hello() -> impl Strategy<Value = Hello> {
    (any::<u16>(), any::<u32>())
        .prop_map(|(protocol_version, schema_hash)| Hello { protocol_version, schema_hash })
}

pub fn flash_header() -> impl Strategy<Value = FlashHeader> {
    (any::<u16>(), any::<u32>(), any::<u32>(), any::<u32>(), any::<u32>()).prop_map(
        |(format_version, plan_id, step_count, image_len_bytes, image_crc32)| FlashHeader {
            format_version,
            plan_id,
            step_count,
            image_len_bytes,
            image_crc32,
        },
    )
}

pub fn flash_chunk() -> impl Strategy<Value = FlashChunk> {
    (any::<u32>(), any::<u32>(), vec(any::<u8>(), 0..=FLASH_CHUNK_MAX_BYTES)).prop_map(
        |(plan_id, offset_bytes, data)| FlashChunk {
            plan_id,
            offset_bytes,
            data: heapless::Vec::from_slice(&data).expect("length bounded by strategy"),
        },
    )
}

pub fn stage_point() -> impl Strategy<Value = StagePoint> {
    (any::<i32>(), any::<i32>()).prop_map(|(x_nm, y_nm)| StagePoint { x_nm, y_nm })
}

pub fn host_to_exec() -> impl Strategy<Value = HostToExec> {
    prop_oneof![
        hello().prop_map(HostToExec::Hello),
        flash_header().prop_map(HostToExec::FlashBegin),
        flash_chunk().prop_map(HostToExec::FlashChunk),
        any::<u32>().prop_map(|plan_id| HostToExec::FlashCommit { plan_id }),
        (any::<u32>(), stage_point())
            .prop_map(|(plan_id, start)| HostToExec::Arm { plan_id, start }),
        any::<u32>().prop_map(|plan_id| HostToExec::Start { plan_id }),
        Just(HostToExec::Abort),
        Just(HostToExec::StatusQuery),
        any::<u64>().prop_map(|host_time_us| HostToExec::Heartbeat { host_time_us }),
        stage_point().prop_map(|target| HostToExec::Goto { target }),
        Just(HostToExec::Home),
        Just(HostToExec::Stop),
    ]
}

pub fn flash_reject() -> impl Strategy<Value = FlashRejectReason> {
    use FlashRejectReason as R;
    let (a, b) = (any::<u32>(), any::<u32>());
    prop_oneof![
        any::<u16>().prop_map(|got| R::UnsupportedFormatVersion { got }),
        (a, b).prop_map(|(step_count, image_len_bytes)| R::StepCountMismatch {
            step_count,
            image_len_bytes
        }),
        a.prop_map(|image_len_bytes| R::PartialStep { image_len_bytes }),
        (a, b).prop_map(|(image_len_bytes, capacity_bytes)| R::TooLarge {
            image_len_bytes,
            capacity_bytes
        }),
        (a, b).prop_map(|(expected_plan_id, got_plan_id)| R::PlanIdMismatch {
            expected_plan_id,
            got_plan_id
        }),
        (a, b).prop_map(|(expected_offset_bytes, got_offset_bytes)| {
            R::OutOfOrderChunk { expected_offset_bytes, got_offset_bytes }
        }),
        (a, b).prop_map(|(expected_len_bytes, received_len_bytes)| {
            R::LengthMismatch { expected_len_bytes, received_len_bytes }
        }),
        (a, b).prop_map(|(expected_crc32, computed_crc32)| R::CrcMismatch {
            expected_crc32,
            computed_crc32
        }),
        Just(R::NoFlashInProgress),
        (a, safety_limit()).prop_map(|(step_index, limit)| R::Unsafe { step_index, limit }),
        Just(R::NotStored),
    ]
}

pub fn safety_limit() -> impl Strategy<Value = SafetyLimit> {
    prop_oneof![
        Just(SafetyLimit::ZeroSpeed),
        Just(SafetyLimit::ZeroLength),
        Just(SafetyLimit::Speed),
        Just(SafetyLimit::Acceleration),
        Just(SafetyLimit::Workspace),
    ]
}

pub fn exec_state() -> impl Strategy<Value = ExecState> {
    prop_oneof![
        Just(ExecState::Idle),
        Just(ExecState::Flashing),
        Just(ExecState::PlanFlashed),
        Just(ExecState::Armed),
        Just(ExecState::Running),
        Just(ExecState::Done),
        Just(ExecState::Aborted),
        Just(ExecState::Faulted),
        Just(ExecState::Moving),
    ]
}

pub fn fault_code() -> impl Strategy<Value = FaultCode> {
    prop_oneof![
        Just(FaultCode::Stall),
        Just(FaultCode::LimitSwitch),
        Just(FaultCode::Reboot),
        Just(FaultCode::QueueOverflow),
        Just(FaultCode::QueueUnderrun),
        Just(FaultCode::BadSegment),
        Just(FaultCode::SegmentLate),
        Just(FaultCode::ExecutorSilent),
        Just(FaultCode::NeedleOverload),
        any::<u16>().prop_map(FaultCode::Other),
        Just(FaultCode::MoveIgnored),
    ]
}

pub fn fault_report() -> impl Strategy<Value = FaultReport> {
    (any::<u64>(), fault_code(), any::<Option<u32>>(), any::<i32>(), any::<i32>()).prop_map(
        |(ctrl_time_us, code, segment_id, x_nm, y_nm)| FaultReport {
            ctrl_time_us,
            code,
            segment_id,
            x_nm,
            y_nm,
        },
    )
}

pub fn trial_fault() -> impl Strategy<Value = TrialFault> {
    prop_oneof![
        fault_report().prop_map(TrialFault::Controller),
        any::<u64>().prop_map(|t| TrialFault::ControllerSilent { last_heard_exec_time_us: t }),
        any::<u64>().prop_map(|t| TrialFault::HostLinkLost { last_heard_exec_time_us: t }),
        Just(TrialFault::ClockSyncLost),
        any::<u32>().prop_map(|step_index| TrialFault::StreamUnderrun { step_index }),
    ]
}

fn exec_status() -> impl Strategy<Value = ExecStatus> {
    (
        any::<u64>(),
        exec_state(),
        any::<Option<u32>>(),
        any::<u32>(),
        any::<u32>(),
        proptest::option::of(trial_fault()),
        proptest::option::of(stage_point()),
        proptest::option::of(ctrl_state()),
    )
        .prop_map(
            |(exec_time_us, state, plan_id, step_count, step_index, last_fault, probe, ctrl)| {
                ExecStatus {
                    exec_time_us,
                    state,
                    plan_id,
                    step_count,
                    step_index,
                    last_fault,
                    probe,
                    ctrl_state: ctrl,
                }
            },
        )
}

fn trial_event() -> impl Strategy<Value = TrialEvent> {
    let kind = prop_oneof![
        Just(TrialEventKind::Started),
        Just(TrialEventKind::Done),
        Just(TrialEventKind::Aborted),
        trial_fault().prop_map(TrialEventKind::Faulted),
    ];
    (any::<u64>(), any::<u32>(), any::<u32>(), kind).prop_map(
        |(exec_time_us, plan_id, step_index, kind)| TrialEvent {
            exec_time_us,
            plan_id,
            step_index,
            kind,
        },
    )
}

fn command_reject() -> impl Strategy<Value = CommandRejectReason> {
    prop_oneof![
        exec_state().prop_map(|state| CommandRejectReason::WrongState { state }),
        any::<Option<u32>>()
            .prop_map(|stored_plan_id| CommandRejectReason::PlanIdMismatch { stored_plan_id }),
        Just(CommandRejectReason::Incompatible),
        (any::<Option<u32>>(), safety_limit())
            .prop_map(|(step_index, limit)| CommandRejectReason::Unsafe { step_index, limit }),
        (any::<bool>(), any::<bool>(), any::<bool>()).prop_map(
            |(clock_synced, position_known, ctrl_ready)| CommandRejectReason::NotReady {
                clock_synced,
                position_known,
                ctrl_ready
            }
        ),
        (stage_point(), stage_point(), any::<u32>()).prop_map(|(probe, start, tolerance_nm)| {
            CommandRejectReason::StartMismatch { probe, start, tolerance_nm }
        }),
        (stage_point(), stage_point(), stage_point()).prop_map(|(target, min, max)| {
            CommandRejectReason::OutsideWorkspace { target, min, max }
        }),
    ]
}

fn motion_event() -> impl Strategy<Value = MotionEvent> {
    let kind = prop_oneof![
        stage_point().prop_map(|target| MotionEventKind::Started { target }),
        stage_point().prop_map(|at| MotionEventKind::Arrived { at }),
        Just(MotionEventKind::Stopped),
        trial_fault().prop_map(MotionEventKind::Faulted),
    ];
    (any::<u64>(), kind).prop_map(|(exec_time_us, kind)| MotionEvent { exec_time_us, kind })
}

pub fn exec_to_host() -> impl Strategy<Value = ExecToHost> {
    let frame = (any::<u32>(), any::<u64>(), any::<i32>(), any::<i32>()).prop_map(
        |(frame_seq, frame_stamp_us, probe_x_nm, probe_y_nm)| {
            ExecToHost::Frame(FrameStamp { frame_seq, frame_stamp_us, probe_x_nm, probe_y_nm })
        },
    );
    let telemetry =
        (any::<u64>(), any::<u64>(), any::<i32>(), any::<i32>(), any::<u32>(), any::<u16>())
            .prop_map(|(exec_time_us, ctrl_time_us, x, y, step_index, free)| {
                ExecToHost::Telemetry(ProbeTelemetry {
                    exec_time_us,
                    ctrl_time_us,
                    probe_x_nm: x,
                    probe_y_nm: y,
                    step_index,
                    ctrl_queue_free_slots: free,
                })
            });
    prop_oneof![
        (hello(), any::<bool>())
            .prop_map(|(hello, accepted)| ExecToHost::HelloReply { hello, accepted }),
        (any::<u32>(), any::<u32>()).prop_map(|(plan_id, received_bytes)| {
            ExecToHost::FlashProgress { plan_id, received_bytes }
        }),
        (any::<u32>(), any::<u32>())
            .prop_map(|(plan_id, step_count)| ExecToHost::FlashAccepted { plan_id, step_count }),
        (any::<u32>(), flash_reject())
            .prop_map(|(plan_id, reason)| ExecToHost::FlashRejected { plan_id, reason }),
        command_reject().prop_map(ExecToHost::CommandRejected),
        exec_status().prop_map(ExecToHost::Status),
        trial_event().prop_map(ExecToHost::Trial),
        frame,
        telemetry,
        motion_event().prop_map(ExecToHost::Motion),
    ]
}

pub fn exec_to_ctrl() -> impl Strategy<Value = ExecToCtrl> {
    let segment = (any::<u32>(), any::<u64>(), any::<i32>(), any::<i32>(), any::<u32>()).prop_map(
        |(segment_id, start_ctrl_time_us, target_x_nm, target_y_nm, speed_nm_s)| {
            ExecToCtrl::Move(MoveSegment {
                segment_id,
                start_ctrl_time_us,
                target_x_nm,
                target_y_nm,
                speed_nm_s,
            })
        },
    );
    prop_oneof![
        segment,
        Just(ExecToCtrl::Stop),
        any::<u32>().prop_map(|query_id| ExecToCtrl::ClockSyncQuery { query_id }),
        Just(ExecToCtrl::StatusQuery),
        any::<u64>().prop_map(|exec_time_us| ExecToCtrl::Heartbeat { exec_time_us }),
        Just(ExecToCtrl::ClearFault),
    ]
}

fn ctrl_state() -> impl Strategy<Value = CtrlState> {
    prop_oneof![
        Just(CtrlState::Idle),
        Just(CtrlState::Moving),
        Just(CtrlState::Stopped),
        Just(CtrlState::Faulted),
    ]
}

pub fn ctrl_to_exec() -> impl Strategy<Value = CtrlToExec> {
    let position = (any::<u64>(), any::<i32>(), any::<i32>(), any::<Option<u32>>()).prop_map(
        |(ctrl_time_us, x_nm, y_nm, active_segment_id)| {
            CtrlToExec::Position(PositionReport { ctrl_time_us, x_nm, y_nm, active_segment_id })
        },
    );
    let status = (any::<u64>(), ctrl_state(), any::<u16>(), any::<u16>(), any::<Option<u32>>())
        .prop_map(|(ctrl_time_us, state, queue_free_slots, queue_len, last_done_segment_id)| {
            CtrlToExec::Status(CtrlStatus {
                ctrl_time_us,
                state,
                queue_free_slots,
                queue_len,
                last_done_segment_id,
            })
        });
    prop_oneof![
        position,
        status,
        (any::<u32>(), any::<u64>()).prop_map(|(query_id, ctrl_time_us)| {
            CtrlToExec::ClockSyncReply { query_id, ctrl_time_us }
        }),
        any::<u64>().prop_map(|ctrl_time_us| CtrlToExec::Heartbeat { ctrl_time_us }),
        fault_report().prop_map(CtrlToExec::Fault),
    ]
}
