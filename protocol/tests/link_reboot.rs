//! A controller that reboots mid-session restarts its link at sequence 0, which the
//! executor's link cannot tell from stale traffic. What the link guarantees, and this test
//! pins: the executor notices within its retry bound (`LinkDown`); messages are never
//! duplicated or reordered, across the reboot included; and once every side that went down
//! has been `reset()` (the documented recovery), traffic flows both ways exactly once, in
//! order. Messages queued across the reboot may be lost (see docs/protocol.md).

mod common;

use common::channel::{Channel, Faults, Rng, flush};
use mesopush_protocol::ctrl::{CtrlToExec, ExecToCtrl};
use mesopush_protocol::{Link, LinkConfig};

type ExecSide = Link<ExecToCtrl, CtrlToExec, 8>;
type CtrlSide = Link<CtrlToExec, ExecToCtrl, 8>;

const LINE: Faults =
    Faults { loss: 0.0, duplicate: 0.0, corrupt: 0.0, base_latency_us: 500, jitter_us: 300 };
const STEP_US: u64 = 100;
const HEARTBEAT_PERIOD_US: u64 = 10_000;
const REBOOT_AT_US: u64 = 1_000_000;
const RESYNCED_BY_US: u64 = 2_000_000;
const STOP_SENDING_US: u64 = 2_800_000;

/// Heartbeat send times as received, in order of delivery.
#[derive(Default)]
struct Run {
    exec_got: Vec<u64>,
    ctrl_got: Vec<u64>,
    exec_down_at_us: Option<u64>,
    ctrl_down_at_us: Option<u64>,
}

fn run(seed: u64) -> Run {
    let config = LinkConfig::DEFAULT;
    let mut rng = Rng(seed);
    let (mut exec, mut ctrl) = (ExecSide::new(config), CtrlSide::new(config));
    let (mut to_ctrl, mut to_exec) = (Channel::default(), Channel::default());
    let mut out = Run::default();
    let mut now_us = 0;
    while now_us < 3_000_000 {
        if now_us == REBOOT_AT_US {
            ctrl = CtrlSide::new(config); // power cycle: all link state lost
        }
        if now_us % HEARTBEAT_PERIOD_US == 0 && now_us < STOP_SENDING_US {
            let _ = exec.send(ExecToCtrl::Heartbeat { exec_time_us: now_us });
            let _ = ctrl.send(CtrlToExec::Heartbeat { ctrl_time_us: now_us });
        }
        if exec.poll(now_us).is_err() {
            out.exec_down_at_us.get_or_insert(now_us);
            exec.reset();
        }
        if ctrl.poll(now_us).is_err() {
            out.ctrl_down_at_us.get_or_insert(now_us);
            ctrl.reset();
        }
        flush(&mut exec, &mut to_ctrl, &mut rng, LINE, now_us);
        flush(&mut ctrl, &mut to_exec, &mut rng, LINE, now_us);
        while let Some(mut bytes) = to_ctrl.pop_due(now_us) {
            if let Some(ExecToCtrl::Heartbeat { exec_time_us }) = ctrl.on_bytes(now_us, &mut bytes)
            {
                out.ctrl_got.push(exec_time_us);
            }
        }
        while let Some(mut bytes) = to_exec.pop_due(now_us) {
            if let Some(CtrlToExec::Heartbeat { ctrl_time_us }) = exec.on_bytes(now_us, &mut bytes)
            {
                out.exec_got.push(ctrl_time_us);
            }
        }
        now_us += STEP_US;
    }
    out
}

fn check_direction(seed: u64, name: &str, got: &[u64]) {
    assert!(got.windows(2).all(|w| w[0] < w[1]), "seed {seed} {name}: duplicate or reordered");
    let after: Vec<u64> = got.iter().copied().filter(|&t| t >= RESYNCED_BY_US).collect();
    let sent: Vec<u64> =
        (RESYNCED_BY_US..STOP_SENDING_US).step_by(HEARTBEAT_PERIOD_US as usize).collect();
    assert_eq!(after, sent, "seed {seed} {name}: not exactly once after resync");
    let before = got.iter().filter(|&&t| t < REBOOT_AT_US).count();
    assert!(before >= 95, "seed {seed} {name}: only {before} delivered before the reboot");
}

#[test]
fn rebooted_peer_is_detected_within_the_retry_bound_and_reset_resynchronises() {
    let config = LinkConfig::DEFAULT;
    let bound_us =
        u64::from(config.max_transmissions) * config.retransmit_timeout_us + HEARTBEAT_PERIOD_US;
    for seed in 1..=10 {
        let run = run(seed);
        let down_us = run.exec_down_at_us.expect("executor link must notice the reboot");
        assert!(
            down_us > REBOOT_AT_US && down_us - REBOOT_AT_US <= bound_us,
            "seed {seed}: executor link down at {down_us} µs, bound {bound_us} µs after reboot"
        );
        if let Some(ctrl_down_us) = run.ctrl_down_at_us {
            assert!(ctrl_down_us > REBOOT_AT_US, "seed {seed}: no down before the reboot");
        }
        check_direction(seed, "exec→ctrl", &run.ctrl_got);
        check_direction(seed, "ctrl→exec", &run.exec_got);
    }
}
