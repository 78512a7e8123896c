//! The four emulators behind one `VendorController`: a harness that only jumps from one
//! `next_deadline_us` to the next sees every reply at the time it is due, and the same
//! inputs give the same bytes at the same times (determinism).

mod vendor_util;

use mesopush_firmware_sim::vendor::mpc200::DEFAULT_ACCEL_USTEPS_S2;
use mesopush_firmware_sim::vendor::{
    Card, Mp285, Mp285Settings, Mpc200, Mpc200Settings, Scientifica, ScientificaSettings, Sensapex,
    SensapexSettings, VendorController,
};
use vendor_util::{trapezoid_s, us};

/// Replies with the time each was read.
type Log = Vec<(u64, Vec<u8>)>;

/// Runs `c` from `t0` by deadlines only and returns every (time, reply) until idle.
fn run_by_deadlines(c: &mut dyn VendorController, t0: u64) -> Log {
    let mut out = Vec::new();
    let mut buf = [0u8; 2048];
    let mut t = t0;
    for _ in 0..100_000 {
        while let Some(n) = c.transmit(t, &mut buf) {
            out.push((t, buf[..n].to_vec()));
        }
        match c.next_deadline_us() {
            Some(next) => {
                assert!(next >= t, "deadline {next} before now {t}");
                t = next.max(t + 1);
            }
            None => return out,
        }
    }
    panic!("never went idle");
}

fn emulators() -> Vec<(Box<dyn VendorController>, Vec<u8>)> {
    let mpc = Mpc200::new(Mpc200Settings { start_usteps: [0; 3], ..Mpc200Settings::DEFAULT }, 0);
    let mut m = vec![0x4D];
    for v in [16_000i32, 0, 0] {
        m.extend_from_slice(&v.to_le_bytes());
    }
    let mut mp = vec![0x6D];
    for v in [25_000i32, 0, 0] {
        mp.extend_from_slice(&v.to_le_bytes());
    }
    mp.push(0x0D);
    let sci = Scientifica::new(ScientificaSettings::patchstar(Card::V3), 0);
    let mut goto = vec![0x10, 0, 0, 1, 2, 0x37, 0, 1, 0, 0, 0, 0x51, 0, 0x21, 0, 1, 0, 6, 0, 6];
    for v in [1_000_000i32, 0, 0, i32::MAX, 1000, 1] {
        goto.extend_from_slice(&v.to_be_bytes());
    }
    let ump = Sensapex::new(SensapexSettings { start_nm: [0; 4], ..SensapexSettings::DEFAULT }, 0);
    vec![
        (Box::new(mpc.unwrap()), m),
        (Box::new(Mp285::new(Mp285Settings::DEFAULT, 0).unwrap()), mp),
        (Box::new(sci.unwrap()), b"ABS 100000 0 0\r".to_vec()),
        (Box::new(ump.unwrap()), goto),
    ]
}

#[test]
fn a_deadline_driven_harness_sees_the_move_reply_exactly_when_due() {
    let mut c =
        Mpc200::new(Mpc200Settings { start_usteps: [0; 3], ..Mpc200Settings::DEFAULT }, 0).unwrap();
    let mut m = vec![0x4D];
    for v in [16_000i32, 0, 0] {
        m.extend_from_slice(&v.to_le_bytes());
    }
    let t0 = 1_000_000;
    c.receive(t0, &m);
    let got = run_by_deadlines(&mut c, t0);
    // 'M' runs each axis at the fast speed, 4.65 mm/s = 74400 µsteps/s.
    let end = t0 + us(trapezoid_s(16_000.0, 74_400.0, DEFAULT_ACCEL_USTEPS_S2));
    assert_eq!(got, vec![(end + 79, vec![0x0D])]);
}

#[test]
fn every_emulator_goes_idle_at_the_target_and_replays_identically() {
    let runs: Vec<Vec<Log>> = (0..2)
        .map(|_| {
            emulators()
                .into_iter()
                .map(|(mut c, cmd)| {
                    c.receive(1_000_000, &cmd);
                    let out = run_by_deadlines(c.as_mut(), 1_000_000);
                    assert_eq!(c.probe_nm().0, 1_000_000, "every move goes 1 mm in x");
                    assert!(!out.is_empty());
                    out
                })
                .collect()
        })
        .collect();
    assert_eq!(runs[0], runs[1]);
}
