//! A controller that reboots mid-session comes back with a fresh link under a new session id.
//! The executor's link must notice the new session, restart its numbering and resend what
//! the old controller had not acknowledged, without going down: from the reboot on, every
//! message in both directions is delivered exactly once and in order, and the controller's
//! post-reboot fault report arrives once. Run over a clean and a faulty (seeded) line.

mod common;

use common::channel::{Channel, Faults, Rng, flush};
use mesopush_protocol::ctrl::{CtrlToExec, ExecToCtrl, FaultCode, FaultReport};
use mesopush_protocol::{Link, LinkConfig};
use std::collections::VecDeque;

type ExecSide = Link<ExecToCtrl, CtrlToExec, 8>;
type CtrlSide = Link<CtrlToExec, ExecToCtrl, 8>;

const CLEAN: Faults =
    Faults { loss: 0.0, duplicate: 0.0, corrupt: 0.0, base_latency_us: 500, jitter_us: 300 };
const FAULTY: Faults =
    Faults { loss: 0.05, duplicate: 0.05, corrupt: 0.05, base_latency_us: 500, jitter_us: 3_000 };
const STEP_US: u64 = 100;
const HEARTBEAT_PERIOD_US: u64 = 10_000;
const REBOOT_AT_US: u64 = 1_000_000;
const STOP_SENDING_US: u64 = 2_000_000;
const END_US: u64 = 3_000_000;

fn reboot_fault() -> CtrlToExec {
    let report = FaultReport {
        ctrl_time_us: 0,
        code: FaultCode::Reboot,
        segment_id: None,
        x_nm: 0,
        y_nm: 0,
    };
    CtrlToExec::Fault(report)
}

/// Heartbeat send times as received, in delivery order, and reboot faults received.
#[derive(Default)]
struct Run {
    exec_got: Vec<u64>,
    ctrl_got: Vec<u64>,
    reboot_faults: usize,
    peer_restarts: u64,
}

fn drain<Tx, Rx: serde::de::DeserializeOwned>(
    outbox: &mut VecDeque<Tx>,
    link: &mut Link<Tx, Rx, 8>,
) {
    while let Some(msg) = outbox.pop_front() {
        if let Err(msg) = link.send(msg) {
            outbox.push_front(msg);
            break;
        }
    }
}

fn run(seed: u64, line: Faults) -> Run {
    let config = LinkConfig::DEFAULT;
    let mut rng = Rng(seed);
    let (mut exec, mut ctrl) = (ExecSide::new(config, 100), CtrlSide::new(config, 7));
    let (mut to_ctrl, mut to_exec) = (Channel::default(), Channel::default());
    let mut out = Run::default();
    // Application outboxes: a full window hands the message back; it waits here.
    let (mut exec_outbox, mut ctrl_outbox) = (VecDeque::new(), VecDeque::new());
    let mut now_us = 0;
    while now_us < END_US {
        if now_us == REBOOT_AT_US {
            ctrl = CtrlSide::new(config, 8); // power cycle: boot counter 7 → 8
            ctrl_outbox.clear(); // its RAM is gone too
            ctrl_outbox.push_back(reboot_fault());
        }
        if now_us % HEARTBEAT_PERIOD_US == 0 && now_us < STOP_SENDING_US {
            exec_outbox.push_back(ExecToCtrl::Heartbeat { exec_time_us: now_us });
            ctrl_outbox.push_back(CtrlToExec::Heartbeat { ctrl_time_us: now_us });
        }
        drain(&mut exec_outbox, &mut exec);
        drain(&mut ctrl_outbox, &mut ctrl);
        assert_eq!(exec.poll(now_us), Ok(()), "seed {seed}: executor link down at {now_us}");
        assert_eq!(ctrl.poll(now_us), Ok(()), "seed {seed}: controller link down at {now_us}");
        flush(&mut exec, &mut to_ctrl, &mut rng, line, now_us);
        flush(&mut ctrl, &mut to_exec, &mut rng, line, now_us);
        while let Some(mut bytes) = to_ctrl.pop_due(now_us) {
            if let Some(ExecToCtrl::Heartbeat { exec_time_us }) = ctrl.on_bytes(now_us, &mut bytes)
            {
                out.ctrl_got.push(exec_time_us);
            }
        }
        while let Some(mut bytes) = to_exec.pop_due(now_us) {
            match exec.on_bytes(now_us, &mut bytes) {
                Some(CtrlToExec::Heartbeat { ctrl_time_us }) => out.exec_got.push(ctrl_time_us),
                Some(msg) if msg == reboot_fault() => out.reboot_faults += 1,
                _ => {}
            }
        }
        now_us += STEP_US;
    }
    out.peer_restarts = exec.stats().peer_restarts;
    out
}

/// From the reboot on, exactly the heartbeats sent are received, once each, in order.
fn check_after_reboot(seed: u64, name: &str, got: &[u64]) {
    let after: Vec<u64> = got.iter().copied().filter(|&t| t >= REBOOT_AT_US).collect();
    let sent: Vec<u64> =
        (REBOOT_AT_US..STOP_SENDING_US).step_by(HEARTBEAT_PERIOD_US as usize).collect();
    assert_eq!(after, sent, "seed {seed} {name}: not exactly once and in order after reboot");
    let before = got.iter().filter(|&&t| t < REBOOT_AT_US).count();
    assert!(before >= 95, "seed {seed} {name}: only {before} delivered before the reboot");
}

fn check(seed: u64, line: Faults) {
    let run = run(seed, line);
    assert_eq!(run.peer_restarts, 1, "seed {seed}: executor saw the controller restart once");
    assert_eq!(run.reboot_faults, 1, "seed {seed}: reboot fault delivered exactly once");
    check_after_reboot(seed, "exec→ctrl", &run.ctrl_got);
    check_after_reboot(seed, "ctrl→exec", &run.exec_got);
}

#[test]
fn rebooted_controller_is_resynchronised_without_losing_later_messages() {
    for seed in 1..=5 {
        check(seed, CLEAN);
    }
}

#[test]
fn reboot_resynchronises_over_a_lossy_reordering_corrupting_line() {
    for seed in 1..=10 {
        check(seed, FAULTY);
    }
}
