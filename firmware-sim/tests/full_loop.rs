//! Executor core and controller core together in one deterministic loop over simulated,
//! faulty serial lines: every move applied exactly once and in order, faults stop the probe
//! and fault the trial, and the same seed gives the same run.

mod bench;

use bench::{Bench, Entry, PROBE_START_NM};
use mesopush_executor::{ExecutorConfig, LogEvent};
use mesopush_firmware_sim::{CtrlConfig, FaultConfig, NodeEvent};
use mesopush_protocol::ctrl::FaultCode;
use mesopush_protocol::flash::PlanStep;
use mesopush_protocol::host::{ExecState, TrialEventKind, TrialFault};

/// A Table II-like plan scaled down: moves of 30–90 µm at 140 µm/s.
fn plan() -> Vec<PlanStep> {
    let moves = [(0, -60_000), (-90_000, 0), (0, 30_000), (0, -30_000), (60_000, 0), (0, 45_000)];
    moves.iter().map(|&(dx_nm, dy_nm)| PlanStep { dx_nm, dy_nm, speed_nm_s: 140_000 }).collect()
}

/// 315 µm at 140 µm/s: step durations rounded up to the µs sum to 2.250003 s → 226
/// segments at 100 Hz (the last one 3 µs long).
const SEGMENTS: u32 = 226;

fn faulty() -> FaultConfig {
    FaultConfig {
        link_drop: 0.02,
        link_corrupt: 0.02,
        link_duplicate: 0.02,
        link_delay: 0.02,
        frame_drop: 0.05,
        frame_black: 0.02,
        ..FaultConfig::NONE
    }
}

fn check_complete_trial(seed: u64, faults: FaultConfig) -> Bench {
    let mut bench = Bench::new(seed, faults, plan());
    bench.run(10_000_000);
    assert_eq!(
        bench.state(),
        ExecState::Done,
        "seed {seed}: {:?}",
        bench.exec.core().status(bench.now_us)
    );
    assert_eq!(
        bench.trial_events(),
        vec![TrialEventKind::Started, TrialEventKind::Done],
        "seed {seed}"
    );
    let applied = bench.applied();
    let first = applied[0];
    let expected: Vec<u32> = (first..first + SEGMENTS).collect();
    assert_eq!(applied, expected, "seed {seed}: every move exactly once, in order");
    bench.run_for(100_000);
    let (x, y) = bench.node.probe_nm();
    let end = (PROBE_START_NM.0 - 30_000.0, PROBE_START_NM.1 - 15_000.0);
    assert!(
        (f64::from(x) - end.0).abs() < 200.0 && (f64::from(y) - end.1).abs() < 200.0,
        "seed {seed}: probe at {x}, {y}"
    );
    bench
}

#[test]
fn a_plan_runs_to_the_end_on_a_clean_line() {
    let bench = check_complete_trial(1, FaultConfig::NONE);
    assert_eq!(bench.lines.iter().map(|l| l.stats().dropped).sum::<u64>(), 0);
}

#[test]
fn every_move_is_applied_exactly_once_in_order_under_link_faults() {
    for seed in [2, 3, 4, 5] {
        let bench = check_complete_trial(seed, faulty());
        let injected: u64 = bench
            .lines
            .iter()
            .map(|l| {
                let s = l.stats();
                s.dropped + s.corrupted + s.duplicated + s.delayed
            })
            .sum();
        assert!(injected > 50, "seed {seed}: only {injected} line faults injected");
        // Camera drops seen by the executor match the camera's (none at the very end).
        let frames = bench.exec.core().frames();
        assert!(
            frames.dropped <= bench.camera.dropped && frames.dropped + 2 >= bench.camera.dropped,
            "seed {seed}: {} vs {}",
            frames.dropped,
            bench.camera.dropped
        );
        assert_eq!(frames.black, bench.camera.black);
    }
}

#[test]
fn a_controller_stall_stops_the_probe_and_faults_the_trial() {
    let mut bench = Bench::new(7, faulty(), plan());
    bench.run_for(2_000_000); // well into the trial
    assert_eq!(bench.state(), ExecState::Running);
    bench.node.controller_mut().inject_stall();
    let stalled_at = bench.node.probe_nm();
    bench.run(10_000_000);
    assert_eq!(bench.state(), ExecState::Faulted);
    let fault = bench.exec.core().status(bench.now_us).last_fault;
    assert!(
        matches!(fault, Some(TrialFault::Controller(r)) if r.code == FaultCode::Stall),
        "{fault:?}"
    );
    assert_eq!(bench.node.probe_nm(), stalled_at, "the stalled probe never moved again");
    bench.run_for(500_000);
    assert_eq!(bench.node.probe_nm(), stalled_at);
    assert!(bench.applied().len() < SEGMENTS as usize);
}

#[test]
fn a_controller_reboot_mid_trial_faults_it_and_no_move_runs_after() {
    let mut bench = Bench::new(8, faulty(), plan());
    bench.run_for(2_000_000);
    assert_eq!(bench.state(), ExecState::Running);
    let applied_before = bench.applied().len();
    bench.node.reboot(bench.now_us);
    bench.run(10_000_000);
    assert_eq!(bench.state(), ExecState::Faulted);
    let fault = bench.exec.core().status(bench.now_us).last_fault;
    assert!(
        matches!(fault, Some(TrialFault::Controller(r)) if r.code == FaultCode::Reboot),
        "{fault:?}"
    );
    let stopped_at = bench.node.probe_nm();
    bench.run_for(500_000);
    assert_eq!(bench.node.probe_nm(), stopped_at, "the rebooted controller moves nothing");
    assert!(
        bench.applied().len() <= applied_before + 1,
        "moves resent to the new controller were ignored"
    );
}

/// The needle check end to end (issue 19, "Needle safety"): a wall 40 µm left of the start
/// holds the needle's tip while the plan's 90 µm move along −x goes on, so the world reports
/// a deflection of up to 50 µm. With a 30 µm limit the controller faults `NeedleOverload`
/// there, the executor faults the trial with it — in words an operator acts on — and the
/// probe stops just past 30 µm of bend; with a 60 µm limit the same plan runs to its end.
#[test]
fn a_needle_bent_beyond_the_controllers_limit_faults_the_trial_and_stops_the_probe() {
    let wall_x_nm = PROBE_START_NM.0 as i32 - 40_000;
    let run = |limit_nm: i32| {
        let ctrl = CtrlConfig { needle_deflection_limit_nm: Some(limit_nm), ..CtrlConfig::DEFAULT };
        let mut bench = Bench::with_configs(9, faulty(), plan(), ExecutorConfig::DEFAULT, ctrl);
        bench.world.wall_x_nm = Some(wall_x_nm);
        bench.run(10_000_000);
        bench
    };
    let mut bench = run(30_000);
    assert_eq!(bench.state(), ExecState::Faulted);
    let fault = bench.exec.core().status(bench.now_us).last_fault;
    let Some(TrialFault::Controller(r)) = fault else { panic!("{fault:?}") };
    assert_eq!(r.code, FaultCode::NeedleOverload);
    let text = TrialFault::Controller(r).to_string();
    assert!(
        text.contains("the needle bent beyond its limit") && text.contains("rig goto"),
        "{text}"
    );
    let stopped_at = bench.node.probe_nm();
    let bent = wall_x_nm - stopped_at.0;
    assert!((30_000..32_000).contains(&bent), "stopped with the needle bent {bent} nm");
    bench.run_for(500_000);
    let (x, y) = bench.node.probe_nm();
    let moved = (x - stopped_at.0).abs().max((y - stopped_at.1).abs());
    assert!(
        moved <= 100,
        "the probe never moved again (settled {moved} nm, within the encoder's 100 nm)"
    );

    let bench = run(60_000);
    assert_eq!(bench.state(), ExecState::Done, "50 µm of bend is within a 60 µm limit");
}

#[test]
fn injected_stage_faults_come_from_the_seed() {
    let faults = FaultConfig { stall_per_s: 0.5, limit_switch_per_s: 0.5, ..faulty() };
    let mut faulted = 0;
    for seed in 20..26 {
        let mut bench = Bench::new(seed, faults, plan());
        bench.run(10_000_000);
        let injected =
            bench.node.events.iter().any(|(_, e)| {
                matches!(e, NodeEvent::InjectedStall | NodeEvent::InjectedLimitSwitch)
            });
        if injected {
            faulted += 1;
            assert_eq!(bench.state(), ExecState::Faulted, "seed {seed}");
            let fault = bench.exec.core().status(bench.now_us).last_fault;
            let code = match fault {
                Some(TrialFault::Controller(r)) => r.code,
                other => panic!("seed {seed}: {other:?}"),
            };
            assert!(
                matches!(code, FaultCode::Stall | FaultCode::LimitSwitch),
                "seed {seed}: {code:?}"
            );
        } else {
            let status = bench.exec.core().status(bench.now_us);
            assert_eq!(bench.state(), ExecState::Done, "seed {seed}: {status:?}");
        }
    }
    assert!(faulted >= 2, "rates of 1/s over ~2 s of motion should fault most runs");
}

fn run_log(seed: u64) -> String {
    let faults = FaultConfig { stall_per_s: 0.2, reboot_per_s: 0.3, ..faulty() };
    let mut bench = Bench::new(seed, faults, plan());
    bench.run(10_000_000);
    let mut text = format!("{:?}\n", bench.node.events);
    for line in &bench.lines {
        text.push_str(&format!("{:?}\n", line.log));
    }
    text.push_str(&format!("{:?}\n", bench.log));
    text
}

#[test]
fn the_same_seed_gives_an_identical_run() {
    let a = run_log(31);
    assert_eq!(a, run_log(31));
    assert_ne!(a, run_log(32));
    assert!(a.len() > 10_000);
}

#[test]
fn frames_are_stamped_with_the_probe_position() {
    let bench = check_complete_trial(9, FaultConfig::NONE);
    let stamped: Vec<_> = bench
        .log
        .iter()
        .filter_map(|(_, e)| match e {
            Entry::Exec(LogEvent::Frame(f)) => Some(*f),
            _ => None,
        })
        .collect();
    assert!(stamped.len() > 60);
    assert!(stamped.iter().all(|f| f.source == mesopush_executor::camera::StampSource::Driver));
    let interpolated = stamped
        .iter()
        .filter(|f| f.position == mesopush_executor::camera::PositionSource::Interpolated)
        .count();
    assert!(interpolated * 10 >= stamped.len() * 8, "{interpolated} of {}", stamped.len());
    // The stamped position matches the true probe position at exposure: reports are
    // quantised to 0.1 µm and 10 ms apart, the probe moves 1.4 µm in 10 ms.
    let mut worst = 0;
    for f in &stamped {
        let t = f.stamp.frame_stamp_us;
        let i = bench.world.history.partition_point(|(ht, _)| *ht < t);
        let (_, truth) = bench.world.history[i];
        let err = (f.stamp.probe_x_nm - truth.0).abs().max((f.stamp.probe_y_nm - truth.1).abs());
        worst = worst.max(err);
    }
    assert!(worst <= 500, "worst stamp error {worst} nm");
}
