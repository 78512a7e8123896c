//! Sensapex uMp: SMCP v1 datagrams over UDP (one [`Protocol::decode`] call is one datagram,
//! one chunk written is one datagram), big-endian, positions in nm.
//!
//! From Sensapex's public SDK (`smcp1.h`, `libum.c` v1.034) and its Python wrapper
//! (`sensapex-py`); the device side is not published, so the device's ACK, response and
//! notification options follow the SDK's own encoder and decoder:
//! - Frame: 16-byte header (version `0x10`, 0, receiver id, sender id, message id — one per
//!   request, from 1, wrapping —, options u32, type u16, sub-block count u16), then
//!   sub-blocks (data type u16, element count u16, count × 4-byte elements). Frames of
//!   another version, to another receiver, from another device or answering another message
//!   are ignored as the SDK ignores them (no reply, not counted unreadable: a link-local
//!   broadcast domain carries other hosts' and devices' traffic); a frame that is ours but
//!   malformed is [`Reply::Garbled`].
//! - Addresses ([`SensapexSettings`]): the device id (default 1) and this host's own id. The
//!   SDK picks its own id at random among 567..=667; here it is fixed (default `0x0237` =
//!   567, the SDK's example) so runs are reproducible — two hosts on one link need two ids.
//! - Position: GET_POSITIONS (14), options REQ | REQ_ACK | REQ_RESP → a bare ACK first
//!   (skipped), then the response: INT32 × 3 or × 4, nm (1000 units per µm). There is no
//!   busy query: [`Request::Busy`] is a GET_POSITIONS as well (the driver counts a move
//!   arrived once a position is at its target).
//! - Move: GOTO_POS (33), options REQ | REQ_ACK | REQ_NOTIFY, INT32 × 6: x, y, z (z is
//!   ARG_UNDEF `0x7FFFFFFF`, "don't move", when it does not change — the adapter holds z),
//!   w = ARG_UNDEF, the speed, mode 1 (all axes simultaneously); the ACK is
//!   [`Reply::Accepted`] ([`MoveReply::AtOnce`]). The speed argument is shared by all axes
//!   (the SDK: "one speed argument shared by all axis"): it is the fastest axis's speed. So
//!   that a diagonal runs straight — sensapex-py's `linear` moves — a move of two or more
//!   axes also carries the SDK's optional second sub-block of per-axis speeds, exactly as
//!   `um_goto_position_ext` lays it out (x and y always, z when defined; an axis that does
//!   not move gets 1 µm/s, sensapex-py's floor). Speeds are µm/s rounded to the nearest;
//!   below 1 µm/s the SDK sends −nm/s (`calc_speed`), and so does this encoder.
//! - Stop: STOP (1), REQ | REQ_ACK → the ACK is [`Reply::Accepted`].
//! - An ACK or response with the ERROR option is [`Reply::DeviceError`] carrying the options
//!   word (the SDK takes an ACK | ERROR for an ACK: stricter here).
//! - Notifications ([`Protocol::unsolicited`]; NOTIFY option, to this host or to the
//!   control-unit / PC groups 0x1FF, 0x2FF, 0x3FF, as the SDK accepts them):
//!   NOTIFY_POSITION_CHANGED (101) → [`Reply::Position`]; NOTIFY_GOTO_POS_COMPLETED (104) →
//!   [`Reply::Busy`]`(false)` whatever its code (the position read after it decides, so a
//!   failed or stuck drive is a stall, and a lost 104 costs only the next poll).
//!
//! Not verifiable here without the device: the device's options words (inferred from the
//! SDK); whether a firmware without the second sub-block takes the move (the SDK sends it
//! for "uMs or uMp not supporting" it, so it is meant to be ignored there — then a diagonal
//! runs each axis at the fastest axis's speed and bends); that notifications asking for an
//! ACK are answered by nothing here (the adapter only answers requests; the device's
//! retransmissions are duplicates, harmless); that a speed below 1 µm/s works ("speed < 1
//! crashes the uMp", say acq4 and sensapex-py, who clamp at 1 µm/s; the SDK's −nm/s encoding
//! is the newer one). A datagram lost on the link is not retransmitted (the SDK tries three
//! times): a lost request is a silent controller or, for a move, an ignored move at its
//! deadline. The physical travel is not published: the SDK's valid range, −1 mm..=125 mm,
//! bounds targets.

use super::{Decoded, MoveReply, Protocol, Reply, Request, Script, axes, push_chunk};
use heapless::Vec;

/// SMCP version byte.
pub const VERSION: u8 = 0x10;
/// Header length, bytes.
pub const HEADER_LEN: usize = 16;
/// "Axis not moved / unknown".
pub const ARG_UNDEF: i32 = i32::MAX;
/// GOTO_POS mode: all axes simultaneously.
pub const MODE_SIMULTANEOUS: i32 = 1;
/// Targets the SDK accepts, nm (−1000..=125 000 µm).
pub const POSITION_RANGE_NM: (i32, i32) = (-1_000_000, 125_000_000);
/// Speed given to an axis that does not move in a multi-axis move, nm/s.
pub const STILL_AXIS_NM_S: u64 = 1_000;

/// Header option bits.
pub mod opt {
    /// A request (clear in responses).
    pub const REQ: u32 = 0x001;
    /// This frame is an ACK.
    pub const ACK: u32 = 0x002;
    /// This frame is a notification.
    pub const NOTIFY: u32 = 0x004;
    /// The peer reports an error.
    pub const ERROR: u32 = 0x008;
    /// Acknowledge this request.
    pub const REQ_ACK: u32 = 0x010;
    /// Respond to this request.
    pub const REQ_RESP: u32 = 0x020;
    /// Notify when this request completes.
    pub const REQ_NOTIFY: u32 = 0x040;
}

/// Message types used here.
pub mod msg {
    /// Stop.
    pub const STOP: u16 = 1;
    /// Read the positions.
    pub const GET_POSITIONS: u16 = 14;
    /// Drive to a position.
    pub const GOTO_POS: u16 = 33;
    /// Positions pushed by the device.
    pub const NOTIFY_POSITION_CHANGED: u16 = 101;
    /// A GOTO_POS ended.
    pub const NOTIFY_GOTO_POS_COMPLETED: u16 = 104;
}

const UINT32: u16 = 5;
const INT32: u16 = 6;
/// Group receivers the SDK accepts notifications for: all CUs, all PCs, CUs or PCs.
const GROUPS: [u16; 3] = [0x01FF, 0x02FF, 0x03FF];

/// Addresses of a Sensapex link; see [`SensapexSettings::DEFAULT`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SensapexSettings {
    /// The manipulator's device id. Default 1.
    pub device_id: u16,
    /// This host's id (the frames' sender). Default `0x0237`.
    pub own_id: u16,
}

impl SensapexSettings {
    /// The documented defaults.
    pub const DEFAULT: Self = Self { device_id: 1, own_id: 0x0237 };
}

/// The Sensapex protocol state: addresses and the last message id sent.
#[derive(Debug)]
pub struct Sensapex {
    settings: SensapexSettings,
    message_id: u16,
}

/// A received frame's header and body.
#[derive(Debug, Clone, Copy)]
struct Frame<'a> {
    receiver: u16,
    sender: u16,
    message_id: u16,
    options: u32,
    kind: u16,
    sub_blocks: u16,
    body: &'a [u8],
}

fn be16(b: &[u8], at: usize) -> u16 {
    u16::from_be_bytes([b[at], b[at + 1]])
}

fn be32(b: &[u8], at: usize) -> u32 {
    u32::from_be_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

impl<'a> Frame<'a> {
    /// The header of an SMCP v1 datagram; `None` when too short or of another version.
    fn parse(bytes: &'a [u8]) -> Option<Self> {
        if bytes.len() < HEADER_LEN || bytes[0] != VERSION {
            return None;
        }
        Some(Self {
            receiver: be16(bytes, 2),
            sender: be16(bytes, 4),
            message_id: be16(bytes, 6),
            options: be32(bytes, 8),
            kind: be16(bytes, 12),
            sub_blocks: be16(bytes, 14),
            body: &bytes[HEADER_LEN..],
        })
    }

    /// The first sub-block's 32-bit elements (INT32 or UINT32), if it is whole.
    fn elements(&self) -> Option<impl Iterator<Item = u32> + 'a> {
        let body = self.body;
        if self.sub_blocks == 0 || body.len() < 4 || !matches!(be16(body, 0), INT32 | UINT32) {
            return None;
        }
        let count = usize::from(be16(body, 2));
        let data = body.get(4..4 + 4 * count)?;
        Some(data.chunks_exact(4).map(|c| u32::from_be_bytes([c[0], c[1], c[2], c[3]])))
    }

    /// x, y, z of a positions block (× 3 or × 4), nm.
    fn positions(&self) -> Option<[i32; 3]> {
        let mut it = self.elements()?.map(|v| i32::from_be_bytes(v.to_be_bytes()));
        let p = [it.next()?, it.next()?, it.next()?];
        Some(p)
    }
}

/// The SDK's speed argument (`calc_speed`) for `nm_s`: µm/s from 1 µm/s (nearest), −nm/s
/// below (at least 1 nm/s).
pub fn speed_arg(nm_s: u64) -> i32 {
    if nm_s >= 1000 {
        return i32::try_from((nm_s + 500) / 1000).unwrap_or(i32::MAX);
    }
    -i32::try_from(nm_s.max(1)).unwrap_or(999)
}

/// The speed `arg` sets, nm/s.
pub fn speed_arg_nm_s(arg: i32) -> u64 {
    if arg < 0 { u64::from(arg.unsigned_abs()) } else { u64::from(arg.unsigned_abs()) * 1000 }
}

impl Sensapex {
    /// A fresh state with `settings` (no message sent yet).
    pub const fn new(settings: SensapexSettings) -> Self {
        Self { settings, message_id: 0 }
    }

    /// The id of the last request encoded.
    pub fn last_message_id(&self) -> u16 {
        self.message_id
    }

    /// Per-axis speeds of `from → target` at `speed_nm_s` along the line, nm/s (rounded to
    /// the nearest; 0 for an axis that does not move).
    fn axis_speeds_nm_s(from: [i32; 3], target: [i32; 3], speed_nm_s: u32) -> [u64; 3] {
        let d = axes::deltas(from, target);
        let (_, norm) = axes::lengths(from, target);
        core::array::from_fn(|k| {
            let num = u128::from(speed_nm_s) * u128::from(d[k]) + u128::from(norm / 2);
            u64::try_from(num / u128::from(norm.max(1))).unwrap_or(u64::MAX)
        })
    }

    /// GOTO_POS's arguments: the first sub-block, and the per-axis speeds of the second
    /// (empty for a move of one axis).
    pub fn goto_args(from: [i32; 3], target: [i32; 3], speed_nm_s: u32) -> ([i32; 6], Vec<i32, 3>) {
        let d = axes::deltas(from, target);
        let speeds = Self::axis_speeds_nm_s(from, target, speed_nm_s);
        let fastest = speeds.iter().copied().max().unwrap_or(0);
        let z = if d[2] == 0 { ARG_UNDEF } else { target[2] };
        let first = [target[0], target[1], z, ARG_UNDEF, speed_arg(fastest), MODE_SIMULTANEOUS];
        let mut second = Vec::new();
        if d.iter().filter(|&&v| v > 0).count() >= 2 {
            let axes_sent = if z == ARG_UNDEF { 2 } else { 3 };
            for k in 0..axes_sent {
                let nm_s = if d[k] == 0 { STILL_AXIS_NM_S } else { speeds[k] };
                let _ = second.push(speed_arg(nm_s)); // at most 3
            }
        }
        (first, second)
    }

    /// Encodes one request frame of `kind` with `options` and up to two sub-blocks.
    fn frame(&mut self, kind: u16, options: u32, blocks: [&[i32]; 2], script: &mut Script) {
        self.message_id = self.message_id.wrapping_add(1);
        let SensapexSettings { device_id, own_id } = self.settings;
        let sub_blocks = blocks.iter().filter(|b| !b.is_empty()).count();
        let mut out: Vec<u8, { super::CHUNK_LEN }> = Vec::new();
        let mut put = |bytes: &[u8]| {
            let fits = out.extend_from_slice(bytes).is_ok();
            debug_assert!(fits, "SMCP frame longer than CHUNK_LEN");
        };
        put(&[VERSION, 0]);
        put(&device_id.to_be_bytes());
        put(&own_id.to_be_bytes());
        put(&self.message_id.to_be_bytes());
        put(&options.to_be_bytes());
        put(&kind.to_be_bytes());
        put(&u16::try_from(sub_blocks).unwrap_or(0).to_be_bytes());
        for block in blocks.iter().filter(|b| !b.is_empty()) {
            put(&INT32.to_be_bytes());
            put(&u16::try_from(block.len()).unwrap_or(0).to_be_bytes());
            for v in block.iter() {
                put(&v.to_be_bytes());
            }
        }
        push_chunk(script, &out, 0);
    }

    /// The reply in `bytes` to `request`, `None` when the datagram is not its answer.
    fn answer(&self, request: &Request, bytes: &[u8]) -> Option<Reply> {
        let f = Frame::parse(bytes)?;
        let kind = match request {
            Request::MoveTo { .. } => msg::GOTO_POS,
            Request::Stop => msg::STOP,
            Request::Setup(_) | Request::Position | Request::Busy => msg::GET_POSITIONS,
        };
        let ours = f.receiver == self.settings.own_id
            && f.sender == self.settings.device_id
            && f.message_id == self.message_id
            && f.kind == kind;
        if !ours {
            return None;
        }
        if f.options & opt::ERROR != 0 {
            return Some(Reply::DeviceError(f.options));
        }
        match request {
            Request::MoveTo { .. } | Request::Stop => {
                (f.options & opt::ACK != 0).then_some(Reply::Accepted)
            }
            _ if f.options & (opt::ACK | opt::REQ) != 0 => None, // the ACK before the response
            _ => Some(f.positions().map_or(Reply::Garbled, Reply::Position)),
        }
    }
}

impl Protocol for Sensapex {
    const NAME: &'static str = "Sensapex uMp";

    fn setup_steps(&self) -> u8 {
        0
    }

    fn units_per_um(&self) -> u32 {
        1000
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
        let (first, _) = Self::goto_args(from, target, speed_nm_s);
        axes::line_nm_s(from, target, speed_arg_nm_s(first[4]))
    }

    fn travel_units(&self) -> (i32, i32) {
        POSITION_RANGE_NM
    }

    fn reply_timeout_us(&self) -> u64 {
        // sensapex-py opens the SDK with a 200 ms timeout (the SDK's own is 20 ms per try,
        // three tries); nothing is retransmitted here, so the longer one.
        200_000
    }

    fn encode(&mut self, request: &Request, script: &mut Script) {
        match *request {
            Request::Setup(_) | Request::Position | Request::Busy => {
                let options = opt::REQ | opt::REQ_ACK | opt::REQ_RESP;
                self.frame(msg::GET_POSITIONS, options, [&[], &[]], script);
            }
            Request::MoveTo { from, target, speed_nm_s } => {
                let (first, second) = Self::goto_args(from, target, speed_nm_s);
                let options = opt::REQ | opt::REQ_ACK | opt::REQ_NOTIFY;
                self.frame(msg::GOTO_POS, options, [&first, &second], script);
            }
            Request::Stop => self.frame(msg::STOP, opt::REQ | opt::REQ_ACK, [&[], &[]], script),
        }
    }

    fn decode(&mut self, request: &Request, bytes: &[u8]) -> Decoded {
        Decoded { consumed: bytes.len(), reply: self.answer(request, bytes) }
    }

    fn reset_receiver(&mut self) {}

    fn unsolicited(&mut self, bytes: &[u8]) -> Option<Reply> {
        let f = Frame::parse(bytes)?;
        let to_us = f.receiver == self.settings.own_id || GROUPS.contains(&f.receiver);
        if !to_us || f.sender != self.settings.device_id || f.options & opt::NOTIFY == 0 {
            return None;
        }
        match f.kind {
            msg::NOTIFY_POSITION_CHANGED => f.positions().map(Reply::Position),
            msg::NOTIFY_GOTO_POS_COMPLETED => f.elements()?.next().map(|_| Reply::Busy(false)),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn speeds_below_one_um_s_are_sent_as_negative_nm_s() {
        assert_eq!(speed_arg(100_000), 100);
        assert_eq!(speed_arg(1_499), 1);
        assert_eq!(speed_arg(999), -999);
        assert_eq!(speed_arg(0), -1);
        assert_eq!(speed_arg_nm_s(-250), 250);
        assert_eq!(speed_arg_nm_s(3), 3_000);
    }

    #[test]
    fn a_diagonal_carries_per_axis_speeds_a_single_axis_does_not() {
        let (first, second) = Sensapex::goto_args([0; 3], [30_000, 40_000, 0], 100_000);
        assert_eq!(first, [30_000, 40_000, ARG_UNDEF, ARG_UNDEF, 80, 1]);
        assert_eq!(second.as_slice(), &[60, 80]);
        let (first, second) = Sensapex::goto_args([0; 3], [30_000, 0, 0], 100_000);
        assert_eq!(first[4], 100);
        assert!(second.is_empty());
        // A shallow diagonal: y's share is under 1 µm/s.
        let (_, second) = Sensapex::goto_args([0; 3], [100_000, 500, 0], 100_000);
        assert_eq!(second.as_slice(), &[100, -500]);
    }
}
