//! Scientifica motion-card emulator, driven by command lines written from the protocol
//! documentation (acq4 `scientifica.py`, Micro-Manager `Scientifica.cpp`, ScanImage).

mod vendor_util;

use mesopush_firmware_sim::vendor::VendorController;
use mesopush_firmware_sim::vendor::scientifica::{Card, Scientifica, ScientificaSettings};
use vendor_util::{take, trapezoid_s, us};

fn sci(card: Card, start_nm: [i64; 3]) -> Scientifica {
    Scientifica::new(ScientificaSettings { start_nm, ..ScientificaSettings::patchstar(card) }, 0)
        .unwrap()
}

/// Sends `line` + CR at `t` and returns the reply line, read as soon as its CR has left
/// (or what came within 50 ms).
fn ask(c: &mut Scientifica, t: u64, line: &str) -> String {
    c.receive(t, line.as_bytes());
    c.receive(t, b"\r");
    let mut got = Vec::new();
    for dt in (0..=50_000).step_by(100) {
        got.extend(take(c, t + dt));
        if got.ends_with(b"\r") {
            break;
        }
    }
    String::from_utf8(got).unwrap()
}

/// v2 PatchStar defaults in ticks (0.1 µm): TOP 30000 → 30000 / (2 · 6.4) = 2343.75 µm/s,
/// ACC 500 → 500 · 250 / 6.4 = 19531.25 µm/s².
const V2_SPEED_TICKS_S: f64 = 23_437.5;
const V2_ACCEL_TICKS_S2: f64 = 195_312.5;

#[test]
fn identify_version_and_case_insensitivity() {
    let mut c = sci(Card::V2, [0; 3]);
    assert_eq!(ask(&mut c, 0, "scientifica"), "Y519\r");
    assert_eq!(ask(&mut c, 100_000, "VER"), "2.13\r");
    assert_eq!(ask(&mut c, 200_000, "ver"), "2.13\r");
    let mut c = sci(Card::V3, [0; 3]);
    assert_eq!(ask(&mut c, 0, "VER"), "3.13\r");
}

#[test]
fn position_units_are_ticks_of_the_card() {
    let mut c = sci(Card::V2, [1_000_000, -2_000_000, 300]);
    assert_eq!(ask(&mut c, 0, "POS"), "10000\t-20000\t3\r", "0.1 µm ticks");
    assert_eq!(ask(&mut c, 100_000, "P"), "E,1\r", "a v2 card has no P");
    let mut c = sci(Card::V3, [1_000_000, -2_000_000, 300]);
    assert_eq!(ask(&mut c, 0, "P"), "100000\t-200000\t30\r", "0.01 µm ticks");
    assert_eq!(ask(&mut c, 100_000, "pos"), "100000\t-200000\t30\r");
}

#[test]
fn abs_is_accepted_at_once_and_the_move_runs_on() {
    let mut c = sci(Card::V2, [0; 3]);
    c.receive(0, b"ABS 10000 0 0\r");
    // "A\r" is two bytes at 9600 baud: 2083.3 µs.
    assert_eq!(take(&mut c, 2083), b"A");
    assert_eq!(take(&mut c, 2084), b"\r");
    assert_eq!(ask(&mut c, 100_000, "S"), "1\r", "x moving");
    let x = c.probe_nm().0;
    assert!(x > 0 && x < 1_000_000, "{x}");
}

#[test]
fn s_reads_zero_before_the_stage_has_completely_stopped() {
    let mut c = sci(Card::V2, [0; 3]);
    assert_eq!(ask(&mut c, 0, "ABS 10000 0 0"), "A\r");
    let end = us(trapezoid_s(10_000.0, V2_SPEED_TICKS_S, V2_ACCEL_TICKS_S2));
    let early = end - 30_000; // the PatchStar default early finish
    c.receive(early - 1, b"S\r");
    c.receive(early, b"S\r");
    let x1 = c.probe_nm().0;
    c.poll(end - 5000);
    let x2 = c.probe_nm().0;
    assert!(x1 < x2 && x2 < 1_000_000, "still moving after S = 0: {x1} {x2}");
    assert_eq!(take(&mut c, end - 5000), b"1\r0\r", "busy, then reports finished");
    c.poll(end);
    assert_eq!(c.probe_nm().0, 1_000_000);
}

#[test]
fn the_stage_can_stop_short_of_its_target() {
    let cfg =
        ScientificaSettings { short_stop_ticks: 7, ..ScientificaSettings::patchstar(Card::V2) };
    let mut c = Scientifica::new(cfg, 0).unwrap();
    assert_eq!(ask(&mut c, 0, "ABS 10000 -5000 0"), "A\r");
    assert_eq!(ask(&mut c, 2_000_000, "POS"), "9993\t-4993\t0\r");
}

#[test]
fn stop_answers_a_and_stops_dead() {
    let mut c = sci(Card::V2, [0; 3]);
    assert_eq!(ask(&mut c, 0, "ABS 10000 0 0"), "A\r");
    assert_eq!(ask(&mut c, 200_000, "STOP"), "A\r");
    let x = c.probe_nm().0;
    c.poll(2_000_000);
    assert_eq!(c.probe_nm().0, x);
    assert_eq!(ask(&mut c, 2_000_000, "S"), "0\r");
}

#[test]
fn a_move_while_busy_is_refused_and_unknown_commands_are_errors() {
    let mut c = sci(Card::V2, [0; 3]);
    assert_eq!(ask(&mut c, 0, "ABS 10000 0 0"), "A\r");
    assert_eq!(ask(&mut c, 100_000, "ABS 0 0 0"), "E,3\r");
    assert_eq!(ask(&mut c, 200_000, "INTERRUPT"), "E,1\r");
    assert_eq!(ask(&mut c, 300_000, "ABS 1 x 3"), "E,2\r");
    assert_eq!(ask(&mut c, 400_000, "ZERO"), "E,3\r");
}

#[test]
fn top_and_acc_units_differ_between_v2_and_v3() {
    let mut v2 = sci(Card::V2, [0; 3]);
    let mut v3 = sci(Card::V3, [0; 3]);
    assert_eq!(ask(&mut v2, 0, "TOP"), "30000\r");
    assert_eq!(ask(&mut v2, 100_000, "TOP 500"), "E,2\r", "v2 TOP is 1000..50000");
    assert_eq!(ask(&mut v3, 0, "TOP 500"), "A\r", "v3 TOP is µm/s");
    // 2000 µm/s on both cards: v2 TOP = 2000 · 2 · 6.4 = 25600; v3 TOP = 2000.
    // Acceleration 25000 µm/s²: v2 ACC = 25000 · 6.4 / 250 = 640; v3 ACC = 25000.
    assert_eq!(ask(&mut v2, 200_000, "TOP 25600"), "A\r");
    assert_eq!(ask(&mut v2, 300_000, "ACC 640"), "A\r");
    assert_eq!(ask(&mut v3, 200_000, "TOP 2000"), "A\r");
    assert_eq!(ask(&mut v3, 300_000, "ACC 25000"), "A\r");
    assert_eq!(ask(&mut v2, 1_000_000, "ABS 10000 0 0"), "A\r"); // 1 mm in 0.1 µm ticks
    assert_eq!(ask(&mut v3, 1_000_000, "ABS 100000 0 0"), "A\r"); // 1 mm in 0.01 µm ticks
    let end = 1_000_000 + us(trapezoid_s(1000.0, 2000.0, 25_000.0));
    for c in [&mut v2, &mut v3] {
        c.receive(end - 30_001, b"S\r");
        c.receive(end - 30_000, b"S\r");
        assert_eq!(take(c, end - 20_000), b"1\r0\r");
        c.poll(end);
        assert_eq!(c.probe_nm().0, 1_000_000);
    }
}

#[test]
fn axis_scale_commands_per_card_and_their_effect_on_reported_units() {
    let mut v2 = sci(Card::V2, [1_000_000, 0, 0]);
    assert_eq!(ask(&mut v2, 0, "UUX"), "-6.4\r");
    assert_eq!(ask(&mut v2, 100_000, "USTEP X"), "E,1\r");
    assert_eq!(ask(&mut v2, 200_000, "UUX -3.2"), "A\r");
    assert_eq!(ask(&mut v2, 300_000, "PX"), "20000\r", "half the scale, twice the ticks");
    let mut v3 = sci(Card::V3, [0; 3]);
    assert_eq!(ask(&mut v3, 0, "USTEP X"), "-1600\r");
    assert_eq!(ask(&mut v3, 100_000, "UUX"), "E,1\r");
}

#[test]
fn targets_beyond_the_travel_are_clamped_and_limits_report_the_switch() {
    let mut c = sci(Card::V2, [0; 3]);
    assert_eq!(ask(&mut c, 0, "LIMITS"), "0\r");
    assert_eq!(ask(&mut c, 100_000, "ABS 200000 0 -200000"), "A\r"); // 20 mm: beyond the ±10 mm travel
    assert_eq!(ask(&mut c, 20_000_000, "POS"), "100000\t0\t-100000\r");
    assert_eq!(ask(&mut c, 20_100_000, "LIMITS"), "18\r", "x_high (2) + z_low (16)");
}

#[test]
fn zero_and_set_position_keep_the_stage_where_it_is() {
    let mut c = sci(Card::V2, [500_000, 0, 0]);
    assert_eq!(ask(&mut c, 0, "ZERO"), "A\r");
    assert_eq!(ask(&mut c, 100_000, "POS"), "0\t0\t0\r");
    assert_eq!(ask(&mut c, 200_000, "PY 123"), "A\r");
    assert_eq!(ask(&mut c, 300_000, "PY"), "123\r");
    assert_eq!(c.probe_nm(), (500_000, 0));
}

#[test]
fn replies_leave_at_the_selected_baud_rate() {
    let cfg = ScientificaSettings { baud: 38_400, ..ScientificaSettings::patchstar(Card::V3) };
    let mut c = Scientifica::new(cfg, 0).unwrap();
    c.receive(0, b"VER\r");
    // 5 bytes at 38400 baud: 1302.08 µs.
    assert_eq!(take(&mut c, 1302), b"3.13");
    assert_eq!(take(&mut c, 1303), b"\r");
    c.receive(10_000, b"BAUD 96\r");
    assert_eq!(take(&mut c, 20_000), b"", "no reply to BAUD");
    c.receive(20_000, b"VER\r");
    assert_eq!(take(&mut c, 20_000 + 5208), b"3.13", "now 9600 baud: 5208.3 µs");
}
