//! The point-to-point adapter driving a Scientifica (LinLab command set), against reply lines
//! written by hand from the documented forms (`VER` → `2.xx`/`3.xx`, `UUX` → `-6.4`,
//! `POS`/`P` → `x\ty\tz`, `A` accepted, `E,<n>` error, `S` → `0` at rest), each ending `\r`.

mod p2p_common;

use mesopush_executor::adapter::AdapterEvent;
use mesopush_executor::adapter::ControllerAdapter;
use mesopush_executor::adapter::p2p::scientifica::Scientifica;
use mesopush_protocol::ExecToCtrl;
use mesopush_protocol::ctrl::FaultCode;
use p2p_common::{Adapter, adapter, events, fault, feed, last_done, raw_events, segment, written};

fn line(s: &str) -> Vec<u8> {
    s.as_bytes().to_vec()
}

/// A v2 card (PatchStar UU −6.4) at rest at (5000, 5000) µm = 50 000 ticks, z 1000.
fn ready_v2() -> Adapter<Scientifica> {
    let mut a = adapter(Scientifica::new());
    assert_eq!(written(&mut a, 0), vec![line("VER\r")]);
    feed(&mut a, 1_000, b"2.21\r");
    assert_eq!(written(&mut a, 1_000), vec![line("UUX\r")]);
    feed(&mut a, 2_000, b"-6.4\r");
    assert_eq!(written(&mut a, 2_000), vec![line("POS\r")]);
    feed(&mut a, 3_000, b"50000\t50000\t1000\r");
    assert_eq!(a.measured_units(), Some([50_000, 50_000, 1_000]));
    assert_eq!(a.protocol().card(), Some(2));
    let _ = events(&mut a);
    a
}

/// Sends 100 µm along x at 140 µm/s due at 50 ms: `TOP` = 140 × 2 × 6.4 = 1792, then 25 ms
/// later the `ABS`; both answered `A`. The move began at 75 ms.
fn move_100_um(a: &mut Adapter<Scientifica>, id: u32) {
    a.command(4_000, &segment(id, 50_000, 5_100_000, 5_000_000, 140_000));
    assert_eq!(written(a, 50_000), vec![line("TOP 1792\r")]);
    feed(a, 52_000, b"A\r");
    assert_eq!(written(a, 75_000), vec![line("ABS 51000 50000 1000\r")]);
    feed(a, 76_000, b"A\r");
}

/// Answers every poll from `from_us` on, every 30 ms, until `until_us`: `S` with `busy`,
/// the position with `pos`. Returns the events.
fn answer_polls(
    a: &mut Adapter<Scientifica>,
    from_us: u64,
    until_us: u64,
    busy: &str,
    pos: &str,
) -> Vec<mesopush_protocol::ctrl::CtrlToExec> {
    let mut evs = Vec::new();
    for t in (from_us..until_us).step_by(30_000) {
        for w in written(a, t) {
            match w.as_slice() {
                b"S\r" => feed(a, t + 1_000, busy.as_bytes()),
                b"POS\r" => feed(a, t + 1_000, pos.as_bytes()),
                b"STOP\r" => feed(a, t + 1_000, b"A\r"),
                other => panic!("unexpected {:?}", String::from_utf8_lossy(other)),
            }
        }
        evs.extend(events(a));
    }
    evs
}

#[test]
fn a_move_answers_at_once_is_polled_and_checked() {
    let mut a = ready_v2();
    move_100_um(&mut a, 10);
    // Polls every 30 ms from 105 ms: `S`, then the position, alternately.
    assert!(written(&mut a, 104_000).is_empty());
    assert_eq!(written(&mut a, 105_000), vec![line("S\r")]);
    feed(&mut a, 106_000, b"1\r");
    assert_eq!(written(&mut a, 135_000), vec![line("POS\r")]);
    feed(&mut a, 136_000, b"50850\t50000\t1000\r");
    // Arrived: `S` → 0, then the position read at the target.
    let evs = answer_polls(&mut a, 165_000, 1_000_000, "0\r", "51000\t50000\t1000\r");
    assert_eq!(last_done(&evs), Some(10));
    assert_eq!(fault(&evs), None);
    // The same speed again: no `TOP`.
    a.command(1_000_000, &segment(11, 1_000_000, 5_000_000, 5_000_000, 140_000));
    assert_eq!(written(&mut a, 1_000_000), vec![line("ABS 50000 50000 1000\r")]);
    feed(&mut a, 1_001_000, b"A\r");
}

#[test]
fn reported_finished_before_stopped_keeps_polling_and_is_never_a_stall() {
    let mut a = ready_v2();
    move_100_um(&mut a, 12);
    // `S` says 0 while the stage is still 1 µm short (more than the 0.5 µm tolerance).
    let evs = answer_polls(&mut a, 105_000, 400_000, "0\r", "50990\t50000\t1000\r");
    assert_eq!(last_done(&evs), None, "not done while short");
    assert_eq!(fault(&evs), None, "and not a stall before the deadline");
    // Then it settles at the target.
    let evs = answer_polls(&mut a, 405_000, 600_000, "0\r", "51000\t50000\t1000\r");
    assert_eq!(last_done(&evs), Some(12));
    assert_eq!(fault(&evs), None);
}

#[test]
fn a_move_that_stays_short_past_its_deadline_is_a_stall() {
    let mut a = ready_v2();
    move_100_um(&mut a, 13);
    // Deadline: 75 ms + 150 % of 714 ms + 1 s = 2.146 s; the first check after it (a `0`
    // then a position read, polls 30 ms apart) finds the stage 50 µm short.
    let evs = answer_polls(&mut a, 105_000, 2_146_000, "0\r", "50500\t50000\t1000\r");
    assert_eq!(fault(&evs), None, "polled on until the deadline");
    let evs = answer_polls(&mut a, 2_175_000, 2_300_000, "0\r", "50500\t50000\t1000\r");
    assert_eq!(fault(&evs), Some(FaultCode::Stall));
}

#[test]
fn an_error_line_refuses_the_move() {
    let mut a = ready_v2();
    a.command(4_000, &segment(14, 50_000, 5_100_000, 5_000_000, 140_000));
    let _ = written(&mut a, 50_000);
    feed(&mut a, 52_000, b"A\r");
    let _ = written(&mut a, 75_000);
    feed(&mut a, 76_000, b"E,2\r");
    assert_eq!(fault(&events(&mut a)), Some(FaultCode::BadSegment));
    assert_eq!(written(&mut a, 77_000), vec![line("STOP\r")]);
}

#[test]
fn an_unanswered_busy_poll_is_a_silent_controller() {
    let mut a = ready_v2();
    move_100_um(&mut a, 15);
    assert_eq!(written(&mut a, 105_000), vec![line("S\r")]);
    let _ = written(&mut a, 305_001);
    assert!(raw_events(&mut a).contains(&AdapterEvent::LinkDown));
    assert!(!a.is_alive());
}

#[test]
fn stop_is_sent_between_polls_and_the_position_read_again() {
    let mut a = ready_v2();
    move_100_um(&mut a, 16);
    a.command(90_000, &ExecToCtrl::Stop);
    assert_eq!(written(&mut a, 90_000), vec![line("STOP\r")]);
    feed(&mut a, 91_000, b"A\r");
    assert_eq!(written(&mut a, 105_000), vec![line("POS\r")]);
    feed(&mut a, 106_000, b"50100\t50000\t1000\r");
    assert_eq!(a.measured_units(), Some([50_100, 50_000, 1_000]));
}

#[test]
fn a_v3_card_is_read_in_hundredths_and_set_in_um_s() {
    let mut a = adapter(Scientifica::new());
    assert_eq!(written(&mut a, 0), vec![line("VER\r")]);
    feed(&mut a, 1_000, b"3.12\r");
    assert_eq!(written(&mut a, 1_000), vec![line("P\r")], "no UUX on v3");
    feed(&mut a, 2_000, b"500000\t-250000\t10000\r");
    assert_eq!(a.measured_units(), Some([500_000, -250_000, 10_000]));
    a.command(3_000, &segment(20, 10_000, 5_100_000, -2_500_000, 140_000));
    assert_eq!(written(&mut a, 10_000), vec![line("TOP 140\r")]);
    feed(&mut a, 11_000, b"A\r");
    assert_eq!(written(&mut a, 35_000), vec![line("ABS 510000 -250000 10000\r")]);
}

#[test]
fn an_unknown_card_is_never_moved() {
    let mut a = adapter(Scientifica::new());
    assert_eq!(written(&mut a, 0), vec![line("VER\r")]);
    feed(&mut a, 1_000, b"4.01\r");
    a.command(2_000, &segment(21, 10_000, 100_000, 0, 140_000));
    assert!(written(&mut a, 10_000).is_empty(), "no position, no move");
    assert_eq!(written(&mut a, 101_000), vec![line("VER\r")], "asked again");
    feed(&mut a, 102_000, b"4.01\r");
    for t in (110_000..1_000_000).step_by(10_000) {
        for w in written(&mut a, t) {
            assert_eq!(w, line("VER\r"), "only VER at {t} µs");
            feed(&mut a, t + 1_000, b"4.01\r");
        }
    }
    assert_eq!(a.measured_units(), None);
    assert_eq!(a.protocol().card(), None);
}

#[test]
fn a_zero_scale_on_a_v2_card_is_not_a_finished_setup() {
    let mut a = adapter(Scientifica::new());
    let _ = written(&mut a, 0);
    feed(&mut a, 1_000, b"2.13\r");
    assert_eq!(written(&mut a, 1_000), vec![line("UUX\r")]);
    feed(&mut a, 2_000, b"0\r");
    assert!(written(&mut a, 50_000).is_empty());
    assert_eq!(written(&mut a, 102_000), vec![line("UUX\r")]);
}
