//! Faults stop the trial: a silent controller, a silent host, a lost link, a controller
//! fault report and a starving stream each command `Stop` within a stated bound and record
//! why.

mod common;

use common::{Rig, square_plan};
use mesopush_executor::{ExecutorConfig, Input};
use mesopush_protocol::ctrl::FaultCode;
use mesopush_protocol::host::{ExecState, HostToExec, StagePoint, TrialEventKind, TrialFault};

fn running(config: ExecutorConfig) -> Rig {
    let mut rig = Rig::new(config);
    rig.hello();
    rig.flash_steps(7, &square_plan(12));
    rig.run_for(200_000);
    rig.host(HostToExec::Arm { plan_id: 7, start: common::START });
    rig.host(HostToExec::Start { plan_id: 7 });
    rig.run_for(300_000);
    assert_eq!(rig.exec.state(), ExecState::Running);
    rig
}

fn fault(rig: &Rig) -> TrialFault {
    rig.exec.status(rig.now_us).last_fault.expect("a fault is recorded")
}

#[test]
fn silent_controller_is_stopped_within_the_bound() {
    // The silence bound (30 ms) is shorter than the look-ahead (16 × 10 ms), so the watchdog,
    // not a stream underrun, catches it.
    let config = ExecutorConfig { ctrl_silence_us: 30_000, ..ExecutorConfig::DEFAULT };
    let mut rig = running(config);
    rig.ctrl.silent = true;
    let silent_from = rig.now_us;
    assert!(rig.run_until(1_000_000, |r| r.exec.state() == ExecState::Faulted));
    let stop_at = *rig.stops.last().expect("Stop sent");
    // Last message heard at most one report period before going silent; the stop comes at
    // the first tick after the silence bound (1 ms steps here).
    assert!(
        stop_at <= silent_from + config.ctrl_silence_us + rig.step_us,
        "{stop_at} vs {silent_from}"
    );
    assert!(stop_at > silent_from + config.ctrl_silence_us - 10_000 - rig.step_us);
    let TrialFault::ControllerSilent { last_heard_exec_time_us } = fault(&rig) else {
        panic!("{:?}", fault(&rig))
    };
    assert!(last_heard_exec_time_us <= silent_from);
}

#[test]
fn silent_controller_while_armed_faults_too() {
    let mut rig = Rig::new(ExecutorConfig::DEFAULT);
    rig.hello();
    rig.flash_steps(7, &square_plan(2));
    rig.run_for(200_000);
    rig.host(HostToExec::Arm { plan_id: 7, start: common::START });
    rig.ctrl.silent = true;
    let silent_from = rig.now_us;
    assert!(rig.run_until(1_000_000, |r| r.exec.state() == ExecState::Faulted));
    assert!(*rig.stops.last().unwrap() <= silent_from + 100_000 + rig.step_us);
    assert!(matches!(fault(&rig), TrialFault::ControllerSilent { .. }));
}

#[test]
fn silent_host_stops_the_trial() {
    let config = ExecutorConfig { host_silence_us: 250_000, ..ExecutorConfig::DEFAULT };
    let mut rig = running(config);
    rig.host_heartbeats = false;
    let quiet_from = rig.now_us;
    assert!(rig.run_until(1_000_000, |r| r.exec.state() == ExecState::Faulted));
    let stop_at = *rig.stops.last().expect("Stop sent");
    assert!(stop_at <= quiet_from + 250_000 + rig.step_us);
    assert!(matches!(fault(&rig), TrialFault::HostLinkLost { .. }));
}

#[test]
fn link_down_inputs_stop_the_trial() {
    let mut rig = running(ExecutorConfig::DEFAULT);
    let n = rig.stops.len();
    rig.input(Input::CtrlLinkDown);
    assert_eq!((rig.exec.state(), rig.stops.len()), (ExecState::Faulted, n + 1));
    assert!(matches!(fault(&rig), TrialFault::ControllerSilent { .. }));

    let mut rig = running(ExecutorConfig::DEFAULT);
    rig.input(Input::HostLinkDown);
    assert_eq!(rig.exec.state(), ExecState::Faulted);
    assert!(matches!(fault(&rig), TrialFault::HostLinkLost { .. }));
}

#[test]
fn controller_fault_report_faults_the_trial() {
    let mut rig = running(ExecutorConfig::DEFAULT);
    rig.ctrl.fault_next = Some(FaultCode::Stall);
    rig.step();
    assert_eq!(rig.exec.state(), ExecState::Faulted);
    let TrialFault::Controller(report) = fault(&rig) else { panic!("{:?}", fault(&rig)) };
    assert_eq!(report.code, FaultCode::Stall);
    let faulted = rig.logs.iter().any(|e| {
        matches!(e, mesopush_executor::LogEvent::Trial(t) if matches!(t.kind, TrialEventKind::Faulted(TrialFault::Controller(_))))
    });
    assert!(faulted);
    // Re-arming a controller still faulted sends ClearFault and asks to retry; once the
    // controller reports it cleared, arming works.
    rig.run_for(20_000);
    let reply = rig.host(HostToExec::Arm { plan_id: 7, start: common::START });
    assert!(
        matches!(reply[..], [mesopush_protocol::host::ExecToHost::CommandRejected(_)]),
        "{reply:?}"
    );
    assert!(!rig.ctrl.faulted, "ClearFault sent");
    rig.run_for(20_000);
    // The probe stopped mid-plan: state where it is (the start check is `rig_commands`').
    let p = rig.exec.latest_position().expect("a position");
    let here = StagePoint { x_nm: p.x_nm, y_nm: p.y_nm };
    let reply = rig.host(HostToExec::Arm { plan_id: 7, start: here });
    assert_eq!(rig.exec.state(), ExecState::Armed, "{reply:?}");
}

#[test]
fn controller_without_status_starves_the_stream_into_an_underrun() {
    let mut rig = running(ExecutorConfig::DEFAULT);
    rig.ctrl.mute_status = true; // heartbeats and positions keep coming, free slots do not
    assert!(rig.run_until(1_000_000, |r| r.exec.state() == ExecState::Faulted));
    assert!(matches!(fault(&rig), TrialFault::StreamUnderrun { .. }), "{:?}", fault(&rig));
    assert!(!rig.stops.is_empty());
    assert!(!rig.ctrl.overflowed, "flow control held back instead of overflowing");
}

#[test]
fn controller_reboot_resets_clock_sync() {
    let mut rig = running(ExecutorConfig::DEFAULT);
    rig.ctrl.fault_next = Some(FaultCode::Reboot);
    rig.ctrl.offset_us = -500; // the rebooted controller's clock restarted
    rig.step();
    assert_eq!(rig.exec.state(), ExecState::Faulted);
    // Any estimate now comes from the new clock only (the old offset was 7 s).
    let offset = rig.exec.clock_sync().offset_us().map(|(o, _)| o);
    assert!(offset.is_none_or(|o| (o + 500).abs() <= 1_000), "{offset:?}");
    rig.run_for(200_000);
    let (offset, _) = rig.exec.clock_sync().offset_us().expect("re-synced");
    assert!((offset + 500).abs() <= 1_000, "offset {offset}");
}
