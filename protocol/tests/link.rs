//! The reliable link under a seeded faulty channel (loss, duplication, reordering, bit
//! corruption) and a manual clock: every message is delivered exactly once and in order, in
//! both directions at once. Plus the edge cases: full window, retry bound, nacks.

mod common;

use common::channel::{Channel, Faults, Rng, flush};
use mesopush_protocol::host::{ExecToHost, HostToExec, StagePoint};

const START: StagePoint = StagePoint { x_nm: 1_000, y_nm: 2_000 };
use mesopush_protocol::link::LinkStats;
use mesopush_protocol::{
    FRAME_BUF_LEN, Frame, FrameKind, Link, LinkConfig, LinkDown, decode_frame, encode_frame,
};

const WINDOW: usize = 8;
type HostLink = Link<HostToExec, ExecToHost, WINDOW>;
type ExecLink = Link<ExecToHost, HostToExec, WINDOW>;
const HOST_SESSION: u16 = 11;
const EXEC_SESSION: u16 = 22;

/// A frame from the host link to the exec link.
fn from_host<M>(ack: u16, kind: FrameKind<M>) -> Frame<M> {
    Frame { sender_session: HOST_SESSION, receiver_session: Some(EXEC_SESSION), ack, kind }
}

/// A frame from the exec link to the host link.
fn from_exec<M>(ack: u16, kind: FrameKind<M>) -> Frame<M> {
    Frame { sender_session: EXEC_SESSION, receiver_session: Some(HOST_SESSION), ack, kind }
}

struct Outcome {
    host_received: Vec<u32>,
    exec_received: Vec<u32>,
    end_us: u64,
    host_stats: LinkStats,
    exec_stats: LinkStats,
}

/// Pushes `count` numbered messages each way through the faulty line until both are
/// delivered and acknowledged, or the simulated time limit passes.
fn simulate(seed: u64, faults: Faults, count: u32) -> Outcome {
    let mut rng = Rng(seed | 1);
    let config = LinkConfig::DEFAULT;
    let (mut host, mut exec) =
        (HostLink::new(config, HOST_SESSION), ExecLink::new(config, EXEC_SESSION));
    let (mut to_exec, mut to_host) = (Channel::default(), Channel::default());
    let (mut host_next, mut exec_next) = (0u32, 0u32);
    let (mut host_received, mut exec_received) = (Vec::new(), Vec::new());
    let mut now_us = 0;
    while now_us < 600_000_000 {
        while host_next < count
            && host.send(HostToExec::Heartbeat { host_time_us: u64::from(host_next) }).is_ok()
        {
            host_next += 1;
        }
        while exec_next < count
            && exec
                .send(ExecToHost::FlashProgress { plan_id: 0, received_bytes: exec_next })
                .is_ok()
        {
            exec_next += 1;
        }
        assert_eq!(host.poll(now_us), Ok(()), "seed {seed}: host link down at {now_us} µs");
        assert_eq!(exec.poll(now_us), Ok(()), "seed {seed}: exec link down at {now_us} µs");
        flush(&mut host, &mut to_exec, &mut rng, faults, now_us);
        flush(&mut exec, &mut to_host, &mut rng, faults, now_us);
        while let Some(mut bytes) = to_exec.pop_due(now_us) {
            if let Some(HostToExec::Heartbeat { host_time_us }) = exec.on_bytes(now_us, &mut bytes)
            {
                exec_received.push(host_time_us as u32);
            }
        }
        while let Some(mut bytes) = to_host.pop_due(now_us) {
            if let Some(ExecToHost::FlashProgress { received_bytes, .. }) =
                host.on_bytes(now_us, &mut bytes)
            {
                host_received.push(received_bytes);
            }
        }
        let all_sent = host_next == count && exec_next == count;
        if all_sent && host.is_idle() && exec.is_idle() {
            break;
        }
        now_us += 100;
    }
    let (host_stats, exec_stats) = (host.stats(), exec.stats());
    Outcome { host_received, exec_received, end_us: now_us, host_stats, exec_stats }
}

fn assert_exactly_once_in_order(seed: u64, faults: Faults, count: u32) -> Outcome {
    let outcome = simulate(seed, faults, count);
    let expected: Vec<u32> = (0..count).collect();
    assert!(
        outcome.exec_received == expected && outcome.host_received == expected,
        "seed {seed} {faults:?}: host→exec got {} msgs, exec→host got {} msgs of {count} \
         by {} µs (first mismatch host→exec at {:?})",
        outcome.exec_received.len(),
        outcome.host_received.len(),
        outcome.end_us,
        outcome.exec_received.iter().zip(&expected).position(|(a, b)| a != b),
    );
    outcome
}

const HARSH: Faults =
    Faults { loss: 0.1, duplicate: 0.05, corrupt: 0.05, base_latency_us: 200, jitter_us: 3_000 };

#[test]
fn delivers_exactly_once_in_order_under_loss_duplication_reordering_and_corruption() {
    for seed in 1..=20u64 {
        let outcome = assert_exactly_once_in_order(seed, HARSH, 500);
        let s = outcome.exec_stats;
        // The faults really happened (otherwise this test proves nothing).
        assert!(s.duplicates > 0 && s.out_of_order > 0 && s.corrupt > 0, "seed {seed}: {s:?}");
        assert!(outcome.host_stats.retransmissions > 0, "seed {seed}");
    }
}

#[test]
fn sequence_numbers_wrap_without_loss_or_duplication() {
    let mild = Faults { loss: 0.01, duplicate: 0.01, corrupt: 0.01, ..HARSH };
    assert_exactly_once_in_order(99, mild, 70_000);
}

#[test]
fn full_window_hands_the_message_back() {
    let mut host = HostLink::new(LinkConfig::DEFAULT, HOST_SESSION);
    for plan_id in 0..WINDOW as u32 {
        assert_eq!(host.send(HostToExec::Arm { plan_id, start: START }), Ok(()));
    }
    assert_eq!(host.free_slots(), 0);
    assert_eq!(host.send(HostToExec::Abort), Err(HostToExec::Abort));
}

#[test]
fn silent_peer_takes_the_link_down_after_bounded_transmissions() {
    let config = LinkConfig::DEFAULT;
    let mut host = HostLink::new(config, HOST_SESSION);
    host.send(HostToExec::Abort).expect("window has room");
    let mut sends = 0;
    let mut now_us = 0;
    let down = loop {
        if let Err(down) = host.poll(now_us) {
            break down;
        }
        while host.poll_transmit(now_us).is_some() {
            sends += 1;
        }
        now_us += 1_000;
        assert!(now_us < 10_000_000, "never went down");
    };
    let max = config.max_timeouts;
    assert_eq!(down, LinkDown { seq: 0, timeouts: max, transmissions: max });
    assert_eq!(sends, u32::from(max));
    assert_eq!(
        now_us,
        u64::from(max) * config.retransmit_timeout_us,
        "down after the last timeout"
    );
    assert_eq!(host.send(HostToExec::Abort), Err(HostToExec::Abort), "a down link refuses sends");
    assert!(host.poll_transmit(now_us).is_none());
}

#[test]
fn damaged_frame_is_answered_with_a_nack_for_the_next_expected_seq() {
    let mut exec = ExecLink::new(LinkConfig::DEFAULT, EXEC_SESSION);
    let mut buf = [0u8; FRAME_BUF_LEN];
    let first = from_host(0, FrameKind::Data { seq: 0, msg: HostToExec::StatusQuery });
    let mut bytes = encode_frame(&first, &mut buf).expect("fits").to_vec();
    assert_eq!(exec.on_bytes(0, &mut bytes), Some(HostToExec::StatusQuery));
    let mut garbage = vec![0x03, 0x11, 0x22, 0x00];
    assert_eq!(exec.on_bytes(10, &mut garbage), None);
    assert!(matches!(exec.poll_transmit(10), Some(Frame { kind: FrameKind::Nack, ack: 1, .. })));
    assert!(exec.poll_transmit(10).is_none(), "the nack also carried the ack");
    // A second damaged frame for the same gap does not nack again (timeouts cover it).
    assert_eq!(exec.on_bytes(20, &mut [0x01, 0x00]), None);
    assert!(exec.poll_transmit(20).is_none());
}

#[test]
fn duplicate_data_is_acked_but_not_redelivered() {
    let mut exec = ExecLink::new(LinkConfig::DEFAULT, EXEC_SESSION);
    let frame = from_host(0, FrameKind::Data { seq: 0, msg: HostToExec::Abort });
    assert_eq!(exec.on_frame(0, Ok(frame.clone())), Some(HostToExec::Abort));
    assert!(matches!(exec.poll_transmit(0), Some(Frame { kind: FrameKind::Ack, ack: 1, .. })));
    assert_eq!(exec.on_frame(5, Ok(frame)), None);
    assert!(matches!(exec.poll_transmit(5), Some(Frame { kind: FrameKind::Ack, ack: 1, .. })));
    assert_eq!(exec.stats().duplicates, 1);
}

#[test]
fn nack_resends_the_window_only_after_the_holdoff() {
    let config = LinkConfig::DEFAULT;
    let mut host = HostLink::new(config, HOST_SESSION);
    host.send(HostToExec::Arm { plan_id: 1, start: START }).expect("room");
    host.send(HostToExec::Start { plan_id: 1 }).expect("room");
    assert!(matches!(
        host.poll_transmit(0),
        Some(Frame { kind: FrameKind::Data { seq: 0, .. }, .. })
    ));
    assert!(matches!(
        host.poll_transmit(0),
        Some(Frame { kind: FrameKind::Data { seq: 1, .. }, .. })
    ));
    let nack: Result<Frame<ExecToHost>, _> = Ok(from_exec(0, FrameKind::Nack));
    host.on_frame(config.nack_holdoff_us - 1, nack.clone());
    assert!(host.poll_transmit(config.nack_holdoff_us - 1).is_none(), "within holdoff");
    host.on_frame(config.nack_holdoff_us, nack);
    let t = config.nack_holdoff_us;
    assert!(matches!(
        host.poll_transmit(t),
        Some(Frame { kind: FrameKind::Data { seq: 0, .. }, .. })
    ));
    assert!(matches!(
        host.poll_transmit(t),
        Some(Frame { kind: FrameKind::Data { seq: 1, .. }, .. })
    ));
    // An ack for the first frame releases it and frees a window slot.
    host.on_frame(t + 1, Ok(from_exec::<ExecToHost>(1, FrameKind::Ack)));
    assert_eq!(host.free_slots(), WINDOW - 1);
    // An ack for frames never sent is ignored.
    host.on_frame(t + 2, Ok(from_exec::<ExecToHost>(500, FrameKind::Ack)));
    assert_eq!(host.free_slots(), WINDOW - 1);
}

#[test]
fn frames_decode_with_the_type_they_were_sent_as() {
    // Guards the test harness: an ack frame decodes under either message type.
    let mut buf = [0u8; FRAME_BUF_LEN];
    let ack = from_exec::<ExecToHost>(3, FrameKind::Ack);
    let mut bytes = encode_frame(&ack, &mut buf).expect("fits").to_vec();
    assert_eq!(decode_frame::<HostToExec>(&mut bytes), Ok(from_exec(3, FrameKind::Ack)));
}
