//! Sutter MPC-200 emulator, driven by raw bytes written from the protocol documentation
//! (MPC-200 USB command sheet, MPC-325/385 manuals, acq4 `mpc200.py`, pyIVLS).

mod vendor_util;

use mesopush_firmware_sim::vendor::VendorController;
use mesopush_firmware_sim::vendor::mpc200::{DEFAULT_ACCEL_USTEPS_S2, Mpc200, Mpc200Settings};
use vendor_util::{le, take, trapezoid_s, us};

/// Input is accepted from 1 s after power-on.
const T0: u64 = 1_000_000;

fn mpc(start: [i64; 3]) -> Mpc200 {
    Mpc200::new(Mpc200Settings { start_usteps: start, ..Mpc200Settings::DEFAULT }, 0).unwrap()
}

fn packet(cmd: u8, v: Option<u8>, xyz: [i32; 3]) -> Vec<u8> {
    let mut p = vec![cmd];
    p.extend(v);
    for c in xyz {
        p.extend_from_slice(&le(c));
    }
    p
}

/// 'S' sent the acq4 way: `53`, 30 ms, then V and the 12 position bytes. Returns the time
/// the move starts (the last byte's arrival).
fn straight(c: &mut Mpc200, t: u64, v: u8, xyz: [i32; 3]) -> u64 {
    c.receive(t, &[0x53]);
    c.receive(t + 30_000, &packet(0x53, Some(v), xyz)[1..]);
    t + 30_000
}

#[test]
fn position_reply_is_14_bytes_little_endian_and_leaves_at_128000_baud() {
    let mut c = mpc([1000, 2000, 3000]);
    c.receive(T0, &[0x43]);
    let want = [1, 0xE8, 3, 0, 0, 0xD0, 7, 0, 0, 0xB8, 0x0B, 0, 0, 0x0D];
    // 14 bytes × 78.125 µs = 1093.75 µs: 13 bytes are out at +1093, the CR at +1094.
    assert_eq!(take(&mut c, T0 + 1093), want[..13]);
    assert_eq!(take(&mut c, T0 + 1094), [0x0D]);
}

#[test]
fn input_during_the_first_second_after_power_on_is_ignored() {
    let mut c = mpc([0; 3]);
    c.receive(500_000, &[0x43]);
    assert_eq!(take(&mut c, T0 + 10_000), b"");
    c.receive(T0 + 20_000, &[0x43]);
    assert_eq!(take(&mut c, T0 + 30_000).len(), 14);
}

#[test]
fn straight_move_replies_cr_at_its_end_at_81_25_um_s_per_speed_step() {
    let mut c = mpc([100_000; 3]);
    let t = straight(&mut c, T0, 15, [116_000, 100_000, 100_000]);
    // V = 15: 81.25 µm/s × 16 = 1300 µsteps/s × 16 = 20800 µsteps/s on the moving axis.
    let end = t + us(trapezoid_s(16_000.0, 20_800.0, DEFAULT_ACCEL_USTEPS_S2));
    assert_eq!(take(&mut c, end + 78), b"", "no CR before the move's end + one byte time");
    assert_eq!(take(&mut c, end + 79), [0x0D]);
    assert_eq!(c.probe_nm(), (116_000 * 125 / 2, 100_000 * 125 / 2));
    c.receive(end + 1000, &[0x43]);
    assert_eq!(take(&mut c, end + 5000)[1..5], le(116_000));
}

#[test]
fn straight_move_speed_scales_with_v_on_the_fastest_axis() {
    // V = 3: 325 µm/s = 5200 µsteps/s on x; the diagonal runs at the x speed on each axis.
    let mut c = mpc([100_000; 3]);
    let t = straight(&mut c, T0, 3, [110_000, 110_000, 100_000]);
    let end = t + us(trapezoid_s(10_000.0, 5_200.0, DEFAULT_ACCEL_USTEPS_S2));
    assert_eq!(take(&mut c, end - 1), b"");
    assert_eq!(take(&mut c, end + 79), [0x0D]);
}

#[test]
fn the_pause_may_also_follow_the_speed_byte_as_the_manual_has_it() {
    let mut c = mpc([100_000; 3]);
    let p = packet(0x53, Some(15), [120_000, 100_000, 100_000]);
    c.receive(T0, &p[..2]);
    c.receive(T0 + 35_000, &p[2..]);
    let end = T0 + 35_000 + us(trapezoid_s(20_000.0, 20_800.0, DEFAULT_ACCEL_USTEPS_S2));
    assert_eq!(take(&mut c, end + 79), [0x0D]);
    assert!(!c.is_crashed());
}

#[test]
fn an_unpaced_straight_packet_crashes_the_controller_until_a_power_cycle() {
    for gap_us in [0, 20_000] {
        let mut c = mpc([100_000; 3]);
        let p = packet(0x53, Some(15), [120_000, 100_000, 100_000]);
        c.receive(T0, &p[..2]);
        c.receive(T0 + gap_us, &p[2..]);
        assert!(c.is_crashed(), "gap {gap_us} µs");
        c.receive(T0 + 100_000, &[0x43]);
        assert_eq!(take(&mut c, T0 + 10_000_000), b"", "silent after the crash");
        assert_eq!(c.probe_nm(), (6_250_000, 6_250_000), "the stage did not move");
        c.power_cycle(T0 + 10_000_000);
        c.receive(T0 + 10_500_000, &[0x43]);
        assert_eq!(take(&mut c, T0 + 10_600_000), b"", "still booting");
        c.receive(T0 + 11_000_000, &[0x43]);
        assert_eq!(take(&mut c, T0 + 11_100_000)[1..5], le(100_000));
    }
}

#[test]
fn a_move_shorter_than_16_usteps_on_every_axis_gets_no_reply() {
    let mut c = mpc([100_000; 3]);
    c.receive(T0, &packet(0x4D, None, [100_015, 99_985, 100_000]));
    assert_eq!(take(&mut c, T0 + 2_000_000), b"", "15 µsteps: ignored, no CR");
    c.receive(T0 + 2_000_000, &[0x43]);
    assert_eq!(take(&mut c, T0 + 2_010_000)[1..5], le(100_000), "idle, did not move");
    c.receive(T0 + 3_000_000, &packet(0x4D, None, [100_016, 100_000, 100_000]));
    assert_eq!(take(&mut c, T0 + 4_000_000), [0x0D], "16 µsteps: moved and replied");
}

#[test]
fn interrupt_replies_cr_at_once_stops_the_stage_and_blocks_queries_until_then() {
    let mut c = mpc([100_000; 3]);
    c.receive(T0, &packet(0x4D, None, [300_000, 100_000, 100_000]));
    let mid = T0 + 1_000_000;
    c.receive(mid, &[0x43]);
    assert_eq!(take(&mut c, mid + 10_000), b"", "no position query during a move");
    c.receive(mid + 10_000, &[0x03]);
    assert_eq!(take(&mut c, mid + 10_078), b"");
    assert_eq!(take(&mut c, mid + 10_079), [0x0D]);
    let stopped = c.probe_nm();
    c.poll(mid + 2_000_000);
    assert_eq!(c.probe_nm(), stopped, "stopped dead");
    assert!(stopped.0 > 100_000 * 125 / 2 && stopped.0 < 300_000 * 125 / 2);
    assert_eq!(take(&mut c, mid + 10_000_000), b"", "no second CR for the stopped move");
}

#[test]
fn the_first_query_after_an_interrupt_may_carry_a_leading_i_drawn_from_the_seed() {
    let run = |chance: f64, seed: u64| {
        let cfg = Mpc200Settings {
            start_usteps: [100_000; 3],
            stray_i_chance: chance,
            seed,
            ..Mpc200Settings::DEFAULT
        };
        let mut c = Mpc200::new(cfg, 0).unwrap();
        c.receive(T0, &packet(0x4D, None, [300_000, 100_000, 100_000]));
        c.receive(T0 + 500_000, &[0x03]);
        c.receive(T0 + 600_000, &[0x43]);
        c.receive(T0 + 700_000, &[0x43]);
        take(&mut c, T0 + 800_000)
    };
    let with_i = run(1.0, 1);
    assert_eq!((with_i.len(), with_i[1], with_i[2]), (1 + 1 + 14 + 14, b'I', 1));
    assert_eq!(run(0.0, 1).len(), 1 + 14 + 14);
    let draws: Vec<usize> = (0..16).map(|s| run(0.5, s).len()).collect();
    assert_eq!(draws, (0..16).map(|s| run(0.5, s).len()).collect::<Vec<_>>(), "seeded");
    assert!(draws.contains(&29) && draws.contains(&30), "both outcomes over 16 seeds");
}

#[test]
fn targets_outside_the_travel_are_clamped_and_the_move_still_replies() {
    let mut c = mpc([100_000; 3]);
    c.receive(T0, &packet(0x4D, None, [500_000, -1, 100_000]));
    assert_eq!(take(&mut c, T0 + 20_000_000), [0x0D]);
    c.receive(T0 + 20_000_000, &[0x43]);
    let r = take(&mut c, T0 + 20_010_000);
    assert_eq!((&r[1..5], &r[5..9]), (&le(400_000)[..], &le(0)[..]));
}

#[test]
fn drive_status_selection_and_firmware_replies() {
    let cfg = Mpc200Settings { drives: [true, true, false, false], ..Mpc200Settings::DEFAULT };
    let mut c = Mpc200::new(cfg, 0).unwrap();
    c.receive(T0, &[0x55, 0x4B, 0x49, 0x03, 0x49, 0x02, 0x43]);
    let r = take(&mut c, T0 + 10_000);
    assert_eq!(r[..6], [2, 1, 1, 0, 0, 0x0D], "U: 2 drives, 1 and 2");
    assert_eq!(r[6..10], [1, 0x15, 0x03, 0x0D], "K: drive 1, firmware 3.15 in BCD");
    assert_eq!(r[10..12], [0x45, 0x0D], "I 3: not connected");
    assert_eq!(r[12..14], [2, 0x0D], "I 2: selected");
    assert_eq!(r[14], 2, "C answers for drive 2");
}

#[test]
fn fast_move_runs_each_axis_on_its_own_profile() {
    let mut c = mpc([100_000; 3]);
    c.receive(T0, &packet(0x4D, None, [200_000, 101_000, 100_000]));
    // y (1000 µsteps) is done long before x (100000 µsteps): not a straight line.
    c.poll(T0 + 300_000);
    let (x, y) = c.probe_nm();
    assert_eq!(y, 101_000 * 125 / 2);
    assert!(x < 150_000 * 125 / 2, "x still far from its target: {x}");
}

#[test]
fn a_stall_freezes_the_probe_while_the_counter_runs_and_calibration_recovers() {
    let mut c = mpc([100_000; 3]);
    c.receive(T0, &packet(0x4D, None, [200_000, 100_000, 100_000]));
    c.set_stalled(T0 + 200_000, true);
    let frozen = c.probe_nm();
    assert_eq!(take(&mut c, T0 + 5_000_000), [0x0D], "the move still 'completes'");
    c.set_stalled(T0 + 5_000_000, false);
    c.receive(T0 + 5_000_000, &[0x43]);
    assert_eq!(take(&mut c, T0 + 5_010_000)[1..5], le(200_000), "counter at the target");
    assert_eq!(c.probe_nm(), frozen, "probe where it stalled");
    c.receive(T0 + 6_000_000, &[0x4E]);
    assert_eq!(take(&mut c, T0 + 16_000_000), [0x0D]);
    c.receive(T0 + 16_000_000, &[0x43]);
    assert_eq!(take(&mut c, T0 + 16_010_000)[1..13], [0; 12]);
    assert_eq!(c.probe_nm(), (0, 0), "calibration drove to the true origin");
}
