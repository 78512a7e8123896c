//! The point-to-point adapter driving a Sutter MPC-200, against replies written by hand from
//! Sutter's documented byte layouts (`C` → drive, x, y, z as i32 LE µsteps, `0D`; a move's
//! `0D` at its end; nothing at all for a move under 16 µsteps). The full loop against the
//! firmware simulator's independent emulator is tested in the rig; these pin each rule of
//! the adapter on exact bytes and times.

use mesopush_executor::adapter::p2p::driver::{P2pSettings, PointToPointAdapter};
use mesopush_executor::adapter::p2p::mpc200::Mpc200;
use mesopush_executor::adapter::{AdapterEvent, ControllerAdapter};
use mesopush_protocol::ExecToCtrl;
use mesopush_protocol::ctrl::{CtrlToExec, FaultCode, MoveSegment};

type Adapter = PointToPointAdapter<Mpc200, 32>;

fn adapter() -> Adapter {
    PointToPointAdapter::new(Mpc200::new(), P2pSettings::DEFAULT)
}

/// The documented `C` reply: drive, x, y, z (i32 LE), `0D`.
fn position_reply(x: i32, y: i32, z: i32) -> Vec<u8> {
    let mut r = vec![1u8];
    for v in [x, y, z] {
        r.extend_from_slice(&v.to_le_bytes());
    }
    r.push(0x0D);
    r
}

/// Everything the adapter writes at `now`.
fn written(a: &mut Adapter, now: u64) -> Vec<Vec<u8>> {
    a.poll(now);
    let mut buf = [0u8; 64];
    std::iter::from_fn(|| a.transmit(now, &mut buf).map(<[u8]>::to_vec)).collect()
}

fn events(a: &mut Adapter) -> Vec<CtrlToExec> {
    std::iter::from_fn(|| a.next_event())
        .map(|e| match e {
            AdapterEvent::Ctrl(m) => m,
            AdapterEvent::LinkDown => panic!("link down"),
        })
        .collect()
}

fn feed(a: &mut Adapter, now: u64, mut bytes: &[u8]) {
    while !bytes.is_empty() {
        let n = a.receive(now, bytes);
        bytes = &bytes[n..];
    }
}

/// At rest at (5000, 5000) µm = 80 000 µsteps, z 1000 µsteps.
fn ready() -> Adapter {
    let mut a = adapter();
    assert_eq!(written(&mut a, 0), vec![b"C".to_vec()]);
    feed(&mut a, 1_000, &position_reply(80_000, 80_000, 1_000));
    assert!(a.is_alive());
    let _ = events(&mut a);
    a
}

fn segment(id: u32, start_us: u64, x_nm: i32, y_nm: i32, speed_nm_s: u32) -> ExecToCtrl {
    ExecToCtrl::Move(MoveSegment {
        segment_id: id,
        start_ctrl_time_us: start_us,
        target_x_nm: x_nm,
        target_y_nm: y_nm,
        speed_nm_s,
    })
}

fn last_done(evs: &[CtrlToExec]) -> Option<u32> {
    evs.iter().rev().find_map(|e| match e {
        CtrlToExec::Status(s) => Some(s.last_done_segment_id),
        _ => None,
    })?
}

fn fault(evs: &[CtrlToExec]) -> Option<FaultCode> {
    evs.iter().find_map(|e| match e {
        CtrlToExec::Fault(f) => Some(f.code),
        _ => None,
    })
}

#[test]
fn an_s_move_is_split_by_the_pause_answers_at_its_end_and_is_checked() {
    let mut a = ready();
    a.command(2_000, &ExecToCtrl::ClockSyncQuery { query_id: 3 });
    assert!(
        events(&mut a).contains(&CtrlToExec::ClockSyncReply { query_id: 3, ctrl_time_us: 2_000 })
    );
    // 100 µm along x at 140 µm/s, due at 50 ms: speed byte 1 (162.5 µm/s, the nearest).
    a.command(3_000, &segment(10, 50_000, 5_100_000, 5_000_000, 140_000));
    assert!(written(&mut a, 49_000).is_empty(), "not before its start");
    assert_eq!(written(&mut a, 50_000), vec![vec![0x53, 0x01]]);
    assert!(written(&mut a, 84_999).is_empty(), "35 ms pause inside the packet");
    let mut xyz = Vec::new();
    for v in [81_600i32, 80_000, 1_000] {
        xyz.extend_from_slice(&v.to_le_bytes());
    }
    assert_eq!(written(&mut a, 85_000), vec![xyz]);
    // No polls during the move; the reported position is the profile's estimate.
    assert!(written(&mut a, 300_000).is_empty());
    let evs = events(&mut a);
    let est = evs.iter().rev().find_map(|e| match e {
        CtrlToExec::Position(p) => Some(p.x_nm),
        _ => None,
    });
    // 215 ms at 162.5 µm/s after the last byte: 34.94 µm along.
    assert_eq!(est, Some(5_000_000 + 34_937));
    // The move's CR, then the check.
    feed(&mut a, 700_000, &[0x0D]);
    assert_eq!(written(&mut a, 700_000), vec![b"C".to_vec()]);
    feed(&mut a, 701_000, &position_reply(81_600, 80_000, 1_000));
    assert_eq!(last_done(&events(&mut a)), Some(10));
}

#[test]
fn a_move_under_16_microsteps_is_not_sent_and_is_done_at_once() {
    let mut a = ready();
    // 0.9 µm = 14.4 µsteps.
    a.command(3_000, &segment(11, 10_000, 5_000_900, 5_000_000, 140_000));
    assert!(written(&mut a, 10_000).is_empty());
    assert_eq!(last_done(&events(&mut a)), Some(11));
    // The next one goes to the absolute target: 2 µm from where the stage is.
    a.command(11_000, &segment(12, 20_000, 5_002_000, 5_000_000, 140_000));
    let w = written(&mut a, 20_000);
    assert_eq!(w, vec![vec![0x53, 0x01]]);
}

#[test]
fn a_move_the_controller_ignored_is_found_at_its_deadline() {
    let mut a = ready();
    a.command(3_000, &segment(12, 10_000, 5_002_000, 5_000_000, 140_000));
    assert_eq!(written(&mut a, 10_000).len(), 1);
    assert_eq!(written(&mut a, 45_000).len(), 1);
    // 2 µm at 162.5 µm/s = 12.3 ms; deadline 45 ms + 150 % + 1 s. No CR ever comes.
    assert!(written(&mut a, 1_000_000).is_empty());
    assert_eq!(written(&mut a, 1_070_000), vec![b"C".to_vec()]);
    feed(&mut a, 1_071_000, &position_reply(80_000, 80_000, 1_000));
    assert_eq!(fault(&events(&mut a)), Some(FaultCode::MoveIgnored));
    // And the device is told to stop.
    assert_eq!(written(&mut a, 1_072_000), vec![vec![0x03]]);
}

#[test]
fn a_move_that_ended_short_is_a_stall() {
    let mut a = ready();
    a.command(3_000, &segment(13, 10_000, 5_100_000, 5_000_000, 140_000));
    let _ = written(&mut a, 10_000);
    let _ = written(&mut a, 45_000);
    feed(&mut a, 700_000, &[0x0D]);
    assert_eq!(written(&mut a, 700_000), vec![b"C".to_vec()]);
    feed(&mut a, 701_000, &position_reply(80_800, 80_000, 1_000)); // 50 µm short
    assert_eq!(fault(&events(&mut a)), Some(FaultCode::Stall));
}

#[test]
fn an_unanswered_position_query_is_a_silent_controller() {
    let mut a = adapter();
    assert_eq!(written(&mut a, 0), vec![b"C".to_vec()]);
    feed(&mut a, 1_000, &position_reply(80_000, 80_000, 1_000));
    let _ = events(&mut a);
    assert_eq!(written(&mut a, 100_000), vec![b"C".to_vec()]); // the idle poll
    let _ = written(&mut a, 300_001); // 200 ms without an answer
    let evs: Vec<_> = std::iter::from_fn(|| a.next_event()).collect();
    assert!(evs.contains(&AdapterEvent::LinkDown), "{evs:?}");
    assert!(!a.is_alive());
    // Clock-sync queries are not answered for a silent controller.
    a.command(300_002, &ExecToCtrl::ClockSyncQuery { query_id: 4 });
    assert_eq!(a.next_event(), None);
}

#[test]
fn stop_interrupts_a_move_at_once() {
    let mut a = ready();
    a.command(3_000, &segment(14, 10_000, 5_100_000, 5_000_000, 140_000));
    let _ = written(&mut a, 10_000);
    let _ = written(&mut a, 45_000);
    a.command(100_000, &ExecToCtrl::Stop);
    assert_eq!(written(&mut a, 100_000), vec![vec![0x03]]);
    feed(&mut a, 101_000, &[0x0D]);
    // Then where it stopped is read again.
    assert_eq!(written(&mut a, 200_000), vec![b"C".to_vec()]);
}

#[test]
fn a_position_reply_with_the_stray_i_after_an_interrupt_is_read() {
    let mut a = adapter();
    let _ = written(&mut a, 0);
    let mut r = vec![b'I'];
    r.extend(position_reply(1_600, 3_200, 0));
    feed(&mut a, 1_000, &r);
    assert_eq!(a.measured_units(), Some([1_600, 3_200, 0]));
}

#[test]
fn the_speed_byte_is_the_nearest_setting_for_the_fastest_axis() {
    let o = [0, 0, 0];
    assert_eq!(Mpc200::speed_byte(o, [1_600, 0, 0], 140_000), 1); // 162.5 nearest to 140
    assert_eq!(Mpc200::speed_byte(o, [1_600, 0, 0], 100_000), 0); // 81.25
    // 45°: the line at 140 µm/s asks 99 µm/s of each axis → 81.25.
    assert_eq!(Mpc200::speed_byte(o, [1_600, 1_600, 0], 140_000), 0);
    assert_eq!(Mpc200::speed_byte(o, [1_600, 0, 0], 5_000_000), 15);
    assert_eq!(Mpc200::speed_byte(o, [1_600, 0, 0], 1), 0);
}

/// Regression: during a move that answers at its end the adapter named a poll time in the
/// past as its next deadline (it never polls then), so the executor's real-time loop spun
/// at FIFO priority and starved the host: "the host went silent" in the three-process flow.
#[test]
fn no_deadline_in_the_past_while_a_move_runs_without_polls() {
    let mut a = ready();
    a.command(3_000, &segment(15, 10_000, 5_100_000, 5_000_000, 140_000));
    let _ = written(&mut a, 10_000);
    let _ = written(&mut a, 45_000);
    for now in [100_000, 200_000, 400_000] {
        let _ = written(&mut a, now);
        let _ = events(&mut a);
        let next = a.next_deadline_us().unwrap();
        assert!(next > now, "at {now} µs the next deadline is {next} µs");
    }
}
