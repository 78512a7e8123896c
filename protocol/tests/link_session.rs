//! Session ids, frame by frame: stale frames addressed to an earlier life are dropped and
//! answered with the current session, a peer restart renumbers and resends the window,
//! delayed frames from the peer's previous life are ignored, `reset` announces itself, and a
//! peer that only nacks still times out.

use mesopush_protocol::host::{ExecToHost, HostToExec, StagePoint};

const START: StagePoint = StagePoint { x_nm: 1_000, y_nm: 2_000 };
use mesopush_protocol::{Frame, FrameKind, Link, LinkConfig};

type HostLink = Link<HostToExec, ExecToHost, 8>;

const HOST: u16 = 10;

fn from_exec(
    session: u16,
    to: Option<u16>,
    ack: u16,
    kind: FrameKind<ExecToHost>,
) -> Frame<ExecToHost> {
    Frame { sender_session: session, receiver_session: to, ack, kind }
}

fn data(seq: u16, plan_id: u32) -> FrameKind<ExecToHost> {
    FrameKind::Data { seq, msg: ExecToHost::FlashAccepted { plan_id, step_count: 1 } }
}

/// A transmitted frame: sender session, receiver session, ack, data (seq, plan id) if any.
type Sent = (u16, Option<u16>, u16, Option<(u16, u32)>);

fn next(host: &mut HostLink, now_us: u64) -> Option<Sent> {
    host.poll_transmit(now_us).map(|f| {
        let data = match f.kind {
            FrameKind::Data { seq, msg: HostToExec::Arm { plan_id, .. } } => Some((seq, *plan_id)),
            _ => None,
        };
        (f.sender_session, f.receiver_session, f.ack, data)
    })
}

#[test]
fn frame_addressed_to_an_earlier_life_is_dropped_and_answered_with_the_current_session() {
    let mut host = HostLink::new(LinkConfig::DEFAULT, HOST);
    let stale = from_exec(1, Some(HOST - 1), 0, data(0, 5));
    assert_eq!(host.on_frame(0, Ok(stale)), None, "stale data must not be delivered");
    assert_eq!(host.stats().stale, 1);
    assert_eq!(next(&mut host, 0), Some((HOST, None, 0, None)), "a nack naming our session");
    let fresh = from_exec(1, Some(HOST), 0, data(0, 6));
    assert!(host.on_frame(1, Ok(fresh)).is_some(), "correctly addressed data is delivered");
}

#[test]
fn peer_restart_renumbers_and_resends_the_unacknowledged_window() {
    let mut host = HostLink::new(LinkConfig::DEFAULT, HOST);
    for plan_id in 0..3 {
        host.send(HostToExec::Arm { plan_id, start: START }).expect("room");
    }
    for _ in 0..3 {
        assert!(next(&mut host, 0).is_some());
    }
    // The old peer (session 1) acknowledges the first message only.
    assert!(host.on_frame(1_000, Ok(from_exec(1, Some(HOST), 1, data(0, 50)))).is_some());
    // The peer reboots (session 2) and nacks from 0.
    assert_eq!(host.on_frame(2_000, Ok(from_exec(2, None, 0, FrameKind::Nack))), None);
    assert_eq!(host.stats().peer_restarts, 1);
    assert_eq!(next(&mut host, 2_000), Some((HOST, Some(2), 0, Some((0, 1)))));
    assert_eq!(next(&mut host, 2_000), Some((HOST, Some(2), 0, Some((1, 2)))));
    // The new peer's first message is delivered as its sequence 0.
    assert!(host.on_frame(3_000, Ok(from_exec(2, Some(HOST), 2, data(0, 60)))).is_some());
    assert!(host.is_idle(), "the renumbered messages were acknowledged");
}

#[test]
fn delayed_frames_from_the_peers_previous_life_are_ignored() {
    let mut host = HostLink::new(LinkConfig::DEFAULT, HOST);
    assert!(host.on_frame(0, Ok(from_exec(1, None, 0, data(0, 1)))).is_some());
    assert!(host.on_frame(10, Ok(from_exec(2, None, 0, data(0, 2)))).is_some(), "new life");
    let late = from_exec(1, Some(HOST), 0, data(1, 3));
    assert_eq!(host.on_frame(20, Ok(late)), None);
    assert_eq!(host.stats().peer_restarts, 1, "no flip-flop back to the old session");
    assert!(host.on_frame(30, Ok(from_exec(2, Some(HOST), 0, data(1, 4)))).is_some());
}

#[test]
fn reset_drops_the_window_and_announces_the_new_session() {
    let mut host = HostLink::new(LinkConfig::DEFAULT, HOST);
    assert!(host.on_frame(0, Ok(from_exec(1, None, 0, data(0, 1)))).is_some());
    host.send(HostToExec::Abort).expect("room");
    host.reset(HOST + 1);
    assert!(host.is_idle());
    assert_eq!(host.session(), HOST + 1);
    assert_eq!(next(&mut host, 5), Some((HOST + 1, Some(1), 0, None)), "announcing ack");
    // The peer still addressing the old session is told again.
    assert_eq!(host.on_frame(6, Ok(from_exec(1, Some(HOST), 1, data(1, 2)))), None);
    assert_eq!(next(&mut host, 6), Some((HOST + 1, Some(1), 0, None)));
}

#[test]
fn a_peer_that_only_nacks_still_times_out() {
    let config = LinkConfig::DEFAULT;
    let mut host = HostLink::new(config, HOST);
    host.send(HostToExec::Abort).expect("room");
    let mut now_us = 0;
    let down = loop {
        if let Err(down) = host.poll(now_us) {
            break down;
        }
        while host.poll_transmit(now_us).is_some() {}
        if now_us % config.nack_holdoff_us == 0 {
            host.on_frame(now_us, Ok(from_exec(1, Some(HOST), 0, FrameKind::Nack)));
        }
        now_us += 1_000;
        assert!(now_us < 10_000_000, "never went down");
    };
    assert_eq!(now_us, u64::from(config.max_timeouts) * config.retransmit_timeout_us);
    assert_eq!(down.timeouts, config.max_timeouts);
    assert!(down.transmissions > config.max_timeouts, "nacks caused extra resends: {down:?}");
    assert_eq!(host.down(), Some(down));
}
