//! Emulator of the Sutter MPC-200 controller (ROE-200; MPC-325/365/385 command family).
//!
//! Sources (see the project's controller-protocol notes, section 1): the MPC-200 "USB
//! commands v1.10" sheet and the MPC-325/385 operation manuals (command table, ^C, 'S'
//! delay row), acq4 `SutterMPC200/mpc200.py` (16-µstep rule, 'S' split, stray 'I', measured
//! speeds), pyIVLS `Mpc325` (35 ms pause, 81.25·(V+1) µm/s table), ScanImage `MPC200.m`.
//!
//! Emulated, byte for byte (binary, little-endian, no host terminator, every reply ends in
//! `0D`; 128000 baud 8N1, each reply byte leaves 78.125 µs after the previous one):
//! - `C` → `D x y z 0D` (14 bytes, i32 µsteps of the active drive); `U` → `N n1..n4 0D`;
//!   `K` → `D minBCD majBCD 0D` (firmware ≥ 3) or `D 0D`; `I D` → `D 0D`, or `45 0D` for a
//!   drive not connected (firmware ≥ 1.06; older: `0D`); `F`/`O`/`L m` → `0D`.
//! - `M x y z`: fast move, every axis on its own profile at [`Mpc200Settings::fast_speed_usteps_s`]
//!   (the manual's "stereotypic multi-axis path"; the exact path is not documented, so the
//!   axes move independently, inferred); `0D` at the END of the move.
//! - `S V x y z`: straight line at 81.25·(V+1) µm/s = 1300·(V+1) µsteps/s on the fastest
//!   moving axis (manual and pyIVLS; acq4's measured table disagrees at low V; the manual is
//!   followed). V > 15 is taken as 15 (inferred). `0D` at the end of the move.
//! - The 'S' pause: the packet is accepted if at least [`S_PAUSE_US`] (the manual's 30 ms)
//!   passed between `53` and V (acq4) OR between V and the first position byte (manual,
//!   pyIVLS). Otherwise the controller **crashes** ("MPC200 crashes if the entire packet is
//!   written at once"): it goes silent, ignores all input and never replies, until
//!   [`Mpc200::power_cycle`] (choice).
//! - A move shorter than 16 µsteps on every axis is ignored and NO `0D` is sent.
//! - Targets outside 0..=400000 µsteps are clamped to the travel on each axis and the move
//!   runs to the clamp, with its `0D` (choice; the manual only says never to send them).
//! - While a move runs every byte but `03` is discarded (no position query during a move).
//!   `03` stops the move dead and replies `0D` at once (for 'M' too, per the MPC-325 manual;
//!   the TRIO manual says 'S' only); `03` when idle also replies `0D`.
//! - After an interrupt, the next `C` reply carries a leading `49` ('I') with probability
//!   [`Mpc200Settings::stray_i_chance`], drawn from a [`SimRng`] seeded by `seed`.
//! - `N` (calibrate, firmware > 1.03) drives to the true origin and zeroes the counter
//!   (clearing steps lost to a stall); `H`/`Y` drive to the home/work positions. These
//!   reply `0D` at the end of their motion, whatever their length (inferred).
//! - Up to four drives, each with its own stage; moves and `C` act on the active drive.
//!   Input is ignored for the first second after power-on ([`BOOT_US`]).
//!
//! Not verifiable without the device: the 'M' path and acceleration (no register exists;
//! [`DEFAULT_ACCEL_USTEPS_S2`] is a choice), the streamed data after `O` (not emulated: 'S'
//! behaves as with streaming off), the "V = 13..15 sometimes fail to move" report, junk
//! after an interrupt beyond the stray 'I', and the real crash behaviour.

use super::controller::{VendorController, steps_to_nm, to_i32};
use super::motion::{AxisLimits, Path, Stage};
pub use super::mpc200_rx::S_PAUSE_US;
use super::mpc200_rx::{Mpc200Rx, Packet};
use super::serial::SerialTx;
use crate::error::SimError;
use crate::rng::SimRng;

/// Link rate, bits/s.
pub const BAUD: u32 = 128_000;
/// Size of a microstep, nm (16 µsteps per µm).
pub const NM_PER_USTEP: f64 = 62.5;
/// Travel of each axis, µsteps (0..=this; 25 mm).
pub const TRAVEL_USTEPS: i64 = 400_000;
/// Moves shorter than this on every axis are ignored without a reply, µsteps.
pub const MIN_MOVE_USTEPS: i64 = 16;
/// 'S' speed per speed step: 81.25 µm/s = 1300 µsteps/s; V gives 1300·(V+1).
pub const SPEED_STEP_USTEPS_S: f64 = 1300.0;
/// 'M' speed: acq4's measured 4.65 mm/s, µsteps/s.
pub const FAST_SPEED_USTEPS_S: f64 = 74_400.0;
/// Acceleration, µsteps/s² (10 mm/s²) (inferred: not documented).
pub const DEFAULT_ACCEL_USTEPS_S2: f64 = 160_000.0;
/// Time from power-on to accepting input, µs.
pub const BOOT_US: u64 = 1_000_000;
const CR: u8 = 0x0D;

/// Settings of an emulated MPC-200.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mpc200Settings {
    /// Which of drives 1..4 are connected.
    pub drives: [bool; 4],
    /// The drive carrying the probe (1..4, connected).
    pub probe_drive: u8,
    /// Start position of every drive, µsteps.
    pub start_usteps: [i64; 3],
    /// Firmware version (major, minor), e.g. (3, 15).
    pub firmware: (u8, u8),
    /// Acceleration of every move, µsteps/s² (> 0).
    pub accel_usteps_s2: f64,
    /// Per-axis speed of 'M', 'H', 'Y', 'N' moves, µsteps/s (> 0).
    pub fast_speed_usteps_s: f64,
    /// Probability (0..=1) that the first `C` after an interrupt has a leading 'I'.
    pub stray_i_chance: f64,
    /// Seed of the stray-'I' draws.
    pub seed: u64,
    /// The ROE's Home position, µsteps.
    pub home_usteps: [i64; 3],
    /// The ROE's Work position, µsteps.
    pub work_usteps: [i64; 3],
}

impl Mpc200Settings {
    /// One drive (1) at mid travel, firmware 3.15, no stray 'I'.
    pub const DEFAULT: Self = Self {
        drives: [true, false, false, false],
        probe_drive: 1,
        start_usteps: [200_000; 3],
        firmware: (3, 15),
        accel_usteps_s2: DEFAULT_ACCEL_USTEPS_S2,
        fast_speed_usteps_s: FAST_SPEED_USTEPS_S,
        stray_i_chance: 0.0,
        seed: 0,
        home_usteps: [0; 3],
        work_usteps: [200_000; 3],
    };

    fn validate(&self) -> Result<(), SimError> {
        let bad = |field| Err(SimError::BadConfig { field });
        let probe_ok = (1..=4).contains(&self.probe_drive)
            && self.drives[usize::from(self.probe_drive.max(1)) - 1];
        if !probe_ok {
            return bad("mpc200.probe_drive");
        }
        if !(self.accel_usteps_s2 > 0.0 && self.accel_usteps_s2.is_finite()) {
            return bad("mpc200.accel_usteps_s2");
        }
        if !(self.fast_speed_usteps_s > 0.0 && self.fast_speed_usteps_s.is_finite()) {
            return bad("mpc200.fast_speed_usteps_s");
        }
        if !(0.0..=1.0).contains(&self.stray_i_chance) {
            return bad("mpc200.stray_i_chance");
        }
        Ok(())
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Power {
    Booting { until_us: u64 },
    Ready,
    Crashed,
}

/// What started a move: a packet ('M'/'S': the 16-µstep rule and the travel clamp apply),
/// a stored position ('H'/'Y': clamped), or the calibration ('N': to the true origin).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Packet,
    Goto,
    Calibrate,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Job {
    drive: usize,
    calibrate: bool,
}

/// An emulated MPC-200 on its USB serial link.
#[derive(Debug, Clone)]
pub struct Mpc200 {
    cfg: Mpc200Settings,
    now_us: u64,
    power: Power,
    rx: Mpc200Rx,
    tx: SerialTx,
    stages: [Stage<3>; 4],
    active: usize,
    job: Option<Job>,
    interrupted: bool,
    rng: SimRng,
}

impl Mpc200 {
    /// Powers on at `now_us` (input is accepted from `now_us + BOOT_US`).
    pub fn new(cfg: Mpc200Settings, now_us: u64) -> Result<Self, SimError> {
        cfg.validate()?;
        let mut c = Self {
            cfg,
            now_us,
            power: Power::Ready,
            rx: Mpc200Rx::default(),
            tx: SerialTx::new(BAUD),
            stages: core::array::from_fn(|_| Stage::new(cfg.start_usteps)),
            active: 0,
            job: None,
            interrupted: false,
            rng: SimRng::new(cfg.seed),
        };
        c.power_cycle(now_us);
        Ok(c)
    }

    /// Power-cycles at `now_us`: motion stops, pending replies are lost, the lowest
    /// connected drive is active, input is ignored for [`BOOT_US`]. Positions are kept.
    pub fn power_cycle(&mut self, now_us: u64) {
        self.advance(now_us);
        for s in &mut self.stages {
            s.stop(self.now_us);
        }
        self.tx.clear();
        self.rx.reset();
        self.job = None;
        self.interrupted = false;
        self.active = self.cfg.drives.iter().position(|&d| d).unwrap_or(0);
        self.power = Power::Booting { until_us: self.now_us.saturating_add(BOOT_US) };
    }

    /// The controller crashed (a badly paced 'S' packet) and waits for a power cycle.
    pub fn is_crashed(&self) -> bool {
        self.power == Power::Crashed
    }

    /// Starts or ends a stall of the probe drive at `now_us` (see [`Stage::set_stalled`]).
    pub fn set_stalled(&mut self, now_us: u64, stalled: bool) {
        self.advance(now_us);
        let d = usize::from(self.cfg.probe_drive) - 1;
        self.stages[d].set_stalled(self.now_us, stalled);
    }

    fn advance(&mut self, now_us: u64) {
        self.now_us = self.now_us.max(now_us);
        if let Power::Booting { until_us } = self.power
            && self.now_us >= until_us
        {
            self.power = Power::Ready;
        }
        if let Some(job) = self.job {
            let stage = &mut self.stages[job.drive];
            let end = stage.end_us().unwrap_or(self.now_us);
            if stage.settle(self.now_us) {
                if job.calibrate {
                    stage.set_counter([0; 3]);
                }
                self.job = None;
                self.tx.send(end, &[CR]);
            }
        }
    }

    fn byte(&mut self, b: u8) {
        if self.power != Power::Ready {
            return;
        }
        if self.job.is_some() {
            if b == 0x03 {
                self.interrupt();
            }
            return;
        }
        let Some(packet) = self.rx.push(self.now_us, b) else { return };
        let fast = self.fast_limits();
        match packet {
            Packet::Unpaced => self.power = Power::Crashed,
            Packet::Select(d) => self.select(d),
            Packet::Roe(_) => self.reply(&[CR]),
            Packet::Fast(to) => self.start_move(to, Path::PerAxis, fast, Kind::Packet),
            Packet::Straight { v, xyz } => {
                let speed = SPEED_STEP_USTEPS_S * f64::from(v.min(15) + 1);
                let lim = [AxisLimits { speed_steps_s: speed, ..fast[0] }; 3];
                self.start_move(xyz, Path::Linear, lim, Kind::Packet);
            }
            Packet::Simple(c) => self.command(c),
        }
    }

    fn command(&mut self, b: u8) {
        let fast = self.fast_limits();
        match b {
            b'C' => self.reply_position(),
            b'U' => {
                let d = self.cfg.drives.map(u8::from);
                let n = d.iter().sum();
                self.reply(&[n, d[0], d[1], d[2], d[3], CR]);
            }
            b'K' => {
                let (maj, min) = self.cfg.firmware;
                let d = self.active as u8 + 1;
                if maj >= 3 {
                    self.reply(&[d, bcd(min), bcd(maj), CR]);
                } else {
                    self.reply(&[d, CR]);
                }
            }
            0x03 | b'F' | b'O' => self.reply(&[CR]),
            b'N' => {
                let slip = self.stages[self.active].slip();
                self.start_move(slip.map(|s| -s), Path::PerAxis, fast, Kind::Calibrate);
            }
            b'H' => self.start_move(self.cfg.home_usteps, Path::PerAxis, fast, Kind::Goto),
            b'Y' => self.start_move(self.cfg.work_usteps, Path::PerAxis, fast, Kind::Goto),
            _ => {}
        }
    }

    fn select(&mut self, d: u8) {
        let connected = (1..=4).contains(&d) && self.cfg.drives[usize::from(d) - 1];
        if self.cfg.firmware < (1, 6) {
            if connected {
                self.active = usize::from(d) - 1;
            }
            return self.reply(&[CR]);
        }
        if connected {
            self.active = usize::from(d) - 1;
            self.reply(&[d, CR]);
        } else {
            self.reply(&[b'E', CR]);
        }
    }

    fn fast_limits(&self) -> [AxisLimits; 3] {
        let lim = AxisLimits {
            speed_steps_s: self.cfg.fast_speed_usteps_s,
            accel_steps_s2: self.cfg.accel_usteps_s2,
        };
        [lim; 3]
    }

    /// Starts a move of the active drive (see [`Kind`] for the rules that apply).
    fn start_move(&mut self, to: [i64; 3], path: Path, lim: [AxisLimits; 3], kind: Kind) {
        let calibrate = kind == Kind::Calibrate;
        let to = if calibrate { to } else { to.map(|v| v.clamp(0, TRAVEL_USTEPS)) };
        let stage = &mut self.stages[self.active];
        let cur = stage.counter(self.now_us);
        if kind == Kind::Packet && (0..3).all(|i| (to[i] - cur[i]).abs() < MIN_MOVE_USTEPS) {
            return;
        }
        stage.start(self.now_us, to, path, lim);
        self.job = Some(Job { drive: self.active, calibrate });
        self.advance(self.now_us);
    }

    fn interrupt(&mut self) {
        if let Some(job) = self.job.take() {
            self.stages[job.drive].stop(self.now_us);
            self.interrupted = true;
        }
        self.tx.send(self.now_us, &[CR]);
    }

    fn reply_position(&mut self) {
        let c = self.stages[self.active].counter(self.now_us);
        let mut out = [0u8; 15];
        let mut n = 0;
        if std::mem::take(&mut self.interrupted) && self.rng.chance(self.cfg.stray_i_chance) {
            out[0] = b'I';
            n = 1;
        }
        out[n] = self.active as u8 + 1;
        for (i, v) in c.iter().enumerate() {
            out[n + 1 + 4 * i..n + 5 + 4 * i].copy_from_slice(&to_i32(*v).to_le_bytes());
        }
        out[n + 13] = CR;
        self.reply(&out[..n + 14]);
    }

    fn reply(&mut self, bytes: &[u8]) {
        self.tx.send(self.now_us, bytes);
    }

    fn probe(&self) -> [i64; 3] {
        self.stages[usize::from(self.cfg.probe_drive) - 1].true_pos(self.now_us)
    }
}

fn bcd(v: u8) -> u8 {
    ((v / 10 % 10) << 4) | (v % 10)
}

impl VendorController for Mpc200 {
    fn receive(&mut self, now_us: u64, bytes: &[u8]) {
        self.advance(now_us);
        for &b in bytes {
            self.byte(b);
        }
    }

    fn poll(&mut self, now_us: u64) {
        self.advance(now_us);
    }

    fn transmit(&mut self, now_us: u64, buf: &mut [u8]) -> Option<usize> {
        self.advance(now_us);
        if self.power == Power::Crashed {
            return None;
        }
        self.tx.transmit(self.now_us, buf)
    }

    fn probe_nm(&self) -> (i32, i32) {
        let p = self.probe();
        (steps_to_nm(p[0], NM_PER_USTEP), steps_to_nm(p[1], NM_PER_USTEP))
    }

    fn probe_z_nm(&self) -> i32 {
        steps_to_nm(self.probe()[2], NM_PER_USTEP)
    }

    fn next_deadline_us(&self) -> Option<u64> {
        let boot = match self.power {
            Power::Booting { until_us } => Some(until_us),
            _ => None,
        };
        let job = self.job.and_then(|j| self.stages[j.drive].end_us());
        [self.tx.next_release_us(), job, boot].into_iter().flatten().min()
    }
}
