//! Emulator of the Sutter MP-285 controller.
//!
//! Sources (controller-protocol notes, section 2): acq4 `SutterMP285/mp285.py` (commands,
//! status layout `=4B5H2B8H`, `abs` when FLAGS bit 5 is set, the ROE crash warning, stop
//! expecting "move interrupted") and its Arduino interposer `mp285_hack.ino` (payload and
//! reply lengths), Micro-Manager `MP285Ctrl.cpp`/`MP285.h` (Sutter's ASCII error codes,
//! `0D 0A` line ends), ScanImage `MP285.m`, Theo Lemaire's `SutterMP285A`.
//!
//! Emulated (ASCII command letter, binary little-endian payload, `0D`; every reply ends in
//! `0D`; 9600 baud 8N1 by default, so a reply byte leaves 1.0417 ms after the previous one
//! and the 13-byte position reply takes 13.54 ms):
//! - `c 0D` → x y z (i32 µsteps, LE) `0D`; `s 0D` → the 32-byte status block `0D` (STEP_DIV
//!   = 25 at offset 24, STEP_MUL = 40 at 26, XSPEED at 28, VERSION at 30, FLAGS bit 5 set in
//!   absolute mode, FLAGS_2 bit 2 set in fine resolution; other fields 0);
//! - `m x y z 0D` → `0D` at the END of the move (straight line, the speed on the fastest
//!   axis, inferred); in relative mode (`b`) the values are deltas;
//! - `V lo hi 0D` → `0D`: bit 15 = fine (50 µsteps per step) / coarse (10); bits 0–14 µm/s,
//!   clamped to 1..=1310 (fine) or 1..=6550 (coarse) (acq4's limits). Little-endian, as
//!   acq4, ScanImage and Theo write it (Micro-Manager's high-byte-first looks like a bug).
//!   Coarse resolution rounds move targets to 5 µsteps (0.2 µm) (inferred);
//! - `a`/`b`/`o`/`n`/`e` + `0D` → `0D` (absolute / relative / set origin here / refresh /
//!   continue); `r 0D` (soft reset) → no reply, the move is dropped, absolute mode, and
//!   input is ignored for [`RESET_QUIET_US`] (ScanImage waits 0.2 s) (inferred);
//! - `03` during a move stops it dead; the move's reply is the error packet `2A 0D` ('*':
//!   "move interrupted … the value normally returned is '*'", MM's Sutter table; acq4 sees
//!   bit 8 in it) and no other `0D` follows (choice). `03` when idle: no reply (inferred);
//! - errors as one ASCII code + `0D`: `32` ('2', the byte where the CR belongs is not `0D`),
//!   `34` ('4', unknown command letter, answered at its CR). SP over-run and frame errors
//!   cannot happen on an emulated line;
//! - a `0A` or `0D` between commands is ignored (Micro-Manager ends lines with `0D 0A`
//!   and stops with `03 0D`); while a move runs every byte but `03` is discarded (inferred);
//! - **the knob hang:** with [`Mp285::set_knob_in_use`] on, a `c` query hangs the
//!   controller (acq4: "will very likely crash"): the move stops, nothing is answered and
//!   no byte leaves until [`Mp285::power_cycle`].
//!
//! Travel: ±312500 µsteps (±12.5 mm) about the power-on position (inferred from Theo's
//! bounds); targets beyond are clamped (choice). Not verifiable here: the acceleration
//! ([`DEFAULT_ACCEL_USTEPS_S2`] is a choice), the real coarse/fine motion, the meaning of
//! STEP_MUL, what follows an error packet, and whether `03` alone or `03 0D` is needed.

use super::controller::{VendorController, steps_to_nm, to_i32};
use super::motion::{AxisLimits, Path, Stage};
use super::serial::SerialTx;
use crate::error::SimError;

/// Default link rate, bits/s.
pub const DEFAULT_BAUD: u32 = 9600;
/// Microsteps per µm (status field STEP_DIV).
pub const STEP_DIV: u16 = 25;
/// Status field STEP_MUL (MM: "uStep to nm"; meaning uncertain).
pub const STEP_MUL: u16 = 40;
/// Size of a microstep, nm.
pub const NM_PER_USTEP: f64 = 40.0;
/// Highest speed in fine resolution, µm/s.
pub const FINE_MAX_UM_S: u16 = 1310;
/// Highest speed in coarse resolution, µm/s.
pub const COARSE_MAX_UM_S: u16 = 6550;
/// Target granularity in coarse resolution, µsteps.
pub const COARSE_QUANTUM_USTEPS: i64 = 5;
/// Travel either side of the power-on position, µsteps.
pub const TRAVEL_USTEPS: i64 = 312_500;
/// Acceleration, µsteps/s² (10 mm/s²) (inferred).
pub const DEFAULT_ACCEL_USTEPS_S2: f64 = 250_000.0;
/// Input ignored after a soft reset or power cycle, µs.
pub const RESET_QUIET_US: u64 = 200_000;
/// Error code of an interrupted move ('*').
pub const ERR_INTERRUPTED: u8 = b'*';
/// Error code "CR not received" ('2').
pub const ERR_NO_CR: u8 = b'2';
/// Error code "bad command" ('4').
pub const ERR_BAD_COMMAND: u8 = b'4';
const CR: u8 = 0x0D;
const FINE: u16 = 0x8000;

/// Settings of an emulated MP-285.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mp285Settings {
    /// Power-on position, µsteps.
    pub start_usteps: [i64; 3],
    /// Link rate, bits/s (> 0).
    pub baud: u32,
    /// Acceleration, µsteps/s² (> 0).
    pub accel_usteps_s2: f64,
    /// Velocity word at power-on (as `V` sets it).
    pub velocity_word: u16,
    /// Firmware version field (e.g. 313 for 3.13).
    pub version: u16,
}

impl Mp285Settings {
    /// At 0,0,0, 9600 baud, fine 1000 µm/s.
    pub const DEFAULT: Self = Self {
        start_usteps: [0; 3],
        baud: DEFAULT_BAUD,
        accel_usteps_s2: DEFAULT_ACCEL_USTEPS_S2,
        velocity_word: FINE | 1000,
        version: 313,
    };
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rx {
    Idle,
    Cmd { cmd: u8, buf: [u8; 13], len: usize, need: usize },
    Unknown,
}

/// Bytes a command letter takes after itself, its `0D` included; `None`: unknown.
fn payload_len(cmd: u8) -> Option<usize> {
    match cmd {
        b'm' => Some(13),
        b'V' => Some(3),
        b'c' | b's' | b'a' | b'b' | b'o' | b'n' | b'e' | b'r' => Some(1),
        _ => None,
    }
}

/// An emulated MP-285 on its RS-232 link.
#[derive(Debug, Clone)]
pub struct Mp285 {
    cfg: Mp285Settings,
    now_us: u64,
    quiet_until_us: u64,
    hung: bool,
    knob: bool,
    rx: Rx,
    tx: SerialTx,
    stage: Stage<3>,
    origin: [i64; 3],
    relative: bool,
    vword: u16,
    moving: bool,
}

impl Mp285 {
    /// Powered on at `now_us`.
    pub fn new(cfg: Mp285Settings, now_us: u64) -> Result<Self, SimError> {
        if cfg.baud == 0 {
            return Err(SimError::BadConfig { field: "mp285.baud" });
        }
        if !(cfg.accel_usteps_s2 > 0.0 && cfg.accel_usteps_s2.is_finite()) {
            return Err(SimError::BadConfig { field: "mp285.accel_usteps_s2" });
        }
        Ok(Self {
            cfg,
            now_us,
            quiet_until_us: now_us,
            hung: false,
            knob: false,
            rx: Rx::Idle,
            tx: SerialTx::new(cfg.baud),
            stage: Stage::new(cfg.start_usteps),
            origin: [0; 3],
            relative: false,
            vword: cfg.velocity_word,
            moving: false,
        })
    }

    /// The rotary encoder (knob) is being turned: a position query now hangs the controller.
    pub fn set_knob_in_use(&mut self, in_use: bool) {
        self.knob = in_use;
    }

    /// The controller hung (position query with the knob in use).
    pub fn is_hung(&self) -> bool {
        self.hung
    }

    /// Power-cycles at `now_us`: clears a hang, stops motion, drops pending replies,
    /// restores absolute mode and the power-on velocity; input is ignored for
    /// [`RESET_QUIET_US`]. Positions and the origin are kept (inferred).
    pub fn power_cycle(&mut self, now_us: u64) {
        self.advance(now_us);
        self.hung = false;
        self.tx.clear();
        self.soft_reset();
        self.vword = self.cfg.velocity_word;
    }

    /// Starts or ends a stall at `now_us` (see [`Stage::set_stalled`]).
    pub fn set_stalled(&mut self, now_us: u64, stalled: bool) {
        self.advance(now_us);
        self.stage.set_stalled(self.now_us, stalled);
    }

    fn soft_reset(&mut self) {
        self.stage.stop(self.now_us);
        self.moving = false;
        self.relative = false;
        self.rx = Rx::Idle;
        self.quiet_until_us = self.now_us.saturating_add(RESET_QUIET_US);
    }

    fn advance(&mut self, now_us: u64) {
        self.now_us = self.now_us.max(now_us);
        if self.moving {
            let end = self.stage.end_us().unwrap_or(self.now_us);
            if self.stage.settle(self.now_us) {
                self.moving = false;
                self.tx.send(end, &[CR]);
            }
        }
    }

    fn byte(&mut self, b: u8) {
        if self.hung || self.now_us < self.quiet_until_us {
            return;
        }
        if self.moving {
            if b == 0x03 {
                self.stage.stop(self.now_us);
                self.moving = false;
                self.reply(&[ERR_INTERRUPTED, CR]);
            }
            return;
        }
        self.rx = match self.rx {
            Rx::Idle => match (b, payload_len(b)) {
                (0x0A | 0x0D | 0x03, _) => Rx::Idle,
                (_, Some(need)) => Rx::Cmd { cmd: b, buf: [0; 13], len: 0, need },
                (_, None) => Rx::Unknown,
            },
            Rx::Unknown => {
                if b == CR {
                    self.reply(&[ERR_BAD_COMMAND, CR]);
                    Rx::Idle
                } else {
                    Rx::Unknown
                }
            }
            Rx::Cmd { cmd, mut buf, len, need } => {
                buf[len] = b;
                if len + 1 < need {
                    Rx::Cmd { cmd, buf, len: len + 1, need }
                } else {
                    if b == CR {
                        self.execute(cmd, &buf[..len]);
                    } else {
                        self.reply(&[ERR_NO_CR, CR]);
                    }
                    Rx::Idle
                }
            }
        };
    }

    fn execute(&mut self, cmd: u8, payload: &[u8]) {
        match cmd {
            b'c' if self.knob => {
                self.hung = true;
                self.stage.stop(self.now_us);
                self.moving = false;
                self.tx.clear();
            }
            b'c' => {
                let mut out = [0u8; 13];
                for (i, v) in self.position().iter().enumerate() {
                    out[4 * i..4 * i + 4].copy_from_slice(&to_i32(*v).to_le_bytes());
                }
                out[12] = CR;
                self.reply(&out);
            }
            b'm' => self.start_move(payload),
            b'V' => {
                self.vword = u16::from_le_bytes([payload[0], payload[1]]);
                self.reply(&[CR]);
            }
            b's' => {
                let status = self.status();
                self.reply(&status);
            }
            b'r' => self.soft_reset(),
            _ => {
                match cmd {
                    b'a' => self.relative = false,
                    b'b' => self.relative = true,
                    b'o' => self.origin = self.stage.counter(self.now_us),
                    _ => {}
                }
                self.reply(&[CR]);
            }
        }
    }

    /// Position as reported: counter relative to the origin, µsteps.
    fn position(&self) -> [i64; 3] {
        let c = self.stage.counter(self.now_us);
        core::array::from_fn(|i| c[i] - self.origin[i])
    }

    fn start_move(&mut self, payload: &[u8]) {
        let fine = self.vword & FINE != 0;
        let max = if fine { FINE_MAX_UM_S } else { COARSE_MAX_UM_S };
        let um_s = (self.vword & !FINE).clamp(1, max);
        let q = if fine { 1 } else { COARSE_QUANTUM_USTEPS };
        let base = if self.relative { self.position() } else { [0; 3] };
        let to: [i64; 3] = core::array::from_fn(|i| {
            let b = [payload[4 * i], payload[4 * i + 1], payload[4 * i + 2], payload[4 * i + 3]];
            let physical = base[i] + i64::from(i32::from_le_bytes(b)) + self.origin[i];
            let rounded = (physical as f64 / q as f64).round() as i64 * q;
            rounded.clamp(-TRAVEL_USTEPS, TRAVEL_USTEPS)
        });
        let lim = AxisLimits {
            speed_steps_s: f64::from(um_s) * f64::from(STEP_DIV),
            accel_steps_s2: self.cfg.accel_usteps_s2,
        };
        self.stage.start(self.now_us, to, Path::Linear, [lim; 3]);
        self.moving = true;
        self.advance(self.now_us);
    }

    fn status(&self) -> [u8; 33] {
        let mut s = [0u8; 33];
        s[0] = if self.relative { 0 } else { 0x20 };
        s[15] = if self.vword & FINE != 0 { 0x04 } else { 0 };
        for (off, v) in [(24, STEP_DIV), (26, STEP_MUL), (28, self.vword), (30, self.cfg.version)] {
            s[off..off + 2].copy_from_slice(&v.to_le_bytes());
        }
        s[32] = CR;
        s
    }

    fn reply(&mut self, bytes: &[u8]) {
        self.tx.send(self.now_us, bytes);
    }
}

impl VendorController for Mp285 {
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
        self.tx.transmit(self.now_us, buf)
    }

    fn probe_nm(&self) -> (i32, i32) {
        let p = self.stage.true_pos(self.now_us);
        (steps_to_nm(p[0], NM_PER_USTEP), steps_to_nm(p[1], NM_PER_USTEP))
    }

    fn probe_z_nm(&self) -> i32 {
        steps_to_nm(self.stage.true_pos(self.now_us)[2], NM_PER_USTEP)
    }

    fn next_deadline_us(&self) -> Option<u64> {
        let end = if self.moving { self.stage.end_us() } else { None };
        let quiet = (self.now_us < self.quiet_until_us).then_some(self.quiet_until_us);
        [self.tx.next_release_us(), end, quiet].into_iter().flatten().min()
    }
}
