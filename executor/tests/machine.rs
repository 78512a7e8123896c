//! Every state-machine transition of the executor core, valid and refused, against a
//! scripted controller (see `common`).

mod common;

use common::{Rig, square_plan};
use mesopush_executor::{ExecutorConfig, Input, LogEvent};
use mesopush_protocol::ExecToCtrl;
use mesopush_protocol::flash::{FlashRejectReason, PlanStep};
use mesopush_protocol::host::{
    CommandRejectReason, ExecState, ExecToHost, Hello, HostToExec, StagePoint, TrialEventKind,
};

fn wrong(state: ExecState) -> Vec<ExecToHost> {
    vec![ExecToHost::CommandRejected(CommandRejectReason::WrongState { state })]
}

/// Hello, flash `square_plan(n)` as plan 7, wait for clock sync.
fn flashed(n: usize) -> Rig {
    let mut rig = Rig::new(ExecutorConfig::DEFAULT);
    rig.hello();
    let reply = rig.flash_steps(7, &square_plan(n));
    assert_eq!(reply, ExecToHost::FlashAccepted { plan_id: 7, step_count: n as u32 });
    assert_eq!(rig.exec.state(), ExecState::PlanFlashed);
    rig.run_for(200_000);
    rig
}

fn armed(n: usize) -> Rig {
    let mut rig = flashed(n);
    let reply = rig.host(HostToExec::Arm { plan_id: 7, start: common::START });
    assert!(
        matches!(reply[..], [ExecToHost::Status(s)] if s.state == ExecState::Armed),
        "{reply:?}"
    );
    rig
}

fn running(n: usize) -> Rig {
    let mut rig = armed(n);
    rig.host(HostToExec::Start { plan_id: 7 });
    assert_eq!(rig.exec.state(), ExecState::Running);
    rig
}

fn trial_kinds(rig: &Rig) -> Vec<TrialEventKind> {
    rig.logs
        .iter()
        .filter_map(|e| match e {
            LogEvent::Trial(t) => Some(t.kind),
            _ => None,
        })
        .collect()
}

#[test]
fn full_trial_streams_every_segment_in_order_and_ends_done() {
    let mut rig = running(6);
    assert!(rig.run_until(5_000_000, |r| r.exec.state() == ExecState::Done), "never done");
    assert_eq!(trial_kinds(&rig), vec![TrialEventKind::Started, TrialEventKind::Done]);
    // 6 steps of 20 µm at 140 µm/s = 857.1 ms → 86 segments of 10 ms.
    let ids: Vec<u32> = rig.ctrl.received.iter().copied().collect();
    assert_eq!(ids, (1..=86).collect::<Vec<u32>>());
    assert!(!rig.ctrl.overflowed);
    // square_plan(6): +x, +y, −x, −y, +x, +y → ends 20 µm right and 20 µm down of the start.
    assert_eq!(rig.ctrl.pos, (1_020_000, 1_020_000));
    let status = rig.exec.status(rig.now_us);
    assert_eq!((status.step_index, status.step_count), (6, 6));
}

#[test]
fn commands_before_a_compatible_hello_are_refused() {
    let mut rig = Rig::new(ExecutorConfig::DEFAULT);
    let incompatible = vec![ExecToHost::CommandRejected(CommandRejectReason::Incompatible)];
    assert_eq!(rig.host(HostToExec::StatusQuery), incompatible);
    assert_eq!(rig.host(HostToExec::Arm { plan_id: 1, start: common::START }), incompatible);
    let old = Hello { protocol_version: 1, ..Hello::CURRENT };
    let reply = rig.host(HostToExec::Hello(old));
    assert_eq!(reply, vec![ExecToHost::HelloReply { hello: Hello::CURRENT, accepted: false }]);
    assert_eq!(rig.host(HostToExec::Abort), incompatible);
    rig.hello();
    assert!(matches!(rig.host(HostToExec::StatusQuery)[..], [ExecToHost::Status(_)]));
}

#[test]
fn refused_transitions_name_the_state() {
    let mut rig = Rig::new(ExecutorConfig::DEFAULT);
    rig.hello();
    assert_eq!(
        rig.host(HostToExec::Arm { plan_id: 7, start: common::START }),
        wrong(ExecState::Idle)
    );
    assert_eq!(rig.host(HostToExec::Start { plan_id: 7 }), wrong(ExecState::Idle));
    assert_eq!(rig.host(HostToExec::Abort), wrong(ExecState::Idle));

    let mut rig = flashed(2);
    assert_eq!(rig.host(HostToExec::Start { plan_id: 7 }), wrong(ExecState::PlanFlashed));
    let mismatch = CommandRejectReason::PlanIdMismatch { stored_plan_id: Some(7) };
    assert_eq!(
        rig.host(HostToExec::Arm { plan_id: 8, start: common::START }),
        vec![ExecToHost::CommandRejected(mismatch)]
    );

    let mut rig = armed(2);
    assert_eq!(
        rig.host(HostToExec::Arm { plan_id: 7, start: common::START }),
        wrong(ExecState::Armed)
    );
    assert_eq!(
        rig.host(HostToExec::Start { plan_id: 9 }),
        vec![ExecToHost::CommandRejected(mismatch)]
    );
    let header = mesopush_protocol::flash::FlashHeader::for_image(8, &[0; 12]).unwrap();
    assert_eq!(rig.host(HostToExec::FlashBegin(header)), wrong(ExecState::Armed));

    let mut rig = running(2);
    assert_eq!(rig.host(HostToExec::FlashBegin(header)), wrong(ExecState::Running));
    assert_eq!(rig.host(HostToExec::FlashCommit { plan_id: 8 }), wrong(ExecState::Running));
    assert_eq!(
        rig.host(HostToExec::Arm { plan_id: 7, start: common::START }),
        wrong(ExecState::Running)
    );
    assert_eq!(rig.host(HostToExec::Start { plan_id: 7 }), wrong(ExecState::Running));
    assert_eq!(rig.exec.state(), ExecState::Running);
}

#[test]
fn arm_waits_for_clock_sync_and_a_position() {
    let mut rig = Rig::new(ExecutorConfig::DEFAULT);
    rig.hello();
    rig.flash_steps(7, &square_plan(2));
    let reply = rig.host(HostToExec::Arm { plan_id: 7, start: common::START });
    let not_ready = CommandRejectReason::NotReady {
        clock_synced: false,
        position_known: false,
        ctrl_ready: false,
    };
    assert_eq!(reply, vec![ExecToHost::CommandRejected(not_ready)]);
    assert_eq!(rig.exec.state(), ExecState::PlanFlashed);
    rig.run_for(200_000);
    let reply = rig.host(HostToExec::Arm { plan_id: 7, start: common::START });
    assert!(matches!(reply[..], [ExecToHost::Status(s)] if s.state == ExecState::Armed));
}

#[test]
fn abort_stops_the_controller_and_the_plan_can_run_again() {
    let mut rig = running(8);
    rig.run_for(300_000);
    let stops_before = rig.stops.len();
    rig.host(HostToExec::Abort);
    assert_eq!(rig.exec.state(), ExecState::Aborted);
    assert_eq!(rig.stops.len(), stops_before + 1, "Stop sent at once");
    assert_eq!(rig.host(HostToExec::Abort), wrong(ExecState::Aborted));
    rig.run_for(50_000);
    // The probe stopped mid-plan: arming from there is refused until it is back at the start.
    let reply = rig.host(HostToExec::Arm { plan_id: 7, start: common::START });
    let probe = rig.exec.latest_position().map(|p| StagePoint { x_nm: p.x_nm, y_nm: p.y_nm });
    let mismatch = CommandRejectReason::StartMismatch {
        probe: probe.unwrap(),
        start: common::START,
        tolerance_nm: ExecutorConfig::DEFAULT.start_tolerance_nm,
    };
    assert_eq!(reply, vec![ExecToHost::CommandRejected(mismatch)]);
    assert_eq!(rig.exec.state(), ExecState::Aborted);
    rig.host(HostToExec::Goto { target: common::START });
    assert_eq!(rig.exec.state(), ExecState::Moving);
    assert!(rig.run_until(5_000_000, |r| r.exec.state() == ExecState::PlanFlashed));
    rig.run_for(20_000);
    let reply = rig.host(HostToExec::Arm { plan_id: 7, start: common::START });
    assert_eq!(
        rig.exec.state(),
        ExecState::Armed,
        "{reply:?} {:?} {:?}",
        rig.exec.latest_position(),
        rig.logs.iter().filter(|l| matches!(l, LogEvent::Motion(_))).collect::<Vec<_>>()
    );
    rig.host(HostToExec::Start { plan_id: 7 });
    assert!(rig.run_until(5_000_000, |r| r.exec.state() == ExecState::Done));
    let kinds = trial_kinds(&rig);
    use TrialEventKind::*;
    assert_eq!(kinds, vec![Started, Aborted, Started, Done]);
}

#[test]
fn abort_while_armed_and_while_flashing() {
    let mut rig = armed(2);
    rig.host(HostToExec::Abort);
    assert_eq!(rig.exec.state(), ExecState::Aborted);
    let image = common::image(&square_plan(3));
    let header = mesopush_protocol::flash::FlashHeader::for_image(9, &image).unwrap();
    rig.host(HostToExec::FlashBegin(header));
    assert_eq!(rig.exec.state(), ExecState::Flashing);
    rig.host(HostToExec::Abort);
    assert_eq!(rig.exec.state(), ExecState::Aborted, "back to the state before the upload");
    assert_eq!(rig.exec.plan().map(|p| p.plan_id()), Some(7));
}

#[test]
fn done_plan_can_be_replaced_by_a_new_upload() {
    let mut rig = running(1);
    assert!(rig.run_until(1_000_000, |r| r.exec.state() == ExecState::Done));
    let reply = rig.flash_steps(8, &square_plan(2));
    assert_eq!(reply, ExecToHost::FlashAccepted { plan_id: 8, step_count: 2 });
    assert_eq!(rig.exec.state(), ExecState::PlanFlashed);
}

#[test]
fn one_khz_setpoints_stream_a_plan() {
    let config = ExecutorConfig {
        setpoint_rate_hz: 1000,
        lookahead_segments: 12,
        ..ExecutorConfig::DEFAULT
    };
    let mut rig = Rig::new(config);
    rig.step_us = 250;
    rig.ctrl.report_us = 1_000;
    rig.hello();
    rig.flash_steps(3, &square_plan(2));
    rig.run_for(200_000);
    rig.host(HostToExec::Arm { plan_id: 3, start: common::START });
    rig.host(HostToExec::Start { plan_id: 3 });
    assert!(
        rig.run_until(2_000_000, |r| r.exec.state() == ExecState::Done),
        "{:?}",
        rig.exec.status(rig.now_us)
    );
    // 2 × 20 µm at 140 µm/s = 285.72 ms → 286 segments of 1 ms.
    assert_eq!(rig.ctrl.received.len(), 286);
    assert!(!rig.ctrl.overflowed);
}

#[test]
fn flow_control_respects_the_controller_queue() {
    let mut rig = flashed(4);
    rig.ctrl.capacity = 3;
    rig.run_for(20_000);
    rig.host(HostToExec::Arm { plan_id: 7, start: common::START });
    rig.host(HostToExec::Start { plan_id: 7 });
    assert!(rig.run_until(5_000_000, |r| r.exec.state() != ExecState::Running));
    assert_eq!(rig.exec.state(), ExecState::Done, "{:?}", rig.exec.status(rig.now_us));
    assert!(rig.ctrl.max_queue <= 3 && !rig.ctrl.overflowed, "max queue {}", rig.ctrl.max_queue);
}

#[test]
fn zero_length_step_is_refused() {
    let mut rig = flashed(2);
    let steps = [PlanStep { dx_nm: 0, dy_nm: 0, speed_nm_s: 1_000 }];
    let reply = rig.flash_steps(9, &steps);
    let limit = mesopush_protocol::flash::SafetyLimit::ZeroLength;
    assert_eq!(
        reply,
        ExecToHost::FlashRejected {
            plan_id: 9,
            reason: FlashRejectReason::Unsafe { step_index: 0, limit }
        }
    );
    assert_eq!(rig.exec.plan().map(|p| p.plan_id()), Some(7));
}

#[test]
fn frames_before_any_position_are_stamped_unknown() {
    let mut rig = Rig::new(ExecutorConfig::DEFAULT);
    let frame =
        mesopush_executor::CameraFrame { frame_seq: 0, driver_stamp_us: None, black: false };
    rig.input(Input::Frame(frame));
    let stamped = rig.logs.iter().find_map(|e| match e {
        LogEvent::Frame(f) => Some(*f),
        _ => None,
    });
    let stamped = stamped.expect("frame logged");
    assert_eq!(stamped.position, mesopush_executor::camera::PositionSource::Unknown);
    assert_eq!(stamped.stamp.frame_stamp_us, rig.now_us);
    assert!(rig.to_host.iter().any(|(_, m)| matches!(m, ExecToHost::Frame(_))));
    assert!(!rig.to_host.iter().any(|(_, m)| matches!(m, ExecToHost::CommandRejected(_))));
    let _ = ExecToCtrl::Stop;
}
