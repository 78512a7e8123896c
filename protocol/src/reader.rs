//! Splits a received byte stream into frames at the `0x00` delimiter.
//!
//! Serial drivers hand over bytes in arbitrary pieces; this fixed-size accumulator collects
//! them until a delimiter and hands out the frame for [`crate::decode_frame`]. A frame longer
//! than the buffer is dropped whole and reported, and reading resumes at the next delimiter,
//! so line noise can never wedge the reader.

use crate::error::WireError;
use crate::frame::{FRAME_BUF_LEN, FRAME_DELIMITER};

/// Byte-stream to frame splitter with an `N`-byte buffer.
#[derive(Debug)]
pub struct FrameReader<const N: usize = FRAME_BUF_LEN> {
    buf: [u8; N],
    len: usize,
    overflowed: bool,
}

impl<const N: usize> Default for FrameReader<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> FrameReader<N> {
    /// An empty reader.
    pub const fn new() -> Self {
        Self { buf: [0; N], len: 0, overflowed: false }
    }

    /// Takes one received byte. At a delimiter ending a non-empty frame, returns the frame's
    /// stuffed bytes (delimiter excluded) or `FrameTooLong` if it did not fit. Runs of
    /// delimiters between frames are ignored.
    pub fn push_byte(&mut self, byte: u8) -> Option<Result<&mut [u8], WireError>> {
        if byte != FRAME_DELIMITER {
            match self.buf.get_mut(self.len) {
                Some(slot) => *slot = byte,
                None => self.overflowed = true,
            }
            self.len = self.len.saturating_add(1);
            return None;
        }
        let len = core::mem::take(&mut self.len);
        if core::mem::take(&mut self.overflowed) {
            // `len` counts the delimiter the sender would have added too.
            return Some(Err(WireError::FrameTooLong { len_bytes: len.saturating_add(1) }));
        }
        if len == 0 {
            return None;
        }
        Some(Ok(&mut self.buf[..len]))
    }

    /// Drops any partial frame (e.g. after the link was reset).
    pub fn clear(&mut self) {
        self.len = 0;
        self.overflowed = false;
    }
}
