//! Frames: how one message travels over a byte stream.
//!
//! A frame is the postcard encoding of [`Frame`] (sender and receiver sessions, cumulative
//! ack, kind and, for data frames, sequence number and message), followed by the
//! CRC-32/ISO-HDLC of those bytes in little endian, all COBS-stuffed and terminated by one
//! `0x00` delimiter. The decoder is strict: it
//! accepts only the exact bytes the encoder produces (canonical stuffing, matching CRC, no
//! trailing bytes), so a damaged frame is rejected rather than misread.

use crate::error::WireError;
use crate::flash::CRC32;
use crate::max_size::{MaxSize, discriminant_bytes};
use crate::{CtrlToExec, ExecToCtrl, ExecToHost, HostToExec};
use cobs::{EncoderState, PushResult};
use postcard::ser_flavors::crc::CrcModifier;
use postcard::ser_flavors::{Cobs, Slice};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

/// Size of every frame buffer, bytes, delimiter included. All messages fit (checked at
/// compile time below).
pub const FRAME_BUF_LEN: usize = 256;
/// Bytes of CRC-32 appended to each frame body.
pub const CRC_LEN_BYTES: usize = 4;
/// The frame delimiter.
pub const FRAME_DELIMITER: u8 = 0x00;

/// One frame of the reliable link.
///
/// Sessions tell link instances apart across restarts: each instance has a `u16` session id
/// chosen by its owner (e.g. a boot counter), and frames name both the sender's session and
/// the receiver's as last heard, so frames addressed to a previous life are recognised.
/// Sequence numbers count data frames modulo 2^16; `ack` is cumulative.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Frame<M> {
    /// Session of the sending link instance.
    pub sender_session: u16,
    /// Session of the receiving instance as last heard by the sender (`None` before the
    /// sender has heard from it).
    pub receiver_session: Option<u16>,
    /// Next data sequence number the sender expects from the receiver.
    pub ack: u16,
    /// What the frame carries.
    pub kind: FrameKind<M>,
}

/// The kind of a [`Frame`] and its payload.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum FrameKind<M> {
    /// A message with its sequence number.
    Data {
        /// Sequence number of this data frame.
        seq: u16,
        /// The message.
        msg: M,
    },
    /// Acknowledges every data frame before `ack`.
    Ack,
    /// A damaged, out-of-order or misaddressed frame arrived: resend from `ack` on.
    Nack,
}

impl<M> Frame<M> {
    /// The message, if this is a data frame.
    pub fn into_msg(self) -> Option<M> {
        match self.kind {
            FrameKind::Data { msg, .. } => Some(msg),
            FrameKind::Ack | FrameKind::Nack => None,
        }
    }
}

impl<M: MaxSize> MaxSize for FrameKind<M> {
    const MAX_SIZE: usize = discriminant_bytes(3) + u16::MAX_SIZE + M::MAX_SIZE;
}

impl<M: MaxSize> MaxSize for Frame<M> {
    const MAX_SIZE: usize = 2 * u16::MAX_SIZE + <Option<u16>>::MAX_SIZE + FrameKind::<M>::MAX_SIZE;
}

/// Worst-case length of the stuffed frame for a body of `body_len` bytes: the CRC, one COBS
/// code byte plus one per 254 bytes, and the delimiter.
pub const fn stuffed_len_max(body_len: usize) -> usize {
    let raw = body_len + CRC_LEN_BYTES;
    raw + 1 + raw / 254 + 1
}

/// Worst-case length of any frame carrying an `M`, delimiter included.
pub const fn frame_len_max<M: MaxSize>() -> usize {
    stuffed_len_max(Frame::<M>::MAX_SIZE)
}

const _: () = assert!(frame_len_max::<HostToExec>() <= FRAME_BUF_LEN);
const _: () = assert!(frame_len_max::<ExecToHost>() <= FRAME_BUF_LEN);
const _: () = assert!(frame_len_max::<ExecToCtrl>() <= FRAME_BUF_LEN);
const _: () = assert!(frame_len_max::<CtrlToExec>() <= FRAME_BUF_LEN);

/// Compile-time proof, per message type, that its frames fit [`FRAME_BUF_LEN`].
struct FitsFrameBuf<M>(core::marker::PhantomData<M>);

impl<M: MaxSize> FitsFrameBuf<M> {
    const OK: () = assert!(frame_len_max::<M>() <= FRAME_BUF_LEN, "message too large for a frame");
}

/// Encodes `frame` into `buf` and returns the bytes to send, delimiter included.
pub fn encode_frame<'b, M: Serialize + MaxSize>(
    frame: &Frame<M>,
    buf: &'b mut [u8],
) -> Result<&'b [u8], WireError> {
    let () = FitsFrameBuf::<M>::OK;
    let cobs = Cobs::try_new(Slice::new(buf)).map_err(|_| WireError::BufferTooSmall)?;
    let flavor = CrcModifier::new(cobs, CRC32.digest());
    match postcard::serialize_with_flavor(frame, flavor) {
        Ok(bytes) => Ok(bytes),
        Err(postcard::Error::SerializeBufferFull) => Err(WireError::BufferTooSmall),
        Err(_) => Err(WireError::Malformed),
    }
}

/// Decodes one frame. `buf` holds the stuffed bytes, with or without the trailing delimiter,
/// and is unstuffed in place.
pub fn decode_frame<M: DeserializeOwned>(buf: &mut [u8]) -> Result<Frame<M>, WireError> {
    let stuffed_len = match buf.split_last() {
        None => return Err(WireError::EmptyFrame),
        Some((&FRAME_DELIMITER, rest)) => rest.len(),
        Some(_) => buf.len(),
    };
    if buf.len() > FRAME_BUF_LEN {
        return Err(WireError::FrameTooLong { len_bytes: buf.len() });
    }
    if stuffed_len == 0 {
        return Err(WireError::EmptyFrame);
    }
    let stuffed = &mut buf[..stuffed_len];
    if stuffed.contains(&FRAME_DELIMITER) {
        return Err(WireError::BadStuffing);
    }
    let report = cobs::decode_in_place_report(stuffed).map_err(|_| WireError::BadStuffing)?;
    let raw = stuffed.get(..report.dst_used).ok_or(WireError::BadStuffing)?;
    if report.src_used != stuffed_len || canonical_stuffed_len(raw) != stuffed_len {
        return Err(WireError::BadStuffing);
    }
    let Some(body_len) = raw.len().checked_sub(CRC_LEN_BYTES).filter(|&n| n > 0) else {
        return Err(WireError::TooShort { len_bytes: raw.len() });
    };
    let (body, crc_bytes) = raw.split_at(body_len);
    let mut crc_le = [0u8; CRC_LEN_BYTES];
    crc_le.copy_from_slice(crc_bytes);
    let received_crc32 = u32::from_le_bytes(crc_le);
    let computed_crc32 = CRC32.checksum(body);
    if received_crc32 != computed_crc32 {
        return Err(WireError::CrcMismatch { received_crc32, computed_crc32 });
    }
    let (frame, rest) = postcard::take_from_bytes(body).map_err(|_| WireError::Malformed)?;
    if !rest.is_empty() {
        return Err(WireError::TrailingBytes { extra_bytes: rest.len() });
    }
    Ok(frame)
}

/// Length, without delimiter, of the COBS stuffing the encoder produces for `raw`: one code
/// byte up front plus one byte per input byte plus one code byte per completed 254-byte run.
fn canonical_stuffed_len(raw: &[u8]) -> usize {
    let mut state = EncoderState::default();
    let mut len = 1;
    for &byte in raw {
        len += match state.push(byte) {
            PushResult::AddSingle(_) | PushResult::ModifyFromStartAndSkip(_) => 1,
            PushResult::ModifyFromStartAndPushAndSkip(_) => 2,
        };
    }
    len
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unstuffer also accepts a 254-byte zero-free run without its trailing code byte,
    /// a second spelling of the same bytes; the canonical length tells the two apart. (Frames
    /// of today's messages are too short to contain such a run, so this guards future sizes.)
    #[test]
    fn canonical_length_rejects_missing_trailing_code_byte() {
        let raw = [0x5Au8; 254];
        let mut short_spelling = [0x5Au8; 255];
        short_spelling[0] = 0xFF;
        let report = cobs::decode_in_place_report(&mut short_spelling).expect("unstuffs");
        assert_eq!((report.src_used, report.dst_used), (255, 254));
        assert_eq!(&short_spelling[..254], &raw[..]);
        assert_eq!(canonical_stuffed_len(&raw), 256, "encoder adds a trailing 0x01 code byte");
    }

    #[test]
    fn canonical_length_matches_encoder_output() {
        let mut buf = [0u8; FRAME_BUF_LEN];
        for (i, msg) in [[0u8, 0, 0], [1, 0, 2], [1, 2, 3], [0, 9, 0]].iter().enumerate() {
            let kind = FrameKind::Data { seq: i as u16, msg: *msg };
            let frame = Frame { sender_session: 1, receiver_session: None, ack: 0, kind };
            let stuffed = encode_frame(&frame, &mut buf).expect("fits").to_vec();
            let mut raw = stuffed.clone();
            let report = cobs::decode_in_place_report(&mut raw).expect("unstuffs");
            let stuffed_len = stuffed.len() - 1;
            assert_eq!(canonical_stuffed_len(&raw[..report.dst_used]), stuffed_len);
        }
    }

    impl MaxSize for [u8; 3] {
        const MAX_SIZE: usize = 3;
    }
}
