//! Between trials: the start-position check at arm, `Goto`, `Home`, `Stop`, the status's
//! absolute position, and many trials back to back (goto start → run → goto start → run),
//! against the scripted controller (see `common`).

mod common;

use common::{Rig, START, square_plan};
use mesopush_executor::{ExecutorConfig, LogEvent};
use mesopush_protocol::ctrl::{CtrlState, FaultCode};
use mesopush_protocol::host::{
    CommandRejectReason, ExecState, ExecToHost, HostToExec, MotionEventKind, StagePoint,
    TrialEventKind, TrialFault,
};

fn flashed(n: usize) -> Rig {
    let mut rig = Rig::new(ExecutorConfig::DEFAULT);
    rig.hello();
    rig.flash_steps(7, &square_plan(n));
    rig.run_for(200_000);
    rig
}

fn motions(rig: &Rig) -> Vec<MotionEventKind> {
    rig.logs
        .iter()
        .filter_map(|e| match e {
            LogEvent::Motion(m) => Some(m.kind),
            _ => None,
        })
        .collect()
}

fn probe(rig: &Rig) -> StagePoint {
    let p = rig.exec.latest_position().expect("a position report");
    StagePoint { x_nm: p.x_nm, y_nm: p.y_nm }
}

fn at(x_nm: i32, y_nm: i32) -> StagePoint {
    StagePoint { x_nm, y_nm }
}

/// A plan stated to start elsewhere in the workspace is refused, naming both positions and
/// the tolerance; a start within the tolerance arms.
#[test]
fn arm_is_refused_when_the_probe_is_not_at_the_plans_stated_start() {
    let mut rig = flashed(2);
    let far = at(9_000_000, 8_000_000);
    let reply = rig.host(HostToExec::Arm { plan_id: 7, start: far });
    let tolerance_nm = ExecutorConfig::DEFAULT.start_tolerance_nm;
    let want = CommandRejectReason::StartMismatch { probe: START, start: far, tolerance_nm };
    assert_eq!(reply, vec![ExecToHost::CommandRejected(want)]);
    let text = want.to_string();
    assert!(text.contains("(1000.0, 1000.0) µm") && text.contains("(9000.0, 8000.0) µm"));
    assert!(text.contains("5.0 µm") && text.contains("rig goto"), "{text}");
    assert_eq!(rig.exec.state(), ExecState::PlanFlashed);
    // Just outside, then just inside the tolerance.
    let off = |d: i32| at(START.x_nm + d, START.y_nm);
    let reply = rig.host(HostToExec::Arm { plan_id: 7, start: off(5_001) });
    assert!(matches!(
        reply[..],
        [ExecToHost::CommandRejected(CommandRejectReason::StartMismatch { .. })]
    ));
    let reply = rig.host(HostToExec::Arm { plan_id: 7, start: off(5_000) });
    assert!(
        matches!(reply[..], [ExecToHost::Status(s)] if s.state == ExecState::Armed),
        "{reply:?}"
    );
}

/// The case, a plan stated to start at (−49 000, −49 000) µm on the stage: outside the
/// workspace, so refused as such (not with advice to `rig goto` an unreachable start).
#[test]
fn arm_of_a_start_outside_the_workspace_is_refused_as_outside_not_as_mismatch() {
    let mut rig = flashed(2);
    let far = at(-49_000_000, -49_000_000);
    let reply = rig.host(HostToExec::Arm { plan_id: 7, start: far });
    let w = ExecutorConfig::DEFAULT.workspace;
    let (min, max) = (at(w.min_x_nm, w.min_y_nm), at(w.max_x_nm, w.max_y_nm));
    let want = CommandRejectReason::OutsideWorkspace { target: far, min, max };
    assert_eq!(reply, vec![ExecToHost::CommandRejected(want)]);
    let text = want.to_string();
    assert!(text.contains("(-49000.0, -49000.0) µm") && text.contains("outside the workspace"));
    assert_eq!(rig.exec.state(), ExecState::PlanFlashed);
    assert_eq!(probe(&rig), START);
}

/// The tolerance is configuration.
#[test]
fn the_start_tolerance_is_configurable() {
    let config = ExecutorConfig { start_tolerance_nm: 200_000, ..ExecutorConfig::DEFAULT };
    let mut rig = Rig::new(config);
    rig.hello();
    rig.flash_steps(7, &square_plan(2));
    rig.run_for(200_000);
    let start = at(START.x_nm + 150_000, START.y_nm);
    let reply = rig.host(HostToExec::Arm { plan_id: 7, start });
    assert!(
        matches!(reply[..], [ExecToHost::Status(s)] if s.state == ExecState::Armed),
        "{reply:?}"
    );
}

/// A goto is a straight line at the goto speed, ends on the target and reports it.
#[test]
fn goto_moves_the_probe_to_the_target_at_the_goto_speed() {
    let mut rig = flashed(2);
    let target = at(1_300_000, 1_400_000); // 500 µm away: 2.5 s at 200 µm/s
    let t0 = rig.now_us;
    let reply = rig.host(HostToExec::Goto { target });
    assert!(
        matches!(reply[..], [ExecToHost::Motion(m)] if m.kind == MotionEventKind::Started { target })
    );
    assert_eq!(rig.exec.state(), ExecState::Moving);
    // Sample the reported position while moving: it stays on the line start → target.
    let (dx, dy) = (300_000.0f64, 400_000.0f64);
    let mut worst_off_line_nm = 0.0f64;
    let arrived = rig.run_until(5_000_000, |r| {
        let p = probe(r);
        let (px, py) = (f64::from(p.x_nm - START.x_nm), f64::from(p.y_nm - START.y_nm));
        worst_off_line_nm = worst_off_line_nm.max((px * dy - py * dx).abs() / dx.hypot(dy));
        r.exec.state() != ExecState::Moving
    });
    assert!(arrived);
    let elapsed_s = (rig.now_us - t0) as f64 * 1e-6;
    rig.run_for(20_000);
    assert_eq!(rig.exec.state(), ExecState::PlanFlashed);
    assert_eq!(probe(&rig), target);
    assert!(
        matches!(motions(&rig)[..], [MotionEventKind::Started { .. }, MotionEventKind::Arrived { at }] if at == target),
        "{:?}",
        motions(&rig)
    );
    // 2.5 s of motion plus the start lead (50 ms) and the controller's report lag.
    assert!((2.5..2.7).contains(&elapsed_s), "took {elapsed_s} s");
    assert!(worst_off_line_nm < 2.0, "{worst_off_line_nm} nm off the line");
    // Armed from there only with that start.
    let reply = rig.host(HostToExec::Arm { plan_id: 7, start: target });
    assert!(
        matches!(reply[..], [ExecToHost::Status(s)] if s.state == ExecState::Armed),
        "{reply:?}"
    );
}

#[test]
fn goto_outside_the_workspace_is_refused_naming_the_box() {
    let mut rig = flashed(2);
    let target = at(-50_000_000, 3_000_000);
    let reply = rig.host(HostToExec::Goto { target });
    let w = ExecutorConfig::DEFAULT.workspace;
    let want = CommandRejectReason::OutsideWorkspace {
        target,
        min: at(w.min_x_nm, w.min_y_nm),
        max: at(w.max_x_nm, w.max_y_nm),
    };
    assert_eq!(reply, vec![ExecToHost::CommandRejected(want)]);
    assert_eq!(rig.exec.state(), ExecState::PlanFlashed);
    assert!(rig.ctrl.received.is_empty(), "no move sent");
}

#[test]
fn stop_halts_a_goto_at_once_from_any_state() {
    let mut rig = flashed(2);
    rig.host(HostToExec::Goto { target: at(3_000_000, 1_000_000) });
    rig.run_for(500_000);
    let stops = rig.stops.len();
    let reply = rig.host(HostToExec::Stop);
    assert_eq!(rig.stops.len(), stops + 1, "Stop sent to the controller in the same call");
    assert!(matches!(reply[0], ExecToHost::Motion(m) if m.kind == MotionEventKind::Stopped));
    assert!(
        matches!(reply.last(), Some(ExecToHost::Status(s)) if s.state == ExecState::PlanFlashed)
    );
    rig.run_for(20_000); // the next position report
    let stopped_at = probe(&rig);
    rig.run_for(300_000);
    assert_eq!(probe(&rig), stopped_at, "the probe does not move after the stop");
    assert!(stopped_at.x_nm > START.x_nm && stopped_at.x_nm < 3_000_000);
    // From idle (nothing moving) a stop still goes to the controller.
    let reply = rig.host(HostToExec::Stop);
    assert_eq!(rig.stops.len(), stops + 2);
    assert!(matches!(reply[..], [ExecToHost::Status(_)]));
    assert!(rig.ctrl.stopped);
}

#[test]
fn home_goes_to_the_configured_home_position() {
    let config = ExecutorConfig { home_nm: (1_100_000, 1_050_000), ..ExecutorConfig::DEFAULT };
    let mut rig = Rig::new(config);
    rig.hello();
    rig.run_for(200_000);
    let reply = rig.host(HostToExec::Home);
    let target = at(1_100_000, 1_050_000);
    assert!(
        matches!(reply[..], [ExecToHost::Motion(m)] if m.kind == MotionEventKind::Started { target })
    );
    assert!(rig.run_until(2_000_000, |r| r.exec.state() == ExecState::Idle));
    rig.run_for(20_000);
    assert_eq!(probe(&rig), target);
}

#[test]
fn a_controller_fault_during_a_goto_stops_it_and_is_reported() {
    let mut rig = flashed(2);
    rig.host(HostToExec::Goto { target: at(2_000_000, 1_000_000) });
    rig.run_for(300_000);
    rig.ctrl.fault_next = Some(FaultCode::Stall);
    assert!(rig.run_until(100_000, |r| r.exec.state() == ExecState::Faulted));
    let kinds = motions(&rig);
    assert!(
        matches!(kinds[..], [MotionEventKind::Started { .. }, MotionEventKind::Faulted(TrialFault::Controller(r))] if r.code == FaultCode::Stall),
        "{kinds:?}"
    );
    let status = rig.exec.status(rig.now_us);
    assert!(matches!(status.last_fault, Some(TrialFault::Controller(_))));
    assert_eq!(status.ctrl_state, Some(CtrlState::Faulted));
    // The next goto clears the controller's fault (refused NotReady until it has), then runs.
    let reply = rig.host(HostToExec::Goto { target: START });
    assert!(
        matches!(
            reply[..],
            [ExecToHost::CommandRejected(CommandRejectReason::NotReady { ctrl_ready: false, .. })]
        ),
        "{reply:?}"
    );
    rig.run_for(20_000);
    let reply = rig.host(HostToExec::Goto { target: START });
    assert!(matches!(reply[..], [ExecToHost::Motion(_)]), "{reply:?}");
    assert!(rig.run_until(10_000_000, |r| r.exec.state() == ExecState::PlanFlashed));
}

#[test]
fn status_reports_the_absolute_position_and_the_controller_state() {
    let mut rig = flashed(2);
    let reply = rig.host(HostToExec::StatusQuery);
    let [ExecToHost::Status(s)] = reply[..] else { panic!("{reply:?}") };
    assert_eq!(s.probe, Some(START));
    assert_eq!(s.ctrl_state, Some(CtrlState::Idle));
    assert_eq!(s.state, ExecState::PlanFlashed);
    assert_eq!(s.last_fault, None);
}

/// Goto start → run → goto start → run, 100 times: every trial is done, every segment of
/// every trial and goto reaches the controller once and in order, and each trial starts
/// at the plan's start.
#[test]
fn a_hundred_trials_back_to_back_with_goto_start_between() {
    let mut rig = flashed(3); // +x, +y, −x: ends 20 µm above its start, the next must goto
    let mut dones = 0;
    for trial in 0..100 {
        if probe(&rig) != START {
            let reply = rig.host(HostToExec::Arm { plan_id: 7, start: START });
            assert!(
                matches!(
                    reply[..],
                    [ExecToHost::CommandRejected(CommandRejectReason::StartMismatch { .. })]
                ),
                "trial {trial}: {reply:?}"
            );
            rig.host(HostToExec::Goto { target: START });
            assert!(rig.run_until(2_000_000, |r| r.exec.state() != ExecState::Moving));
            rig.run_for(20_000);
            assert_eq!(probe(&rig), START, "trial {trial}: goto ended off the start");
        }
        let reply = rig.host(HostToExec::Arm { plan_id: 7, start: START });
        assert!(
            matches!(reply[..], [ExecToHost::Status(s)] if s.state == ExecState::Armed),
            "trial {trial}: {reply:?}"
        );
        rig.host(HostToExec::Start { plan_id: 7 });
        assert!(rig.run_until(2_000_000, |r| r.exec.state() == ExecState::Done), "trial {trial}");
        rig.run_for(20_000);
        assert_eq!(probe(&rig), at(START.x_nm, START.y_nm + 20_000), "trial {trial}");
        dones += 1;
    }
    assert_eq!(dones, 100);
    let ids = &rig.ctrl.received;
    assert!(ids.windows(2).all(|w| w[1] == w[0] + 1), "segment ids gap-free and in order");
    let trial_ends: Vec<_> = rig
        .logs
        .iter()
        .filter_map(|e| match e {
            LogEvent::Trial(t) if t.kind != TrialEventKind::Started => Some(t.kind),
            _ => None,
        })
        .collect();
    assert_eq!(trial_ends, vec![TrialEventKind::Done; 100]);
    assert!(!rig.ctrl.overflowed);
    assert!(rig.stops.is_empty(), "no stop needed");
}
