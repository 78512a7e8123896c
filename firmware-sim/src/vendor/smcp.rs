//! The SMCP1 frame (Sensapex micromanipulator control protocol v1): a 16-byte big-endian
//! header, then sub-blocks of `u16 data_type, u16 count, count × 4-byte big-endian values`.
//!
//! Layout and constants from Sensapex's public SDK header `smcp1.h` (umsdk); see the
//! controller-protocol notes, section 4.2. This module only encodes and decodes; what a
//! device does with a frame is [`super::sensapex`]'s business.

/// Protocol version byte of SMCP1.
pub const VERSION: u8 = 0x10;
/// Header length, bytes.
pub const HEADER_LEN: usize = 16;
/// "Axis not moved / unknown" (`SMCP1_ARG_UNDEF`, INT32_MAX).
pub const ARG_UNDEF: i32 = i32::MAX;
/// Receiver id: all devices.
pub const ALL_DEVICES: u16 = 0x00FF;
/// Receiver id: all PCs.
pub const ALL_PCS: u16 = 0x02FF;
/// Receiver id: everyone.
pub const ALL: u16 = 0x07FF;
/// Sub-block data type UINT32.
pub const DATA_UINT32: u16 = 5;
/// Sub-block data type INT32.
pub const DATA_INT32: u16 = 6;

/// Option bits of the header.
pub mod opt {
    /// The frame is a request (0: a response).
    pub const REQ: u32 = 0x001;
    /// The frame is an ACK.
    pub const ACK: u32 = 0x002;
    /// The frame is a notification.
    pub const NOTIFY: u32 = 0x004;
    /// The frame reports an error.
    pub const ERROR: u32 = 0x008;
    /// An ACK is requested.
    pub const REQ_ACK: u32 = 0x010;
    /// A response is requested.
    pub const REQ_RESP: u32 = 0x020;
    /// A completion notification is requested.
    pub const REQ_NOTIFY: u32 = 0x040;
    /// Replies go to the broadcast address.
    pub const REQ_BCAST: u32 = 0x080;
}

/// Message types used by the emulator.
pub mod kind {
    /// Echo request.
    pub const PING: u16 = 0;
    /// Emergency stop.
    pub const STOP: u16 = 1;
    /// Read positions (nm).
    pub const GET_POSITIONS: u16 = 14;
    /// Write a parameter.
    pub const SET_PARAMETER: u16 = 15;
    /// Read a parameter.
    pub const GET_PARAMETER: u16 = 16;
    /// Read the firmware version.
    pub const GET_VERSION: u16 = 23;
    /// Absolute move.
    pub const GOTO_POS: u16 = 33;
    /// Relative move.
    pub const TAKE_STEP: u16 = 34;
    /// Positions pushed while moving.
    pub const NOTIFY_POSITION_CHANGED: u16 = 101;
    /// Status bits pushed on change.
    pub const NOTIFY_STATUS_CHANGED: u16 = 102;
    /// A GOTO_POS finished (UINT32 code, 0 = OK).
    pub const NOTIFY_GOTO_POS_COMPLETED: u16 = 104;
}

/// The frame header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    /// Protocol version (0x10).
    pub version: u8,
    /// Reserved (0).
    pub extra: u8,
    /// Receiver id.
    pub receiver: u16,
    /// Sender id.
    pub sender: u16,
    /// Per-sender message counter.
    pub message_id: u16,
    /// [`opt`] bits.
    pub options: u32,
    /// Message type ([`kind`]).
    pub kind: u16,
    /// Number of sub-blocks that follow.
    pub sub_blocks: u16,
}

fn be16(b: &[u8], at: usize) -> u16 {
    u16::from_be_bytes([b[at], b[at + 1]])
}

impl Header {
    /// The header at the start of `frame`, if it is long enough.
    pub fn parse(frame: &[u8]) -> Option<Self> {
        if frame.len() < HEADER_LEN {
            return None;
        }
        Some(Self {
            version: frame[0],
            extra: frame[1],
            receiver: be16(frame, 2),
            sender: be16(frame, 4),
            message_id: be16(frame, 6),
            options: u32::from_be_bytes([frame[8], frame[9], frame[10], frame[11]]),
            kind: be16(frame, 12),
            sub_blocks: be16(frame, 14),
        })
    }

    fn write(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&[self.version, self.extra]);
        for v in [self.receiver, self.sender, self.message_id] {
            out.extend_from_slice(&v.to_be_bytes());
        }
        out.extend_from_slice(&self.options.to_be_bytes());
        out.extend_from_slice(&self.kind.to_be_bytes());
        out.extend_from_slice(&self.sub_blocks.to_be_bytes());
    }
}

/// One decoded sub-block.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SubBlock {
    /// Data type (e.g. [`DATA_INT32`]).
    pub data_type: u16,
    /// The elements, as signed 32-bit values.
    pub values: Vec<i32>,
}

/// The sub-blocks of `frame` as its header announces them; `None` when the frame is
/// malformed (truncated, or bytes left over after the last block).
pub fn parse_blocks(frame: &[u8], header: &Header) -> Option<Vec<SubBlock>> {
    let mut at = HEADER_LEN;
    let mut blocks = Vec::new();
    for _ in 0..header.sub_blocks {
        if frame.len() < at + 4 {
            return None;
        }
        let (data_type, count) = (be16(frame, at), usize::from(be16(frame, at + 2)));
        at += 4;
        let end = at.checked_add(count * 4)?;
        let bytes = frame.get(at..end)?;
        let values =
            bytes.chunks_exact(4).map(|c| i32::from_be_bytes([c[0], c[1], c[2], c[3]])).collect();
        blocks.push(SubBlock { data_type, values });
        at = end;
    }
    (at == frame.len()).then_some(blocks)
}

/// A whole frame: `header` (its `sub_blocks` field is set from `blocks`), then each
/// `(data_type, values)` block.
pub fn encode(header: Header, blocks: &[(u16, &[i32])]) -> Vec<u8> {
    let mut out =
        Vec::with_capacity(HEADER_LEN + blocks.iter().map(|b| 4 + 4 * b.1.len()).sum::<usize>());
    let count = u16::try_from(blocks.len()).unwrap_or(u16::MAX);
    Header { sub_blocks: count, ..header }.write(&mut out);
    for (data_type, values) in blocks {
        out.extend_from_slice(&data_type.to_be_bytes());
        let n = u16::try_from(values.len()).unwrap_or(u16::MAX);
        out.extend_from_slice(&n.to_be_bytes());
        for v in values.iter().take(usize::from(n)) {
            out.extend_from_slice(&v.to_be_bytes());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_malformed() {
        let h = Header {
            version: VERSION,
            extra: 0,
            receiver: 1,
            sender: 0x237,
            message_id: 9,
            options: opt::REQ,
            kind: kind::GOTO_POS,
            sub_blocks: 0,
        };
        let f = encode(h, &[(DATA_INT32, &[1, -2]), (DATA_UINT32, &[3])]);
        assert_eq!(f.len(), 16 + 4 + 8 + 4 + 4);
        let back = Header::parse(&f).unwrap();
        assert_eq!(back.sub_blocks, 2);
        let blocks = parse_blocks(&f, &back).unwrap();
        assert_eq!(blocks[0].values, vec![1, -2]);
        assert_eq!(parse_blocks(&f[..f.len() - 1], &back), None);
        let mut long = f.clone();
        long.push(0);
        assert_eq!(parse_blocks(&long, &back), None);
    }
}
