//! Sutter MP-285: an ASCII command letter with a binary payload and `0D` over RS-232 at
//! 9600 baud, 8N1, little-endian; every reply ends in `0D`.
//!
//! From the public drivers (acq4's `mp285.py` and its Arduino interposer, Micro-Manager's
//! `MP285` adapter with Sutter's error table, ScanImage's `MP285.m`, Theo Lemaire's driver);
//! the official manual was not available:
//! - Start-up: `s\r` → the 32-byte status block and `0D`; STEP_DIV (u16 at offset 24) is the
//!   µsteps per µm (25 until read). Then `a\r` → `0D`: absolute mode, set rather than read
//!   from the status flags, whose REL/ABS bit ScanImage found documented reversed (a stage
//!   left in relative mode by Micro-Manager would otherwise take targets as steps).
//! - `c\r` → x, y, z (i32 µsteps) and `0D`, 13 bytes read by length: the position bytes may
//!   themselves be `0D`.
//! - `V` + u16 + `\r` → `0D`: bit 15 = fine resolution (always used here), bits 0–14 = µm/s,
//!   1..=1310 in fine mode (acq4's and Theo's limit; ScanImage says 1300). Sent only when the
//!   speed changes, as the first chunk of a move (a 10 ms pause after it: its 4 bytes and
//!   its `0D` take 5.2 ms at 9600 baud, and Theo's driver waits 2 ms after every command);
//!   the move's decoder skips its `0D`. Byte order LE as acq4, Theo and ScanImage write it
//!   (Micro-Manager writes it high byte first, which looks like its bug).
//! - `m` + x, y, z + `\r` → `0D` at the END of the move; an error instead is one ASCII code
//!   byte and `0D` ([`Reply::DeviceError`] with that byte: `'0'` serial over-run, `'1'`
//!   frame error, `'2'` buffer over-run, `'4'` bad command, `'8'`/`'*'` move interrupted —
//!   Micro-Manager's table; acq4's bitmask reading of the same byte is not used).
//! - `03` interrupts a move; any `0D`-terminated answer (the interrupted move's error
//!   packet) counts as done.
//!
//! The knob: asked for its position while its knob (ROE) is turned, an MP-285 "will very
//! likely crash" (acq4). So this adapter reads the position only when it needs it — at
//! start-up, at the end of each move, after a stop — never at rest
//! ([`Protocol::idle_polls_safe`] is false), and never during a move (the device takes no
//! command before the move's `0D`). A controller that hung anyway stops answering: the
//! adapter reports a silent controller ([`crate::adapter::AdapterEvent::LinkDown`]), the core
//! stops the trial with "the controller went silent … check the controller's power and
//! cable", and then asks for the position every `idle_poll_us` until it answers again (after
//! the operator has power-cycled it). Do not touch the knob during a trial.
//!
//! Inferred, not verifiable here without the device: that the `V` speed is the fastest
//! axis's (as the MPC-200's is; the adapter checks each move's end, not its duration); the
//! travel of ±12 500 µm about the origin (Theo's bounds); whether `03` alone (acq4) or
//! `03 0D` (Micro-Manager) is needed, and whether an idle MP-285 answers `03` at all; the
//! error packet's framing (`code 0D`; Micro-Manager also accepts `code 0D 0D`, whose second
//! `0D` would be counted unreadable here).

use super::{Decoded, MoveReply, Protocol, Reply, Request, Script, axes, push_chunk};
use heapless::Vec;

/// µsteps per µm until the status block is read (Micro-Manager's default STEP_DIV).
pub const DEFAULT_USTEPS_PER_UM: u32 = 25;
/// Travel about the origin on every axis, µm (Theo Lemaire's bounds; inferred).
pub const TRAVEL_UM: i32 = 12_500;
/// Bit 15 of the `V` word: fine resolution.
pub const FINE: u16 = 0x8000;
/// Fastest speed in fine resolution, µm/s.
pub const FINE_MAX_UM_S: u16 = 1310;
/// Pause after a `V` command before the move's bytes, µs.
pub const V_PAUSE_US: u64 = 10_000;
/// One byte on the line at 9600 baud (10 bits), µs, rounded up.
pub const BYTE_US: u64 = 1_042;
/// Length of the status block's reply, `0D` included.
pub const STATUS_LEN: usize = 33;
/// Offset of STEP_DIV (µsteps per µm) in the status block.
pub const STEP_DIV_AT: usize = 24;
/// Length of the position reply, `0D` included.
pub const POSITION_LEN: usize = 13;
/// [`Reply::DeviceError`] code for a status block whose STEP_DIV is 0 (no ASCII error byte
/// has this value): the stage's scale is unknown, so it is not moved.
pub const STEP_DIV_ZERO: u32 = 0x100;

/// The MP-285 protocol state: scale, speed setting, the reply being received.
#[derive(Debug)]
pub struct Mp285 {
    rx: Vec<u8, STATUS_LEN>,
    usteps_per_um: u32,
    speed_word: Option<u16>,
    skip_crs: u8,
}

impl Default for Mp285 {
    fn default() -> Self {
        Self::new()
    }
}

impl Mp285 {
    /// A fresh state (STEP_DIV not read yet, speed setting unknown).
    pub const fn new() -> Self {
        Self { rx: Vec::new(), usteps_per_um: DEFAULT_USTEPS_PER_UM, speed_word: None, skip_crs: 0 }
    }

    /// The `V` word for `speed_nm_s` along `from → target`: fine resolution, the µm/s the
    /// fastest axis needs, rounded to the nearest and clamped to 1..=1310.
    pub fn speed_word(from: [i32; 3], target: [i32; 3], speed_nm_s: u32) -> u16 {
        let axis_nm_s = axes::fastest_axis_nm_s(from, target, speed_nm_s);
        let um_s = (axis_nm_s + 500) / 1000;
        let um_s = um_s.clamp(1, u64::from(FINE_MAX_UM_S));
        FINE | u16::try_from(um_s).unwrap_or(FINE_MAX_UM_S)
    }

    /// Reads `want` bytes by length; `done` turns them (ending in `0D`) into the reply.
    fn by_length(&mut self, bytes: &[u8], want: usize, done: fn(&mut Self) -> Reply) -> Decoded {
        for (i, &b) in bytes.iter().enumerate() {
            let _ = self.rx.push(b); // cleared at `want` ≤ capacity below
            if self.rx.len() < want {
                continue;
            }
            let reply = if self.rx[want - 1] == 0x0D { done(self) } else { Reply::Garbled };
            self.rx.clear();
            return Decoded { consumed: i + 1, reply: Some(reply) };
        }
        Decoded { consumed: bytes.len(), reply: None }
    }

    fn status_block(&mut self) -> Reply {
        let step_div = u16::from_le_bytes([self.rx[STEP_DIV_AT], self.rx[STEP_DIV_AT + 1]]);
        if step_div == 0 {
            return Reply::DeviceError(STEP_DIV_ZERO);
        }
        self.usteps_per_um = u32::from(step_div);
        Reply::SetupDone
    }

    fn position(&mut self) -> Reply {
        let axis = |k: usize| {
            let b = &self.rx[4 * k..4 * k + 4];
            i32::from_le_bytes([b[0], b[1], b[2], b[3]])
        };
        Reply::Position([axis(0), axis(1), axis(2)])
    }

    /// Reads `0D`-terminated answers: `0D` alone, or an error code byte and `0D`.
    fn terminated(&mut self, request: &Request, bytes: &[u8]) -> Decoded {
        for (i, &b) in bytes.iter().enumerate() {
            if b != 0x0D {
                if self.rx.push(b).is_err() {
                    self.rx.clear(); // junk longer than any answer: wait for its `0D`
                }
                continue;
            }
            let code = match self.rx.as_slice() {
                [] => None,
                [code] => Some(u32::from(*code)),
                _ => Some(u32::MAX),
            };
            self.rx.clear();
            let reply = match (request, code) {
                (Request::Stop, _) => Reply::Accepted,
                (Request::MoveTo { .. }, None) if self.skip_crs > 0 => {
                    self.skip_crs -= 1; // the `V` command's answer
                    continue;
                }
                (Request::MoveTo { .. }, None) => Reply::Arrived,
                (_, None) => Reply::SetupDone,
                (_, Some(u32::MAX)) if !matches!(request, Request::MoveTo { .. }) => Reply::Garbled,
                (_, Some(code)) => {
                    self.speed_word = None; // a refused `V` leaves the setting unknown
                    Reply::DeviceError(code)
                }
            };
            return Decoded { consumed: i + 1, reply: Some(reply) };
        }
        Decoded { consumed: bytes.len(), reply: None }
    }
}

impl Protocol for Mp285 {
    const NAME: &'static str = "Sutter MP-285";

    fn setup_steps(&self) -> u8 {
        2
    }

    fn units_per_um(&self) -> u32 {
        self.usteps_per_um
    }

    fn min_move_units(&self) -> i32 {
        1
    }

    fn move_reply(&self) -> MoveReply {
        MoveReply::AtEnd
    }

    fn poll_while_moving(&self) -> bool {
        false
    }

    fn achieved_speed_nm_s(&self, from: [i32; 3], target: [i32; 3], speed_nm_s: u32) -> u32 {
        let um_s = Self::speed_word(from, target, speed_nm_s) & !FINE;
        axes::line_nm_s(from, target, u64::from(um_s) * 1000)
    }

    fn travel_units(&self) -> (i32, i32) {
        let per = i32::try_from(self.usteps_per_um).unwrap_or(i32::MAX);
        let half = TRAVEL_UM.saturating_mul(per);
        (-half, half)
    }

    fn reply_timeout_us(&self) -> u64 {
        // The longest exchange, `s\r` and its 33 bytes, takes 35 × 1.04 ms = 36.5 ms at
        // 9600 baud; no latency figure is published. 200 ms is over five times that, and a
        // dead line is noticed within two heartbeats of the core's 100 ms silence bound.
        200_000
    }

    fn encode(&mut self, request: &Request, script: &mut Script) {
        self.rx.clear();
        self.skip_crs = 0;
        match *request {
            Request::Setup(0) => push_chunk(script, b"s\r", 0),
            Request::Setup(_) => push_chunk(script, b"a\r", 0),
            Request::Busy | Request::Position => push_chunk(script, b"c\r", 0),
            Request::MoveTo { from, target, speed_nm_s } => {
                let word = Self::speed_word(from, target, speed_nm_s);
                if self.speed_word != Some(word) {
                    let [lo, hi] = word.to_le_bytes();
                    push_chunk(script, &[b'V', lo, hi, b'\r'], V_PAUSE_US);
                    self.speed_word = Some(word);
                    self.skip_crs = 1;
                }
                let mut m = [0u8; 14];
                m[0] = b'm';
                for (k, t) in target.iter().enumerate() {
                    m[1 + 4 * k..5 + 4 * k].copy_from_slice(&t.to_le_bytes());
                }
                m[13] = b'\r';
                push_chunk(script, &m, 0);
            }
            Request::Stop => push_chunk(script, &[0x03], 0),
        }
    }

    fn decode(&mut self, request: &Request, bytes: &[u8]) -> Decoded {
        match request {
            Request::Setup(0) => self.by_length(bytes, STATUS_LEN, Self::status_block),
            Request::Busy | Request::Position => {
                self.by_length(bytes, POSITION_LEN, Self::position)
            }
            Request::Setup(_) | Request::MoveTo { .. } | Request::Stop => {
                self.terminated(request, bytes)
            }
        }
    }

    fn reset_receiver(&mut self) {
        self.rx.clear();
        self.skip_crs = 0;
        self.speed_word = None; // a `V` may or may not have been taken: send it again
    }

    fn idle_polls_safe(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_speed_word_is_fine_and_clamped_for_the_fastest_axis() {
        let o = [0, 0, 0];
        assert_eq!(Mp285::speed_word(o, [2_500, 0, 0], 140_000), 0x8000 | 140);
        assert_eq!(Mp285::speed_word(o, [2_500, 2_500, 0], 141_421), 0x8000 | 100);
        assert_eq!(Mp285::speed_word(o, [2_500, 0, 0], 100), 0x8000 | 1);
        assert_eq!(Mp285::speed_word(o, [2_500, 0, 0], 9_000_000), 0x8000 | 1310);
    }

    #[test]
    fn the_reply_timeout_covers_the_status_block_five_times() {
        let line_us = (2 + STATUS_LEN as u64) * BYTE_US;
        assert!(Mp285::new().reply_timeout_us() > 5 * line_us);
    }
}
