//! Sutter MPC-200 (and the MPC-325/385 family's ROE-200 command set): binary over a USB
//! serial port at 128000 baud, 8N1, little-endian, every reply ending in `0D`.
//!
//! From the public documentation (Sutter's "MPC-200 USB commands" v1.10 and the MPC-325/385
//! manuals, with acq4's and pyIVLS's drivers for what the manuals leave open):
//! - `C` → drive number, x, y, z (i32 µsteps), `0D`: 14 bytes. After an interrupt a stray
//!   `I` may precede it (acq4 strips it): 15 bytes beginning `49` are read the same.
//! - `S` + speed byte V (0–15) + x, y, z: a straight-line move at 81.25·(V + 1) µm/s for the
//!   fastest-moving axis (the manual's rule; acq4 measured other speeds on one stage, which
//!   is why the adapter verifies each move's end rather than trusting its duration). A plan
//!   speed becomes the nearest setting: 140 µm/s along an axis runs at 162.5 µm/s. The
//!   controller needs a pause inside the packet (acq4: "crashes if the entire packet is
//!   written at once"): `53 V`, 35 ms, then the 12 position bytes, as pyIVLS does on
//!   Sutter's advice. The `0D` comes at the END of the move; nothing but `03` may be sent
//!   before it, so the position is never polled during a move.
//! - A move shorter than 16 µsteps on every axis is ignored with no reply at all: such moves
//!   are never sent (their distance is carried into the next move's absolute target).
//! - `03` interrupts a move, answered `0D`.
//! - 16 µsteps per µm; travel 0..=400 000 µsteps (25 mm); negative targets must not be sent.
//!
//! Not verifiable here without the device: the speed table (the manual's and acq4's measured
//! speeds disagree up to 4× at low V), the exact pause position, whether `03` also stops an
//! `M` move (only `S` is used).

use super::{Decoded, MoveReply, Protocol, Reply, Request, Script, axes, push_chunk};
use heapless::Vec;

/// µsteps per µm.
pub const USTEPS_PER_UM: u32 = 16;
/// Travel, µsteps (25 mm).
pub const TRAVEL_USTEPS: i32 = 400_000;
/// Speed of setting V = 0 for the fastest-moving axis, nm/s; setting V is (V + 1) × this.
pub const SPEED_STEP_NM_S: u64 = 81_250;
/// Pause between `53 V` and the position bytes of an `S` move, µs.
pub const S_PAUSE_US: u64 = 35_000;

/// The MPC-200 protocol state: the reply being received.
#[derive(Debug, Default)]
pub struct Mpc200 {
    rx: Vec<u8, 16>,
}

impl Mpc200 {
    /// A fresh receiver.
    pub const fn new() -> Self {
        Self { rx: Vec::new() }
    }

    /// Speed byte for `speed_nm_s` along the line `from → target`: the setting whose
    /// fastest-axis speed is nearest to what the line speed asks of the fastest axis (ties
    /// to the faster: a quasi-static push does not depend on its speed, while a slower
    /// controller falls behind the plan's schedule), clamped to 0..=15.
    pub fn speed_byte(from: [i32; 3], target: [i32; 3], speed_nm_s: u32) -> u8 {
        if axes::lengths(from, target).1 == 0 {
            return 0;
        }
        let axis_nm_s = axes::fastest_axis_nm_s(from, target, speed_nm_s);
        let settings = (axis_nm_s + SPEED_STEP_NM_S / 2) / SPEED_STEP_NM_S; // nearest multiple
        u8::try_from(settings.clamp(1, 16) - 1).unwrap_or(15)
    }

    fn decode_position(&mut self, bytes: &[u8]) -> Decoded {
        for (i, &b) in bytes.iter().enumerate() {
            let _ = self.rx.push(b); // cleared at 15 below, so never full
            let want = if self.rx[0] == b'I' { 15 } else { 14 };
            if self.rx.len() < want {
                continue;
            }
            let body = &self.rx[want - 14..];
            let reply = if body[13] == 0x0D {
                let axis = |k: usize| {
                    let at = 1 + 4 * k;
                    i32::from_le_bytes([body[at], body[at + 1], body[at + 2], body[at + 3]])
                };
                Reply::Position([axis(0), axis(1), axis(2)])
            } else {
                Reply::Garbled
            };
            self.rx.clear();
            return Decoded { consumed: i + 1, reply: Some(reply) };
        }
        Decoded { consumed: bytes.len(), reply: None }
    }
}

impl Protocol for Mpc200 {
    const NAME: &'static str = "Sutter MPC-200";

    fn setup_steps(&self) -> u8 {
        0
    }

    fn units_per_um(&self) -> u32 {
        USTEPS_PER_UM
    }

    fn min_move_units(&self) -> i32 {
        16
    }

    fn move_reply(&self) -> MoveReply {
        MoveReply::AtEnd
    }

    fn poll_while_moving(&self) -> bool {
        false
    }

    fn achieved_speed_nm_s(&self, from: [i32; 3], target: [i32; 3], speed_nm_s: u32) -> u32 {
        let v = Self::speed_byte(from, target, speed_nm_s);
        axes::line_nm_s(from, target, SPEED_STEP_NM_S * (u64::from(v) + 1))
    }

    fn travel_units(&self) -> (i32, i32) {
        (0, TRAVEL_USTEPS)
    }

    fn reply_timeout_us(&self) -> u64 {
        // 15 bytes at 128 kBd take 1.2 ms; acq4 allows 2 s. 200 ms: a dead line is noticed
        // within two heartbeats of the core's 100 ms silence bound.
        200_000
    }

    fn encode(&mut self, request: &Request, script: &mut Script) {
        self.rx.clear();
        match *request {
            Request::Setup(_) | Request::Busy | Request::Position => push_chunk(script, b"C", 0),
            Request::MoveTo { from, target, speed_nm_s } => {
                let v = Self::speed_byte(from, target, speed_nm_s);
                push_chunk(script, &[b'S', v], S_PAUSE_US);
                let mut xyz = [0u8; 12];
                for (k, t) in target.iter().enumerate() {
                    xyz[4 * k..4 * k + 4].copy_from_slice(&t.to_le_bytes());
                }
                push_chunk(script, &xyz, 0);
            }
            Request::Stop => push_chunk(script, &[0x03], 0),
        }
    }

    fn decode(&mut self, request: &Request, bytes: &[u8]) -> Decoded {
        match request {
            Request::Setup(_) | Request::Busy | Request::Position => self.decode_position(bytes),
            Request::MoveTo { .. } | Request::Stop => {
                let Some(i) = bytes.iter().position(|&b| b == 0x0D) else {
                    return Decoded { consumed: bytes.len(), reply: None };
                };
                let reply =
                    if matches!(request, Request::Stop) { Reply::Accepted } else { Reply::Arrived };
                Decoded { consumed: i + 1, reply: Some(reply) }
            }
        }
    }

    fn reset_receiver(&mut self) {
        self.rx.clear();
    }
}
