//! Sutter MP-285 emulator, driven by raw bytes written from the protocol documentation
//! (acq4 `mp285.py` and its Arduino interposer, Micro-Manager `MP285`, ScanImage).

mod vendor_util;

use mesopush_firmware_sim::vendor::VendorController;
use mesopush_firmware_sim::vendor::mp285::{
    DEFAULT_ACCEL_USTEPS_S2, Mp285, Mp285Settings, RESET_QUIET_US,
};
use vendor_util::{le, take, trapezoid_s, us};

/// One byte at 9600 baud 8N1 takes 1041.67 µs.
const BYTE_US: f64 = 10.0 / 9600.0 * 1e6;

fn mp(start: [i64; 3]) -> Mp285 {
    Mp285::new(Mp285Settings { start_usteps: start, ..Mp285Settings::DEFAULT }, 0).unwrap()
}

fn mv(xyz: [i32; 3]) -> Vec<u8> {
    let mut p = vec![0x6D];
    for c in xyz {
        p.extend_from_slice(&le(c));
    }
    p.push(0x0D);
    p
}

fn pos(c: &mut Mp285, t: u64) -> [i32; 3] {
    c.receive(t, &[0x63, 0x0D]);
    let r = take(c, t + 20_000);
    assert_eq!((r.len(), r[12]), (13, 0x0D), "{r:02X?}");
    core::array::from_fn(|i| {
        i32::from_le_bytes([r[4 * i], r[4 * i + 1], r[4 * i + 2], r[4 * i + 3]])
    })
}

#[test]
fn position_reply_takes_13_5_ms_to_leave_at_9600_baud() {
    let mut c = mp([1000, -2000, 3000]);
    c.receive(10_000, &[0x63, 0x0D]);
    let all = [0xE8, 3, 0, 0, 0x30, 0xF8, 0xFF, 0xFF, 0xB8, 0x0B, 0, 0, 0x0D];
    let last = 10_000 + (13.0 * BYTE_US).ceil() as u64; // 13541.67 µs
    assert_eq!(take(&mut c, last - 1), all[..12], "the 13th byte is still on the wire");
    assert_eq!(take(&mut c, last), [0x0D]);
}

#[test]
fn a_stray_line_feed_after_the_cr_is_ignored() {
    let mut c = mp([5, 6, 7]);
    c.receive(0, &[0x63, 0x0D, 0x0A]);
    c.receive(50_000, &[0x63, 0x0D, 0x0A]);
    let r = take(&mut c, 100_000);
    assert_eq!(r.len(), 26, "two position replies, no error packet: {r:02X?}");
    assert_eq!(r[..13], r[13..]);
}

#[test]
fn move_replies_cr_at_its_end_at_the_velocity_set_by_v() {
    let mut c = mp([0; 3]);
    c.receive(0, &[0x56, 0xE8, 0x83, 0x0D]); // fine | 1000 µm/s, little-endian
    assert_eq!(take(&mut c, 10_000), [0x0D]);
    c.receive(100_000, &mv([25_000, 0, 0])); // 1 mm = 25000 µsteps at 25 µsteps/µm
    let end = 100_000 + us(trapezoid_s(25_000.0, 25_000.0, DEFAULT_ACCEL_USTEPS_S2));
    let cr = end + BYTE_US.ceil() as u64;
    assert_eq!(take(&mut c, cr - 1), b"");
    assert_eq!(take(&mut c, cr), [0x0D]);
    assert_eq!(c.probe_nm(), (1_000_000, 0));
}

#[test]
fn coarse_resolution_rounds_targets_to_five_usteps_and_runs_faster() {
    let mut c = mp([0; 3]);
    c.receive(0, &[0x56, 0x88, 0x13, 0x0D]); // coarse, 5000 µm/s (above the fine limit)
    c.receive(10_000, &mv([25_003, 0, 0]));
    let end = 10_000 + us(trapezoid_s(25_005.0, 125_000.0, DEFAULT_ACCEL_USTEPS_S2));
    assert_eq!(take(&mut c, end - 1), [0x0D], "only the V reply so far");
    assert_eq!(take(&mut c, end + 1042), [0x0D]);
    assert_eq!(pos(&mut c, end + 2000), [25_005, 0, 0]);
}

#[test]
fn status_block_is_32_bytes_with_step_div_speed_and_mode_flags() {
    let mut c = mp([0; 3]);
    c.receive(0, &[0x56, 0x0A, 0x80, 0x0D, 0x73, 0x0D]); // fine | 10 µm/s, then status
    let r = take(&mut c, 100_000);
    let s = &r[1..];
    assert_eq!((s.len(), s[32]), (33, 0x0D));
    assert_eq!(u16::from_le_bytes([s[24], s[25]]), 25, "STEP_DIV");
    assert_eq!(u16::from_le_bytes([s[26], s[27]]), 40, "STEP_MUL");
    assert_eq!(u16::from_le_bytes([s[28], s[29]]), 0x800A, "XSPEED as V set it");
    assert_eq!((s[0] & 0x20, s[15] & 0x04), (0x20, 0x04), "absolute, fine");
    c.receive(200_000, &[0x62, 0x0D, 0x73, 0x0D]);
    let r = take(&mut c, 300_000);
    assert_eq!(r[1] & 0x20, 0, "relative mode clears FLAGS bit 5");
}

#[test]
fn interrupt_ends_the_move_with_the_move_interrupted_error_packet() {
    let mut c = mp([0; 3]);
    c.receive(0, &mv([250_000, 0, 0]));
    c.receive(500_000, &[0x63, 0x0D]);
    assert_eq!(take(&mut c, 600_000), b"", "no query during a move");
    c.receive(600_000, &[0x03]);
    assert_eq!(take(&mut c, 600_000 + 2084), [0x2A, 0x0D], "'*' then CR");
    assert_eq!(take(&mut c, 60_000_000), b"", "nothing else for the stopped move");
    let p = pos(&mut c, 60_000_000);
    assert!(p[0] > 0 && p[0] < 250_000, "{p:?}");
}

#[test]
fn a_position_query_with_the_knob_in_use_hangs_the_controller_until_power_cycled() {
    let mut c = mp([100, 0, 0]);
    c.set_knob_in_use(true);
    c.receive(0, &[0x73, 0x0D]);
    assert_eq!(take(&mut c, 100_000).len(), 33, "status is fine with the knob in use");
    c.receive(100_000, &[0x63, 0x0D]);
    assert!(c.is_hung());
    c.set_knob_in_use(false);
    c.receive(200_000, &[0x73, 0x0D, 0x63, 0x0D, 0x72, 0x0D]);
    assert_eq!(take(&mut c, 10_000_000), b"", "no reply to anything, soft reset included");
    c.power_cycle(10_000_000);
    c.receive(10_000_000 + RESET_QUIET_US - 1, &[0x63, 0x0D]);
    assert_eq!(take(&mut c, 10_500_000), b"", "still starting up");
    assert_eq!(pos(&mut c, 10_500_000), [100, 0, 0]);
}

#[test]
fn bad_command_and_missing_cr_get_ascii_error_codes() {
    let mut c = mp([0; 3]);
    c.receive(0, &[0x7A, 0x0D]); // 'z'
    assert_eq!(take(&mut c, 10_000), [0x34, 0x0D]);
    c.receive(20_000, &[0x63, 0x58]); // 'c' without its CR
    assert_eq!(take(&mut c, 30_000), [0x32, 0x0D]);
}

#[test]
fn relative_mode_and_set_origin() {
    let mut c = mp([1000, 1000, 1000]);
    c.receive(0, &[0x6F, 0x0D, 0x62, 0x0D]);
    assert_eq!(take(&mut c, 10_000), [0x0D, 0x0D]);
    assert_eq!(pos(&mut c, 10_000), [0, 0, 0]);
    c.receive(100_000, &mv([100, -100, 0]));
    assert_eq!(take(&mut c, 1_000_000), [0x0D]);
    assert_eq!(pos(&mut c, 1_000_000), [100, -100, 0]);
    assert_eq!(c.probe_nm(), (1100 * 40, 900 * 40), "the true stage never jumped");
}

#[test]
fn soft_reset_sends_nothing_and_drops_the_move() {
    let mut c = mp([0; 3]);
    c.receive(0, &mv([250_000, 0, 0]));
    c.receive(100_000, &[0x03]);
    assert_eq!(take(&mut c, 200_000), [0x2A, 0x0D]);
    c.receive(200_000, &[0x72, 0x0D]);
    assert_eq!(take(&mut c, 1_000_000), b"");
    c.receive(200_000 + RESET_QUIET_US / 2, &[0x63, 0x0D]);
    assert_eq!(take(&mut c, 1_000_000), b"", "ignored while restarting");
}
