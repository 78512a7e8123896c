//! The controller core on its own: segments executed in order at their times, flow-control
//! status, and every fault code it can raise.

use mesopush_firmware_sim::{Controller, CtrlConfig, CtrlEvent, CtrlOutput};
use mesopush_protocol::ctrl::{CtrlState, CtrlToExec, ExecToCtrl, FaultCode, MoveSegment};

type Ctrl = Controller<32>;

#[derive(Default)]
struct Out {
    msgs: Vec<CtrlToExec>,
    events: Vec<CtrlEvent>,
}

impl Out {
    fn sink(&mut self) -> impl FnMut(CtrlOutput) + '_ {
        |o| match o {
            CtrlOutput::Msg(m) => self.msgs.push(m),
            CtrlOutput::Event(e) => self.events.push(e),
        }
    }
    fn faults(&self) -> Vec<FaultCode> {
        self.msgs
            .iter()
            .filter_map(|m| match m {
                CtrlToExec::Fault(f) => Some(f.code),
                _ => None,
            })
            .collect()
    }
    fn applied(&self) -> Vec<u32> {
        self.events
            .iter()
            .filter_map(|e| match e {
                CtrlEvent::Applied(id) => Some(*id),
                _ => None,
            })
            .collect()
    }
}

const START: (f64, f64) = (1_000_000.0, 1_000_000.0);

/// Segment `k` of a 10 ms-per-segment stream along +x at 140 µm/s from `START`.
fn seg(k: u32, t0: u64) -> MoveSegment {
    MoveSegment {
        segment_id: k,
        start_ctrl_time_us: t0 + u64::from(k - 1) * 10_000,
        target_x_nm: 1_000_000 + k as i32 * 1_400,
        target_y_nm: 1_000_000,
        speed_nm_s: 140_000,
    }
}

fn boot(out: &mut Out) -> Ctrl {
    Ctrl::boot(CtrlConfig::DEFAULT, 0, START, false, &mut out.sink())
}

#[test]
fn segments_run_in_order_and_the_stage_follows() {
    let mut out = Out::default();
    let mut c = boot(&mut out);
    for k in 1..=20 {
        c.handle(0, &ExecToCtrl::Move(seg(k, 50_000)), &mut out.sink());
    }
    assert_eq!(c.state(), CtrlState::Moving);
    for t in (0..=300_000).step_by(1_000) {
        c.tick(t, &mut out.sink());
    }
    assert_eq!(out.applied(), (1..=20).collect::<Vec<_>>());
    assert!(out.faults().is_empty(), "{:?}", out.faults());
    assert_eq!(c.state(), CtrlState::Idle);
    let x = c.stage().pos_nm.0;
    assert!((x - 1_028_000.0).abs() < 100.0, "stage at {x}");
    let last = out.msgs.iter().rev().find_map(|m| match m {
        CtrlToExec::Status(s) => Some(*s),
        _ => None,
    });
    let last = last.expect("status reports");
    assert_eq!(
        (last.last_done_segment_id, last.queue_len, last.queue_free_slots),
        (Some(20), 0, 32)
    );
}

#[test]
fn a_dry_queue_mid_stream_is_an_underrun_and_a_stale_segment_is_late() {
    let mut out = Out::default();
    let mut c = boot(&mut out);
    c.handle(0, &ExecToCtrl::Move(seg(1, 50_000)), &mut out.sink());
    c.tick(80_000, &mut out.sink()); // segment 1 ends at 60 ms; segment 2 was due then
    c.handle(80_000, &ExecToCtrl::Move(seg(2, 50_000)), &mut out.sink());
    c.tick(81_000, &mut out.sink());
    assert_eq!(out.faults(), vec![FaultCode::QueueUnderrun]);
    assert_eq!(c.state(), CtrlState::Faulted);

    let mut out = Out::default();
    let mut c = boot(&mut out);
    c.tick(20_000, &mut out.sink());
    c.handle(20_000, &ExecToCtrl::Move(seg(1, 10_000)), &mut out.sink());
    c.tick(21_000, &mut out.sink());
    assert_eq!(out.faults(), vec![FaultCode::SegmentLate], "nothing ran before it");
}

#[test]
fn overflow_bad_segments_and_faulted_moves() {
    let mut out = Out::default();
    let mut c = boot(&mut out);
    for k in 1..=33 {
        c.handle(0, &ExecToCtrl::Move(seg(k, 1_000_000)), &mut out.sink());
    }
    assert_eq!(out.faults(), vec![FaultCode::QueueOverflow]);
    c.handle(0, &ExecToCtrl::Move(seg(40, 1_000_000)), &mut out.sink());
    assert!(out.events.contains(&CtrlEvent::Ignored(40)));
    c.handle(0, &ExecToCtrl::ClearFault, &mut out.sink());
    assert_eq!(c.state(), CtrlState::Idle);
    assert_eq!(c.queue_len(), 0, "the fault flushed the queue");

    let mut fast = seg(1, 1_000_000);
    fast.speed_nm_s = 3_000_000;
    c.handle(0, &ExecToCtrl::Move(fast), &mut out.sink());
    let mut outside = seg(1, 1_000_000);
    outside.target_x_nm = -5;
    c.handle(0, &ExecToCtrl::ClearFault, &mut out.sink());
    c.handle(0, &ExecToCtrl::Move(outside), &mut out.sink());
    let mut zero = seg(1, 1_000_000);
    zero.speed_nm_s = 0;
    c.handle(0, &ExecToCtrl::ClearFault, &mut out.sink());
    c.handle(0, &ExecToCtrl::Move(zero), &mut out.sink());
    let bad = out.faults().iter().filter(|f| **f == FaultCode::BadSegment).count();
    assert_eq!(bad, 3);
}

#[test]
fn stall_limit_switch_and_executor_silence_fault_the_controller() {
    let mut out = Out::default();
    let mut c = boot(&mut out);
    for k in 1..=30 {
        c.handle(0, &ExecToCtrl::Move(seg(k, 10_000)), &mut out.sink());
    }
    c.tick(50_000, &mut out.sink());
    c.inject_stall();
    for t in (50_000..=300_000).step_by(1_000) {
        c.tick(t, &mut out.sink());
    }
    assert_eq!(out.faults(), vec![FaultCode::Stall]);
    let stuck = c.stage().pos_nm;
    c.tick(400_000, &mut out.sink());
    assert_eq!(c.stage().pos_nm, stuck, "a faulted, stalled stage stays put");

    let mut out = Out::default();
    let mut c = boot(&mut out);
    c.handle(0, &ExecToCtrl::Move(seg(1, 10_000)), &mut out.sink());
    c.inject_limit_switch();
    c.tick(5_000, &mut out.sink());
    assert_eq!(out.faults(), vec![FaultCode::LimitSwitch]);

    let mut out = Out::default();
    let mut c = boot(&mut out);
    let mut long = seg(1, 10_000);
    long.target_x_nm = 1_140_000; // 1 s at 140 µm/s
    c.handle(0, &ExecToCtrl::Move(long), &mut out.sink());
    for t in (0..=400_000).step_by(1_000) {
        c.tick(t, &mut out.sink());
    }
    assert_eq!(out.faults(), vec![FaultCode::ExecutorSilent]);
}

#[test]
fn stop_flushes_and_sync_queries_are_answered_in_controller_time() {
    let mut out = Out::default();
    let mut c = boot(&mut out);
    for k in 1..=10 {
        c.handle(0, &ExecToCtrl::Move(seg(k, 10_000)), &mut out.sink());
    }
    c.tick(30_000, &mut out.sink());
    c.handle(30_000, &ExecToCtrl::Stop, &mut out.sink());
    assert_eq!((c.state(), c.queue_len()), (CtrlState::Stopped, 0));
    c.tick(100_000, &mut out.sink());
    assert!(out.faults().is_empty());
    assert!(out.applied().len() <= 2);
    c.handle(123_456, &ExecToCtrl::ClockSyncQuery { query_id: 9 }, &mut out.sink());
    assert_eq!(
        out.msgs.last(),
        Some(&CtrlToExec::ClockSyncReply { query_id: 9, ctrl_time_us: 123_456 })
    );
    let rebooted = Ctrl::boot(CtrlConfig::DEFAULT, 5, START, true, &mut out.sink());
    assert_eq!(rebooted.state(), CtrlState::Faulted);
    assert_eq!(out.faults().last(), Some(&FaultCode::Reboot));
}

/// The needle check (issue 19, "Needle safety"): the controller faults `NeedleOverload` as
/// soon as the sensed deflection exceeds its limit — not at the limit, not below it — stops
/// the stage there, reports the segment it was running, and faults once per episode.
#[test]
fn the_needle_fault_fires_above_the_limit_and_not_at_or_below_it() {
    const LIMIT_NM: i32 = 50_000;
    let cfg = CtrlConfig { needle_deflection_limit_nm: Some(LIMIT_NM), ..CtrlConfig::DEFAULT };
    cfg.validate().unwrap();
    let mut out = Out::default();
    let mut c = Ctrl::boot(cfg, 0, START, false, &mut out.sink());
    for k in 1..=20 {
        c.handle(0, &ExecToCtrl::Move(seg(k, 10_000)), &mut out.sink());
    }
    c.tick(50_000, &mut out.sink());
    for d in [0, 25_000, 49_999, LIMIT_NM] {
        c.sense_needle(50_000, d, &mut out.sink());
    }
    assert!(out.faults().is_empty(), "at and below the limit: {:?}", out.faults());
    assert_eq!(c.state(), CtrlState::Moving);
    c.sense_needle(51_000, LIMIT_NM + 1, &mut out.sink());
    assert_eq!(out.faults(), vec![FaultCode::NeedleOverload]);
    assert_eq!(c.state(), CtrlState::Faulted);
    let report = out.msgs.iter().find_map(|m| match m {
        CtrlToExec::Fault(f) => Some(*f),
        _ => None,
    });
    let report = report.unwrap();
    assert_eq!((report.ctrl_time_us, report.segment_id), (51_000, Some(5)), "{report:?}");
    let held = c.stage().pos_nm;
    c.tick(300_000, &mut out.sink());
    let drift = (c.stage().pos_nm.0 - held.0).hypot(c.stage().pos_nm.1 - held.1);
    assert!(drift < 1.0, "the faulted stage stays put: moved {drift} nm");
    assert_eq!(c.queue_len(), 0, "the queue was flushed");

    // Cleared while still bent: backing off does not fault again until the needle has
    // relaxed to half the limit; then a new episode faults again.
    c.handle(300_000, &ExecToCtrl::ClearFault, &mut out.sink());
    for d in [80_000, 60_000, 30_000] {
        c.sense_needle(301_000, d, &mut out.sink());
    }
    assert_eq!(out.faults().len(), 1, "one fault per episode");
    c.sense_needle(302_000, LIMIT_NM / 2, &mut out.sink());
    c.sense_needle(303_000, LIMIT_NM + 1, &mut out.sink());
    assert_eq!(out.faults(), vec![FaultCode::NeedleOverload; 2]);
}

#[test]
fn without_a_needle_limit_no_deflection_faults_and_a_limit_of_zero_is_refused() {
    let mut out = Out::default();
    let mut c = boot(&mut out);
    c.sense_needle(1_000, i32::MAX, &mut out.sink());
    assert!(out.faults().is_empty());
    for bad in [0, -1] {
        let cfg = CtrlConfig { needle_deflection_limit_nm: Some(bad), ..CtrlConfig::DEFAULT };
        let e = cfg.validate().unwrap_err().to_string();
        assert!(e.contains("needle_deflection_limit_nm"), "{e}");
    }
}
