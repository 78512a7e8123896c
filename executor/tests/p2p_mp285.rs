//! The point-to-point adapter driving a Sutter MP-285, against replies written by hand from
//! the documented layouts (status block: 32 bytes + `0D`, STEP_DIV u16 LE at offset 24;
//! `c` → x, y, z i32 LE + `0D`; `V` and `m` → `0D`, the move's at its end; an error is one
//! ASCII code byte + `0D`).

mod p2p_common;

use mesopush_executor::adapter::AdapterEvent;
use mesopush_executor::adapter::ControllerAdapter;
use mesopush_executor::adapter::p2p::mp285::Mp285;
use mesopush_protocol::ExecToCtrl;
use mesopush_protocol::ctrl::FaultCode;
use p2p_common::{
    Adapter, adapter, events, fault, feed, last_done, raw_events, reported, segment, written,
};

/// A status block as the MP-285 sends it: 32 bytes, then `0D`. STEP_DIV at 24..26 (LE);
/// UOFFSET (6..8) holds `0D 0D` so that only the length can delimit it.
fn status_block(step_div: u16) -> Vec<u8> {
    let [lo, hi] = step_div.to_le_bytes();
    vec![
        0x20, 0, 0, 0, // FLAGS, UDIRX/Y/Z
        0x0A, 0x00, 0x0D, 0x0D, // ROE_VARI, UOFFSET
        0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // URANGE, PULSE, USPEED
        0x00, 0x04, // INDEVICE, FLAGS_2
        0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // JUMPSPD, HIGHSPD, DEAD, WATCH_DOG
        lo, hi, 0x28, 0x00, // STEP_DIV, STEP_MUL = 40
        0x8C, 0x80, 0x2C, 0x01, // XSPEED = fine | 140, VERSION = 300
        0x0D,
    ]
}

/// `c`'s reply: x, y, z (i32 LE) and `0D`.
fn position_reply(x: i32, y: i32, z: i32) -> Vec<u8> {
    let mut r = Vec::new();
    for v in [x, y, z] {
        r.extend_from_slice(&v.to_le_bytes());
    }
    r.push(0x0D);
    r
}

/// Start-up: status block, absolute mode, position. At rest at (5000, 5000) µm =
/// 125 000 µsteps at STEP_DIV 25, z 1000 µsteps.
fn ready() -> Adapter<Mp285> {
    let mut a = adapter(Mp285::new());
    assert_eq!(written(&mut a, 0), vec![b"s\r".to_vec()]);
    feed(&mut a, 1_000, &status_block(25));
    assert_eq!(written(&mut a, 1_000), vec![b"a\r".to_vec()]);
    feed(&mut a, 2_000, &[0x0D]);
    assert_eq!(written(&mut a, 2_000), vec![b"c\r".to_vec()]);
    feed(&mut a, 3_000, &position_reply(125_000, 125_000, 1_000));
    assert_eq!(a.measured_units(), Some([125_000, 125_000, 1_000]));
    let _ = events(&mut a);
    a
}

/// `V` fine | 140 µm/s: `56 8C 80 0D`.
const V_140: [u8; 4] = [0x56, 0x8C, 0x80, 0x0D];
/// `m` to (127 500, 125 000, 1 000) µsteps: 5100 µm, 5000 µm.
const M_5100: [u8; 14] =
    [0x6D, 0x0C, 0xF2, 0x01, 0x00, 0x48, 0xE8, 0x01, 0x00, 0xE8, 0x03, 0x00, 0x00, 0x0D];

/// Sends the 100 µm move along x at 140 µm/s due at 50 ms; its `V` answered at 55 ms.
fn move_100_um(a: &mut Adapter<Mp285>, id: u32) {
    a.command(4_000, &segment(id, 50_000, 5_100_000, 5_000_000, 140_000));
    assert!(written(a, 49_000).is_empty(), "not before its start");
    assert_eq!(written(a, 50_000), vec![V_140.to_vec()]);
    assert!(written(a, 59_999).is_empty(), "10 ms after the V");
    feed(a, 55_000, &[0x0D]); // V's answer: skipped
    assert_eq!(written(a, 60_000), vec![M_5100.to_vec()]);
}

#[test]
fn a_move_sets_the_speed_answers_at_its_end_and_is_checked() {
    let mut a = ready();
    move_100_um(&mut a, 10);
    // No polls during the move (the device takes no command before its CR); the reported
    // position is the profile's: 240 ms at 140 µm/s after the last byte = 33.6 µm, less
    // the nanometre the estimate's integer steps lose (duration rounded up to 714 286 µs,
    // the fraction rounded down).
    assert!(written(&mut a, 300_000).is_empty());
    assert_eq!(reported(&events(&mut a)), Some((5_033_599, 5_000_000)));
    feed(&mut a, 780_000, &[0x0D]);
    assert_eq!(written(&mut a, 780_000), vec![b"c\r".to_vec()]);
    feed(&mut a, 781_000, &position_reply(127_500, 125_000, 1_000));
    assert_eq!(last_done(&events(&mut a)), Some(10));
    // The same speed again: no `V`, the move at once.
    a.command(790_000, &segment(11, 800_000, 5_000_000, 5_000_000, 140_000));
    let m_back =
        [0x6D, 0x48, 0xE8, 0x01, 0x00, 0x48, 0xE8, 0x01, 0x00, 0xE8, 0x03, 0x00, 0x00, 0x0D];
    assert_eq!(written(&mut a, 800_000), vec![m_back.to_vec()]);
    feed(&mut a, 1_520_000, &[0x0D]);
    assert_eq!(written(&mut a, 1_520_000), vec![b"c\r".to_vec()]);
    feed(&mut a, 1_521_000, &position_reply(125_000, 125_000, 1_000));
    assert_eq!(last_done(&events(&mut a)), Some(11));
}

#[test]
fn the_knob_quirk_no_position_is_asked_at_rest() {
    let mut a = ready();
    for t in (100_000..5_000_000).step_by(50_000) {
        assert!(written(&mut a, t).is_empty(), "asked at rest at {t} µs");
    }
    assert!(a.is_alive());
}

#[test]
fn a_controller_hung_by_its_knob_is_reported_silent() {
    let mut a = ready();
    move_100_um(&mut a, 12);
    // The move's CR never comes: at the deadline (60 ms + 150 % of 714 ms + 1 s) the
    // position is asked, and not answered either.
    assert!(written(&mut a, 2_131_000).is_empty());
    assert_eq!(written(&mut a, 2_132_000), vec![b"c\r".to_vec()]);
    assert!(written(&mut a, 2_332_001).is_empty());
    let evs = raw_events(&mut a);
    assert!(evs.contains(&AdapterEvent::LinkDown), "{evs:?}");
    assert!(!a.is_alive());
    // Then asked every 100 ms until it answers again (after a power cycle).
    assert_eq!(written(&mut a, 2_432_001), vec![b"c\r".to_vec()]);
    feed(&mut a, 2_433_000, &position_reply(126_000, 125_000, 1_000));
    assert!(a.is_alive());
}

#[test]
fn an_unanswered_position_after_a_move_is_a_silent_controller() {
    let mut a = ready();
    move_100_um(&mut a, 13);
    feed(&mut a, 780_000, &[0x0D]);
    assert_eq!(written(&mut a, 780_000), vec![b"c\r".to_vec()]);
    let _ = written(&mut a, 980_001);
    assert!(raw_events(&mut a).contains(&AdapterEvent::LinkDown));
}

#[test]
fn a_move_that_ended_short_is_a_stall() {
    let mut a = ready();
    move_100_um(&mut a, 14);
    feed(&mut a, 780_000, &[0x0D]);
    let _ = written(&mut a, 780_000);
    feed(&mut a, 781_000, &position_reply(126_250, 125_000, 1_000)); // 50 µm short
    assert_eq!(fault(&events(&mut a)), Some(FaultCode::Stall));
    assert_eq!(written(&mut a, 782_000), vec![vec![0x03]]);
}

#[test]
fn an_error_code_refuses_the_move_and_the_speed_is_sent_again() {
    let mut a = ready();
    move_100_um(&mut a, 15);
    feed(&mut a, 61_000, &[b'4', 0x0D]); // bad command
    assert_eq!(fault(&events(&mut a)), Some(FaultCode::BadSegment));
    assert_eq!(written(&mut a, 62_000), vec![vec![0x03]]);
    feed(&mut a, 63_000, &[0x0D]);
    // Where it is is read again at the next poll slot (30 ms after the move began).
    assert_eq!(written(&mut a, 90_000), vec![b"c\r".to_vec()]);
    feed(&mut a, 91_000, &position_reply(125_000, 125_000, 1_000));
    a.command(92_000, &ExecToCtrl::ClearFault);
    a.command(92_000, &segment(16, 100_000, 5_100_000, 5_000_000, 140_000));
    assert_eq!(written(&mut a, 100_000), vec![V_140.to_vec()], "the V again");
}

#[test]
fn stop_interrupts_the_move_and_the_position_is_read_again() {
    let mut a = ready();
    move_100_um(&mut a, 17);
    a.command(300_000, &ExecToCtrl::Stop);
    assert_eq!(written(&mut a, 300_000), vec![vec![0x03]]);
    feed(&mut a, 301_000, &[b'8', 0x0D]); // "move interrupted"
    // Idle polls are unsafe, but where it stopped must be known.
    assert_eq!(written(&mut a, 301_000), vec![b"c\r".to_vec()]);
    feed(&mut a, 302_000, &position_reply(126_000, 125_000, 1_000));
    assert_eq!(a.measured_units(), Some([126_000, 125_000, 1_000]));
    assert!(written(&mut a, 1_000_000).is_empty(), "and then no more");
}

#[test]
fn position_bytes_equal_to_cr_are_read_by_length() {
    let mut a = adapter(Mp285::new());
    let _ = written(&mut a, 0);
    feed(&mut a, 1_000, &status_block(25));
    let _ = written(&mut a, 1_000);
    feed(&mut a, 2_000, &[0x0D]);
    let _ = written(&mut a, 2_000);
    // x = 0x0D0D, y = 0x0D: the reply holds four `0D` before its last.
    feed(&mut a, 3_000, &[0x0D, 0x0D, 0, 0, 0x0D, 0, 0, 0, 0, 0, 0, 0, 0x0D]);
    assert_eq!(a.measured_units(), Some([0x0D0D, 0x0D, 0]));
}

#[test]
fn step_div_from_the_status_block_sets_the_scale() {
    let mut a = adapter(Mp285::new());
    let _ = written(&mut a, 0);
    feed(&mut a, 1_000, &status_block(10));
    let _ = written(&mut a, 1_000);
    feed(&mut a, 2_000, &[0x0D]);
    let _ = written(&mut a, 2_000);
    feed(&mut a, 3_000, &position_reply(50_000, 50_000, 0));
    let _ = events(&mut a);
    assert_eq!(reported(&events_after(&mut a, 10_000)), Some((5_000_000, 5_000_000)));
}

#[test]
fn a_zero_step_div_is_not_a_finished_setup() {
    let mut a = adapter(Mp285::new());
    assert_eq!(written(&mut a, 0), vec![b"s\r".to_vec()]);
    feed(&mut a, 1_000, &status_block(0));
    a.command(2_000, &segment(18, 3_000, 100_000, 0, 140_000));
    assert!(written(&mut a, 50_000).is_empty(), "neither `a`, `c` nor a move");
    assert_eq!(written(&mut a, 101_000), vec![b"s\r".to_vec()], "asked again");
    assert_eq!(a.measured_units(), None);
}

fn events_after(a: &mut Adapter<Mp285>, t: u64) -> Vec<mesopush_protocol::ctrl::CtrlToExec> {
    a.poll(t);
    events(a)
}
