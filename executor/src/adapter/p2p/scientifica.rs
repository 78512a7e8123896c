//! Scientifica PatchStar, MicroStar, SliceScope… ("LinLab" command set): ASCII lines ending
//! `\r` over a USB serial port (9600 or 38400 baud, chosen by the serial shell), every reply a
//! line ending `\r`.
//!
//! From the public drivers (acq4's `scientifica.py`, Micro-Manager's `Scientifica` adapter,
//! ScanImage's `LinearStageController.m`, T. v. d. Burgt's PatchStar driver); Scientifica's
//! own command reference was not available:
//! - Start-up: `VER\r` → e.g. `2.21\r` / `3.12\r`. The integer part selects the motion card,
//!   never assumed (acq4 refuses a card other than the configured one "to avoid possible
//!   device damage": speeds of one card mean other speeds on the other): 2 → 10 ticks/µm,
//!   position `POS`, speeds in the card's units; 3 → 100 ticks/µm, position `P`, speeds in
//!   µm/s. Any other answer is [`Reply::DeviceError`] (code: the integer part, or
//!   [`UNREADABLE`]) and the adapter never moves the stage (its set-up is not done).
//!   Micro-Manager picks the card by baud rate instead; `VER` is what acq4 trusts.
//! - v2 only, step 1: `UUX\r` → the x axis's user-unit scale, e.g. `-6.4`; `TOP` on v2 is
//!   µm/s × 2 × |UU|, 1000..=50000. Zero or unreadable → [`Reply::DeviceError`]`(`[`UNREADABLE`]`)`.
//! - Position → `x\ty\tz\r`, signed ticks.
//! - A move: `TOP <v>\r` → `A\r` (only when the speed changes; a 25 ms pause follows it:
//!   its line and answer take 12.5 ms at 9600 baud), then `ABS x y z\r` → `A\r` at ONCE
//!   ([`MoveReply::AtOnce`]); `E,<n>\r` (Micro-Manager also saw `E <n>`) is
//!   [`Reply::DeviceError`]`(n)`. The move's decoder skips the `TOP` answer.
//! - Busy: `S\r` → `0\r` at rest, non-zero while moving (only its leading integer is read).
//! - Stop: `STOP\r` → `A\r`.
//! - "Sometimes devices report they are finished moving before they have completely stopped"
//!   (acq4): the adapter does not trust `S` alone — a move is done only once a position read
//!   after it is within `arrive_tolerance_nm` of its target, and until the move's deadline a
//!   short position means "poll on" (the driver's rule for moves that answer at once).
//!
//! Inferred, not verifiable here without the device: that `TOP` limits the fastest axis (the
//! opposite reading, the speed along the line, makes diagonal moves up to √2 slower, inside
//! the 150 % deadline); that `UUX` stands for all three axes (`TOP` is one value); the v3
//! speed range (not in the sources: 1..=50000 µm/s is sent, the card clamps); the travel
//! (not in the sources: ±25 mm about the zero bounds only nonsense targets, the card's limit
//! switches end real overtravel). `FIRST` and `ACC` are left as the card has them.

use super::{Decoded, MoveReply, Protocol, Reply, Request, Script, axes, push_chunk};
use core::fmt::Write as _;
use heapless::{String, Vec};

/// [`Reply::DeviceError`] code of an answer that could not be read as a version or a scale.
pub const UNREADABLE: u32 = u32::MAX;
/// Pause after a `TOP` command before the `ABS` line, µs.
pub const TOP_PAUSE_US: u64 = 25_000;
/// v2 cards' `TOP` range (card units).
pub const V2_TOP: (u64, u64) = (1_000, 50_000);
/// The `TOP` range sent to v3 cards, µm/s (their range is not documented).
pub const V3_TOP: (u64, u64) = (1, 50_000);
/// Travel bound about the zero on every axis, µm (inferred, see the module doc).
pub const TRAVEL_UM: i32 = 25_000;

/// Longest reply line read (three signed i32 and separators fit).
const LINE: usize = 40;

/// The Scientifica protocol state: the card, the speed setting, the line being received.
#[derive(Debug, Default)]
pub struct Scientifica {
    card: Option<u8>,
    uu_milli: u64,
    top: Option<u64>,
    skip_lines: u8,
    rx: Vec<u8, LINE>,
    overlong: bool,
}

impl Scientifica {
    /// A fresh state (card not identified yet).
    pub const fn new() -> Self {
        Self { card: None, uu_milli: 0, top: None, skip_lines: 0, rx: Vec::new(), overlong: false }
    }

    /// The motion card's generation read from `VER` (2 or 3), once read.
    pub fn card(&self) -> Option<u8> {
        self.card
    }

    /// The `TOP` value for `speed_nm_s` along `from → target` on this card: the fastest
    /// axis's speed in the card's units, rounded to the nearest and clamped to its range.
    pub fn top(&self, from: [i32; 3], target: [i32; 3], speed_nm_s: u32) -> u64 {
        let axis_nm_s = axes::fastest_axis_nm_s(from, target, speed_nm_s);
        if self.card == Some(3) {
            return ((axis_nm_s + 500) / 1000).clamp(V3_TOP.0, V3_TOP.1);
        }
        // µm/s × 2 × |UU| = nm/s × 2 × (UU × 1000) / 10⁶.
        let top = (u128::from(axis_nm_s) * 2 * u128::from(self.uu_milli) + 500_000) / 1_000_000;
        u64::try_from(top).unwrap_or(u64::MAX).clamp(V2_TOP.0, V2_TOP.1)
    }

    /// The fastest axis's speed that `top` sets, nm/s.
    fn top_axis_nm_s(&self, top: u64) -> u64 {
        if self.card == Some(3) {
            return top * 1000;
        }
        top * 1_000_000 / (2 * self.uu_milli.max(1))
    }

    fn position_command(&self) -> &'static [u8] {
        if self.card == Some(3) { b"P\r" } else { b"POS\r" }
    }

    /// The answer to `request` in the complete line `line`; `None` to read the next line.
    fn answer(&mut self, request: &Request, line: &str) -> Option<Reply> {
        if let Some(code) = error_code(line) {
            self.top = None; // a refused `TOP` leaves the setting unknown
            return Some(Reply::DeviceError(code));
        }
        let reply = match request {
            Request::Setup(0) => self.version(line),
            Request::Setup(_) => self.scale(line),
            Request::Position => position(line),
            Request::Busy => busy(line),
            Request::MoveTo { .. } if line == "A" && self.skip_lines > 0 => {
                self.skip_lines -= 1; // the `TOP` answer
                return None;
            }
            Request::MoveTo { .. } | Request::Stop if line == "A" => Reply::Accepted,
            Request::MoveTo { .. } | Request::Stop => Reply::Garbled,
        };
        Some(reply)
    }

    fn version(&mut self, line: &str) -> Reply {
        let major = line.split('.').next().and_then(|m| m.trim().parse::<u32>().ok());
        match major {
            Some(2) => self.card = Some(2),
            Some(3) => self.card = Some(3),
            Some(other) => return Reply::DeviceError(other),
            None => return Reply::DeviceError(UNREADABLE),
        }
        Reply::SetupDone
    }

    fn scale(&mut self, line: &str) -> Reply {
        match parse_milli(line) {
            Some(uu) if uu != 0 => {
                self.uu_milli = uu.unsigned_abs();
                Reply::SetupDone
            }
            _ => Reply::DeviceError(UNREADABLE),
        }
    }
}

/// `E,<n>` or `E <n>` → `n` (0 when no number follows).
fn error_code(line: &str) -> Option<u32> {
    let rest = line.strip_prefix('E').or_else(|| line.strip_prefix('e'))?;
    let rest = rest.trim_start_matches([',', ' ']);
    Some(rest.trim().parse().unwrap_or(0))
}

/// `x\ty\tz` (TABs, or spaces) → a position.
fn position(line: &str) -> Reply {
    let mut fields = line.split(['\t', ' ']).filter(|f| !f.is_empty());
    let mut p = [0i32; 3];
    for v in &mut p {
        match fields.next().map(str::parse::<i32>) {
            Some(Ok(n)) => *v = n,
            _ => return Reply::Garbled,
        }
    }
    if fields.next().is_some() { Reply::Garbled } else { Reply::Position(p) }
}

/// `S`'s answer: its leading integer, 0 at rest.
fn busy(line: &str) -> Reply {
    let digits = line.trim_start().bytes().take_while(u8::is_ascii_digit).count();
    match line.trim_start()[..digits].parse::<u64>() {
        Ok(n) => Reply::Busy(n != 0),
        Err(_) => Reply::Garbled,
    }
}

/// A decimal such as `-6.4` in thousandths (`-6400`); further digits are dropped.
fn parse_milli(s: &str) -> Option<i64> {
    let s = s.trim();
    let (negative, s) = match s.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, s.strip_prefix('+').unwrap_or(s)),
    };
    let (int, frac) = s.split_once('.').unwrap_or((s, ""));
    if int.is_empty() && frac.is_empty() {
        return None;
    }
    let whole: i64 = if int.is_empty() { 0 } else { int.parse().ok()? };
    let mut milli = whole.checked_mul(1000)?;
    for (i, c) in frac.bytes().enumerate() {
        let digit = i64::from(c.checked_sub(b'0').filter(|d| *d <= 9)?);
        if let Some(scale) = [100, 10, 1].get(i) {
            milli += digit * scale;
        }
    }
    Some(if negative { -milli } else { milli })
}

impl Protocol for Scientifica {
    const NAME: &'static str = "Scientifica LinLab";

    fn setup_steps(&self) -> u8 {
        if self.card == Some(2) { 2 } else { 1 }
    }

    fn units_per_um(&self) -> u32 {
        if self.card == Some(3) { 100 } else { 10 }
    }

    fn min_move_units(&self) -> i32 {
        1
    }

    fn move_reply(&self) -> MoveReply {
        MoveReply::AtOnce
    }

    fn poll_while_moving(&self) -> bool {
        true
    }

    fn achieved_speed_nm_s(&self, from: [i32; 3], target: [i32; 3], speed_nm_s: u32) -> u32 {
        let top = self.top(from, target, speed_nm_s);
        axes::line_nm_s(from, target, self.top_axis_nm_s(top))
    }

    fn travel_units(&self) -> (i32, i32) {
        let per = i32::try_from(self.units_per_um()).unwrap_or(i32::MAX);
        let half = TRAVEL_UM.saturating_mul(per);
        (-half, half)
    }

    fn reply_timeout_us(&self) -> u64 {
        // The longest exchange, `POS\r` and a 36-character position line, takes 42 ms at
        // 9600 baud; no latency figure is published (acq4 allows 5 s). 200 ms: a dead line is
        // noticed within two heartbeats of the core's 100 ms silence bound.
        200_000
    }

    fn encode(&mut self, request: &Request, script: &mut Script) {
        self.reset_line();
        self.skip_lines = 0;
        match *request {
            Request::Setup(0) => push_chunk(script, b"VER\r", 0),
            Request::Setup(_) => push_chunk(script, b"UUX\r", 0),
            Request::Position => push_chunk(script, self.position_command(), 0),
            Request::Busy => push_chunk(script, b"S\r", 0),
            Request::MoveTo { from, target, speed_nm_s } => {
                let top = self.top(from, target, speed_nm_s);
                let mut line: String<{ super::CHUNK_LEN }> = String::new();
                if self.top != Some(top) {
                    let _ = write!(line, "TOP {top}\r"); // ≤ 26 characters
                    push_chunk(script, line.as_bytes(), TOP_PAUSE_US);
                    self.top = Some(top);
                    self.skip_lines = 1;
                    line.clear();
                }
                let [x, y, z] = target;
                let _ = write!(line, "ABS {x} {y} {z}\r"); // ≤ 40 characters
                push_chunk(script, line.as_bytes(), 0);
            }
            Request::Stop => push_chunk(script, b"STOP\r", 0),
        }
    }

    fn decode(&mut self, request: &Request, bytes: &[u8]) -> Decoded {
        for (i, &b) in bytes.iter().enumerate() {
            match b {
                b'\r' => {}
                b'\n' => continue, // not sent by the cards; tolerated
                _ => {
                    self.overlong |= self.rx.push(b).is_err();
                    continue;
                }
            }
            let raw = core::mem::take(&mut self.rx);
            let overlong = core::mem::replace(&mut self.overlong, false);
            let reply = match core::str::from_utf8(&raw) {
                Ok(_) if overlong => Some(Reply::Garbled),
                Ok(line) if line.trim().is_empty() => None, // a stray `\r`
                Ok(line) => self.answer(request, line.trim()),
                Err(_) => Some(Reply::Garbled),
            };
            if let Some(reply) = reply {
                return Decoded { consumed: i + 1, reply: Some(reply) };
            }
        }
        Decoded { consumed: bytes.len(), reply: None }
    }

    fn reset_receiver(&mut self) {
        self.reset_line();
        self.skip_lines = 0;
        self.top = None; // a `TOP` may or may not have been taken: send it again
    }
}

impl Scientifica {
    fn reset_line(&mut self) {
        self.rx.clear();
        self.overlong = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimals_read_in_thousandths() {
        assert_eq!(parse_milli("-6.4"), Some(-6_400));
        assert_eq!(parse_milli("-4.032"), Some(-4_032));
        assert_eq!(parse_milli("5.12"), Some(5_120));
        assert_eq!(parse_milli("1600"), Some(1_600_000));
        assert_eq!(parse_milli("0.5"), Some(500));
        assert_eq!(parse_milli("x"), None);
        assert_eq!(parse_milli("-"), None);
    }

    #[test]
    fn replies_read_as_documented() {
        assert_eq!(position("-12\t34\t0"), Reply::Position([-12, 34, 0]));
        assert_eq!(position("1\t2"), Reply::Garbled);
        assert_eq!(busy("0"), Reply::Busy(false));
        assert_eq!(busy("5 2"), Reply::Busy(true));
        assert_eq!(busy("?"), Reply::Garbled);
        assert_eq!(error_code("E,3"), Some(3));
        assert_eq!(error_code("E 7"), Some(7));
        assert_eq!(error_code("A"), None);
    }

    #[test]
    fn top_on_a_v2_card_is_twice_the_speed_times_the_scale() {
        let s = Scientifica { card: Some(2), uu_milli: 6_400, ..Scientifica::new() };
        let o = [0, 0, 0];
        assert_eq!(s.top(o, [1_000, 0, 0], 100_000), 1_280);
        assert_eq!(s.top(o, [1_000, 0, 0], 10_000), 1_000, "clamped to the card's range");
        assert_eq!(s.achieved_speed_nm_s(o, [1_000, 0, 0], 100_000), 100_000);
        let v3 = Scientifica { card: Some(3), ..Scientifica::new() };
        assert_eq!(v3.top(o, [1_000, 0, 0], 100_400), 100);
    }
}
