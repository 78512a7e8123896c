//! The one error type of the protocol crate.
//!
//! Every way a frame can fail to encode or decode has its own variant so that a link can tell
//! line noise (checksum, stuffing) from a peer speaking another schema (malformed body). `no_std`
//! rules out `thiserror`, so `Display` is written by hand.

use core::fmt;

/// Why a frame could not be encoded or decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum WireError {
    /// The output buffer cannot hold the encoded frame.
    BufferTooSmall,
    /// The frame is longer than [`crate::FRAME_BUF_LEN`] bytes.
    FrameTooLong {
        /// Length of the offered frame in bytes.
        len_bytes: usize,
    },
    /// There were no bytes between two delimiters.
    EmptyFrame,
    /// The COBS byte stuffing is invalid or not in canonical form.
    BadStuffing,
    /// The unstuffed frame is too short to hold a header and a CRC.
    TooShort {
        /// Unstuffed length in bytes.
        len_bytes: usize,
    },
    /// The CRC-32 carried by the frame does not match its contents.
    CrcMismatch {
        /// CRC-32 found in the frame.
        received_crc32: u32,
        /// CRC-32 computed over the frame contents.
        computed_crc32: u32,
    },
    /// The CRC matched but the body is not a valid message of the expected type
    /// (usually a peer with another schema).
    Malformed,
    /// The body decoded but bytes were left over before the CRC.
    TrailingBytes {
        /// Number of unused bytes.
        extra_bytes: usize,
    },
}

impl fmt::Display for WireError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::BufferTooSmall => write!(f, "output buffer too small for the encoded frame"),
            Self::FrameTooLong { len_bytes } => {
                write!(
                    f,
                    "frame of {len_bytes} bytes exceeds the {} byte limit",
                    crate::FRAME_BUF_LEN
                )
            }
            Self::EmptyFrame => write!(f, "empty frame"),
            Self::BadStuffing => write!(f, "invalid COBS byte stuffing"),
            Self::TooShort { len_bytes } => {
                write!(f, "frame of {len_bytes} bytes is too short for a header and a CRC-32")
            }
            Self::CrcMismatch { received_crc32, computed_crc32 } => write!(
                f,
                "CRC-32 mismatch: frame carries {received_crc32:#010x}, contents give {computed_crc32:#010x}"
            ),
            Self::Malformed => write!(f, "frame body is not a valid message (schema mismatch?)"),
            Self::TrailingBytes { extra_bytes } => {
                write!(f, "{extra_bytes} unused bytes after the message body")
            }
        }
    }
}

impl core::error::Error for WireError {}
