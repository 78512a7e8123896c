//! Sensapex uMp emulator, driven by SMCP1 datagrams written from the protocol notes'
//! worked packets (section 4.5) and the SDK's `smcp1.h` / `libum.c` layouts.

mod vendor_util;

use mesopush_firmware_sim::vendor::VendorController;
use mesopush_firmware_sim::vendor::sensapex::{Sensapex, SensapexSettings};
use vendor_util::{datagrams, trapezoid_s, us};

/// The notes' GOTO_POS: dev 1 from SDK id 0x0237, msg 1, REQ|REQ_ACK|REQ_NOTIFY, to
/// (1000, 2000, 3000) µm, W undefined, 100 µm/s, simultaneous.
const GOTO: [u8; 44] = [
    0x10, 0x00, 0x00, 0x01, 0x02, 0x37, 0x00, 0x01, 0x00, 0x00, 0x00, 0x51, 0x00, 0x21, 0x00, 0x01,
    0x00, 0x06, 0x00, 0x06, //
    0x00, 0x0F, 0x42, 0x40, 0x00, 0x1E, 0x84, 0x80, 0x00, 0x2D, 0xC6, 0xC0, 0x7F, 0xFF, 0xFF, 0xFF,
    0x00, 0x00, 0x00, 0x64, 0x00, 0x00, 0x00, 0x01,
];
const GOTO_ACK: [u8; 16] = [
    0x10, 0x00, 0x02, 0x37, 0x00, 0x01, 0x00, 0x01, 0x00, 0x00, 0x00, 0x02, 0x00, 0x21, 0x00, 0x00,
];
const GET_POSITIONS: [u8; 16] = [
    0x10, 0x00, 0x00, 0x01, 0x02, 0x37, 0x00, 0x02, 0x00, 0x00, 0x00, 0x31, 0x00, 0x0E, 0x00, 0x00,
];
const STOP: [u8; 16] = [
    0x10, 0x00, 0x00, 0x01, 0x02, 0x37, 0x00, 0x03, 0x00, 0x00, 0x00, 0x11, 0x00, 0x01, 0x00, 0x00,
];

fn ump(start_nm: [i64; 4]) -> Sensapex {
    Sensapex::new(SensapexSettings { start_nm, ..SensapexSettings::DEFAULT }, 0).unwrap()
}

/// A request from 0x0237 to device 1 with one INT32 sub-block (built here by hand, not with
/// the emulator's codec).
fn request(msg_id: u16, options: u32, kind: u16, args: &[i32]) -> Vec<u8> {
    let mut f = vec![0x10, 0x00, 0x00, 0x01, 0x02, 0x37];
    f.extend_from_slice(&msg_id.to_be_bytes());
    f.extend_from_slice(&options.to_be_bytes());
    f.extend_from_slice(&kind.to_be_bytes());
    f.extend_from_slice(&u16::from(!args.is_empty()).to_be_bytes());
    if !args.is_empty() {
        f.extend_from_slice(&[0x00, 0x06]);
        f.extend_from_slice(&(args.len() as u16).to_be_bytes());
        for a in args {
            f.extend_from_slice(&a.to_be_bytes());
        }
    }
    f
}

fn kind_of(d: &[u8]) -> u16 {
    u16::from_be_bytes([d[12], d[13]])
}

fn be32(d: &[u8], at: usize) -> i32 {
    i32::from_be_bytes([d[at], d[at + 1], d[at + 2], d[at + 3]])
}

/// The completion notification of the notes, with receiver = the requester (0x0237): the
/// SDK header says notifications are unicast to the sender unless REQ_BCAST (the notes'
/// example used 0x02FF, marked inferred). Bytes 6-7 (message id) are the device's own.
fn assert_done(d: &[u8], code: u8) {
    let want = [
        0x10, 0x00, 0x02, 0x37, 0x00, 0x01, d[6], d[7], 0x00, 0x00, 0x00, 0x04, 0x00, 0x68, 0x00,
        0x01, 0x00, 0x05, 0x00, 0x01, 0x00, 0x00, 0x00, code,
    ];
    assert_eq!(d, want);
}

#[test]
fn goto_pos_golden_ack_at_once_and_completion_notification_at_the_end() {
    let mut c = ump([990_000, 2_000_000, 3_000_000, 0]);
    c.receive(0, &GOTO);
    let first = datagrams(&mut c, 0);
    assert_eq!(first[0], GOTO_ACK);
    // 10 µm on x at 100 µm/s with the default 10 mm/s²: 0.1 s + 0.01 s.
    let end = us(trapezoid_s(10_000.0, 100_000.0, 10_000_000.0));
    assert_eq!(end, 110_000);
    let before = datagrams(&mut c, end - 1);
    assert!(before.iter().all(|d| kind_of(d) != 104), "no completion before the end");
    let at_end = datagrams(&mut c, end);
    let done = at_end.iter().find(|d| kind_of(d) == 104).expect("NOTIFY 104 at the end");
    assert_done(done, 0);
    assert_eq!(c.probe_nm(), (1_000_000, 2_000_000));
}

#[test]
fn get_positions_golden_ack_then_response_in_nm() {
    let mut c = ump([1_000_000, 2_000_000, 3_000_000, 0]);
    c.receive(0, &GET_POSITIONS);
    let d = datagrams(&mut c, 0);
    assert_eq!(d.len(), 2);
    assert_eq!(d[0], [0x10, 0, 0x02, 0x37, 0, 1, 0, 2, 0, 0, 0, 0x02, 0, 0x0E, 0, 0]);
    let head = [0x10, 0, 0x02, 0x37, 0, 1, 0, 2, 0, 0, 0, 0, 0, 0x0E, 0, 1, 0, 6, 0, 4];
    assert_eq!(d[1][..20], head);
    assert_eq!(
        d[1][20..],
        [0, 0x0F, 0x42, 0x40, 0, 0x1E, 0x84, 0x80, 0, 0x2D, 0xC6, 0xC0, 0, 0, 0, 0]
    );
}

#[test]
fn stop_golden_acks_and_ends_the_move_with_a_non_zero_code() {
    let mut c = ump([0; 4]);
    c.receive(0, &GOTO);
    datagrams(&mut c, 500_000);
    c.receive(500_000, &STOP);
    let d = datagrams(&mut c, 500_000);
    assert_eq!(d[0], [0x10, 0, 0x02, 0x37, 0, 1, 0, 3, 0, 0, 0, 0x02, 0, 0x01, 0, 0]);
    assert_done(d.iter().find(|d| kind_of(d) == 104).unwrap(), 1);
    let x = c.probe_nm().0;
    assert!(x > 0 && x < 1_000_000, "{x}");
    c.poll(60_000_000);
    assert_eq!(c.probe_nm().0, x, "stopped");
    assert!(datagrams(&mut c, 60_000_000).is_empty());
}

#[test]
fn a_frame_with_another_version_or_receiver_is_dropped() {
    let mut c = ump([0; 4]);
    let mut old = GET_POSITIONS;
    old[0] = 0x02;
    c.receive(0, &old);
    let mut other = GET_POSITIONS;
    other[3] = 0x02; // receiver 2
    c.receive(0, &other);
    assert!(datagrams(&mut c, 1_000_000).is_empty());
}

#[test]
fn a_malformed_unicast_frame_with_req_ack_gets_ack_error_and_is_not_acted_on() {
    let mut c = ump([0; 4]);
    c.receive(0, &GOTO[..40]); // the header announces 6 values, 5 arrive
    let d = datagrams(&mut c, 1_000_000);
    assert_eq!(d, vec![vec![0x10, 0, 0x02, 0x37, 0, 1, 0, 1, 0, 0, 0, 0x0A, 0, 0x21, 0, 0]]);
    assert_eq!(c.probe_nm(), (0, 0));
    let mut no_ack = GOTO;
    no_ack[11] = 0x41;
    c.receive(1_000_000, &no_ack[..40]);
    let mut bcast = GOTO;
    bcast[2..4].copy_from_slice(&[0x00, 0xFF]);
    c.receive(1_000_000, &bcast[..40]);
    assert!(datagrams(&mut c, 2_000_000).is_empty(), "silent without REQ_ACK or unicast");
}

#[test]
fn speed_zero_is_not_understood_and_below_1_um_s_is_sent_as_negative_nm_s() {
    let mut c = ump([0; 4]);
    let undef = i32::MAX;
    c.receive(0, &request(5, 0x51, 33, &[100, undef, undef, undef, 0, 1]));
    assert_eq!(datagrams(&mut c, 0)[0][11], 0x0A, "ACK|ERROR");
    // 100 nm at 0.5 µm/s = -500 (nm/s): 0.2 s + 0.00005 s.
    c.receive(1_000_000, &request(6, 0x51, 33, &[100, undef, undef, undef, -500, 1]));
    let end = 1_000_000 + us(trapezoid_s(100.0, 500.0, 10_000_000.0));
    assert!(datagrams(&mut c, end - 1).iter().all(|d| kind_of(d) != 104));
    assert!(datagrams(&mut c, end).iter().any(|d| kind_of(d) == 104));
    assert_eq!(c.probe_nm().0, 100);
}

#[test]
fn positions_are_pushed_every_20_ms_while_moving() {
    let mut c = ump([990_000, 2_000_000, 3_000_000, 0]);
    c.receive(0, &GOTO);
    let mut pushes = Vec::new();
    for t in (0..=120_000).step_by(1000) {
        for d in datagrams(&mut c, t) {
            if kind_of(&d) == 101 {
                assert_eq!(u16::from_be_bytes([d[2], d[3]]), 0x02FF, "to all PCs");
                pushes.push((t, be32(&d, 20)));
            }
        }
    }
    let times: Vec<u64> = pushes.iter().map(|p| p.0).collect();
    assert_eq!(times, [20_000, 40_000, 60_000, 80_000, 100_000, 110_000]);
    assert!(pushes.windows(2).all(|w| w[0].1 < w[1].1), "x increases: {pushes:?}");
    assert_eq!(pushes.last().unwrap().1, 1_000_000);
}

#[test]
fn mode_0_moves_one_axis_after_another() {
    let mut c = ump([0; 4]);
    let undef = i32::MAX;
    c.receive(0, &request(7, 0x51, 33, &[10_000, 10_000, undef, undef, 100, 0]));
    let leg = us(trapezoid_s(10_000.0, 100_000.0, 10_000_000.0));
    c.poll(leg / 2);
    assert!(c.probe_nm().0 > 0 && c.probe_nm().1 == 0, "{:?}", c.probe_nm());
    c.poll(leg);
    assert_eq!(c.probe_nm(), (10_000, 0));
    let done = datagrams(&mut c, 2 * leg);
    assert!(done.iter().any(|d| kind_of(d) == 104));
    assert_eq!(c.probe_nm(), (10_000, 10_000));
}

#[test]
fn a_stall_ends_the_move_off_target_with_a_failure_code() {
    let mut c = ump([0; 4]);
    c.receive(0, &GOTO);
    c.set_stalled(200_000, true);
    let stalled_at = c.probe_nm();
    let d = datagrams(&mut c, 100_000_000);
    assert_done(d.iter().find(|d| kind_of(d) == 104).unwrap(), 3);
    assert_eq!(c.probe_nm(), stalled_at);
}

#[test]
fn ping_echoes_take_step_acks_only_and_parameters_answer() {
    let mut c = ump([0; 4]);
    c.receive(0, &request(9, 0x31, 0, &[7, 8]));
    let d = datagrams(&mut c, 0);
    assert_eq!(d[0][11], 0x02);
    let echo = [
        0x10, 0, 0x02, 0x37, 0, 1, 0, 9, 0, 0, 0, 0, 0, 0, 0, 1, 0, 6, 0, 2, 0, 0, 0, 7, 0, 0, 0, 8,
    ];
    assert_eq!(d[1], echo);
    c.receive(1000, &request(10, 0x11, 34, &[500, 0, 0, 0, 10, 0, 0, 0]));
    let d = datagrams(&mut c, 10_000_000);
    assert!(d.iter().all(|d| kind_of(d) != 104), "TAKE_STEP has no completion notify");
    assert_eq!(c.probe_nm().0, 500);
    c.receive(10_000_000, &request(11, 0x31, 16, &[0x105]));
    let d = datagrams(&mut c, 10_000_000);
    assert_eq!((be32(&d[1], 20), be32(&d[1], 24)), (0x105, 4), "AXIS_COUNT");
}

#[test]
fn after_a_stall_the_next_move_starts_from_the_sensed_position() {
    let mut c = ump([0; 4]);
    c.set_stalled(0, true);
    c.receive(0, &GOTO);
    datagrams(&mut c, 100_000_000);
    c.set_stalled(100_000_000, false);
    assert_eq!(c.probe_nm(), (0, 0), "never moved");
    let undef = i32::MAX;
    c.receive(100_000_000, &request(20, 0x51, 33, &[1000, undef, undef, undef, 100, 1]));
    datagrams(&mut c, 200_000_000);
    assert_eq!(c.probe_nm(), (1000, 0));
}
