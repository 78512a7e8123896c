//! The camera channel's frame header: how a camera (the firmware simulator's, or a frame
//! grabber's relay) streams frames to the executor's frame source over a byte stream (a
//! Unix socket in the hardware-in-the-loop workflow, `docs/hil.md`).
//!
//! Not a postcard message: frames are large (a 928 × 480 8-bit image is 445 KB) and go over
//! their own stream, so each is a fixed 32-byte little-endian header followed by
//! `width_px × height_px` bytes of 8-bit grey pixels, row-major (none when black):
//!
//! | bytes | field |
//! |---|---|
//! | 0..4 | magic `MPCF` |
//! | 4..6 | `format_version` (u16, [`CAMERA_FORMAT_VERSION`]) |
//! | 6..8 | flags (u16): bit 0 black frame, bit 1 `capture_mono_us` valid |
//! | 8..12 | `frame_seq` (u32): the camera's counter (gaps are dropped frames) |
//! | 12..20 | `capture_mono_us` (u64): the driver's exposure stamp, µs of `CLOCK_MONOTONIC` |
//! | 20..24 | `width_px` (u32) |
//! | 24..28 | `height_px` (u32) |
//! | 28..32 | reserved, 0 |
//!
//! Time domain: `capture_mono_us` is the Linux `CLOCK_MONOTONIC` in µs — the clock V4L2
//! stamps buffers with — shared by every process on one machine; the executor converts it
//! into its own time base (`exec_time_us`) by subtracting its clock's epoch.

/// Header length, bytes.
pub const CAMERA_HEADER_LEN: usize = 32;
/// The header's magic.
pub const CAMERA_MAGIC: [u8; 4] = *b"MPCF";
/// Format version of the header.
pub const CAMERA_FORMAT_VERSION: u16 = 1;
/// Largest image accepted, pixels (a bound for readers: 4096 × 4096).
pub const CAMERA_MAX_PIXELS: u64 = 4096 * 4096;

const FLAG_BLACK: u16 = 1;
const FLAG_STAMP: u16 = 2;

/// One frame's header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CameraFrameHeader {
    /// The camera's frame counter.
    pub frame_seq: u32,
    /// The driver's exposure stamp, µs of `CLOCK_MONOTONIC`, if the camera has one.
    pub capture_mono_us: Option<u64>,
    /// The frame is black (no pixels follow).
    pub black: bool,
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
}

/// Why a header was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CameraHeaderError {
    /// The magic is not `MPCF`.
    BadMagic,
    /// Another format version.
    UnsupportedVersion {
        /// The version found.
        got: u16,
    },
    /// The image is larger than [`CAMERA_MAX_PIXELS`].
    TooLarge {
        /// Width found.
        width_px: u32,
        /// Height found.
        height_px: u32,
    },
}

impl CameraFrameHeader {
    /// Pixel bytes that follow the header.
    pub const fn pixel_len(&self) -> usize {
        if self.black { 0 } else { self.width_px as usize * self.height_px as usize }
    }

    /// The header's bytes.
    pub fn encode(&self) -> [u8; CAMERA_HEADER_LEN] {
        let mut b = [0u8; CAMERA_HEADER_LEN];
        b[0..4].copy_from_slice(&CAMERA_MAGIC);
        b[4..6].copy_from_slice(&CAMERA_FORMAT_VERSION.to_le_bytes());
        let flags = if self.black { FLAG_BLACK } else { 0 }
            | if self.capture_mono_us.is_some() { FLAG_STAMP } else { 0 };
        b[6..8].copy_from_slice(&flags.to_le_bytes());
        b[8..12].copy_from_slice(&self.frame_seq.to_le_bytes());
        b[12..20].copy_from_slice(&self.capture_mono_us.unwrap_or(0).to_le_bytes());
        b[20..24].copy_from_slice(&self.width_px.to_le_bytes());
        b[24..28].copy_from_slice(&self.height_px.to_le_bytes());
        b
    }

    /// Parses a header.
    pub fn decode(b: &[u8; CAMERA_HEADER_LEN]) -> Result<Self, CameraHeaderError> {
        if b[0..4] != CAMERA_MAGIC {
            return Err(CameraHeaderError::BadMagic);
        }
        let u16_at = |i: usize| u16::from_le_bytes([b[i], b[i + 1]]);
        let u32_at = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        let version = u16_at(4);
        if version != CAMERA_FORMAT_VERSION {
            return Err(CameraHeaderError::UnsupportedVersion { got: version });
        }
        let flags = u16_at(6);
        let mut stamp = [0u8; 8];
        stamp.copy_from_slice(&b[12..20]);
        let (width_px, height_px) = (u32_at(20), u32_at(24));
        if u64::from(width_px) * u64::from(height_px) > CAMERA_MAX_PIXELS {
            return Err(CameraHeaderError::TooLarge { width_px, height_px });
        }
        Ok(Self {
            frame_seq: u32_at(8),
            capture_mono_us: (flags & FLAG_STAMP != 0).then(|| u64::from_le_bytes(stamp)),
            black: flags & FLAG_BLACK != 0,
            width_px,
            height_px,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_bytes_are_pinned_and_round_trip() {
        let h = CameraFrameHeader {
            frame_seq: 0x0102_0304,
            capture_mono_us: Some(0x1122_3344_5566_7788),
            black: false,
            width_px: 928,
            height_px: 480,
        };
        let b = h.encode();
        assert_eq!(&b[0..8], b"MPCF\x01\x00\x02\x00");
        assert_eq!(&b[8..12], &[4, 3, 2, 1]);
        assert_eq!(&b[12..20], &[0x88, 0x77, 0x66, 0x55, 0x44, 0x33, 0x22, 0x11]);
        assert_eq!(&b[20..28], &[0xa0, 3, 0, 0, 0xe0, 1, 0, 0]);
        assert_eq!(CameraFrameHeader::decode(&b), Ok(h));
        assert_eq!(h.pixel_len(), 928 * 480);
        let black = CameraFrameHeader { black: true, capture_mono_us: None, ..h };
        assert_eq!(black.pixel_len(), 0);
        assert_eq!(CameraFrameHeader::decode(&black.encode()), Ok(black));
    }

    #[test]
    fn bad_headers_are_refused_with_a_reason() {
        let h = CameraFrameHeader {
            frame_seq: 1,
            capture_mono_us: None,
            black: false,
            width_px: 10,
            height_px: 10,
        };
        let mut b = h.encode();
        b[0] = b'X';
        assert_eq!(CameraFrameHeader::decode(&b), Err(CameraHeaderError::BadMagic));
        let mut b = h.encode();
        b[4] = 9;
        assert_eq!(
            CameraFrameHeader::decode(&b),
            Err(CameraHeaderError::UnsupportedVersion { got: 9 })
        );
        let big = CameraFrameHeader { width_px: 100_000, height_px: 100_000, ..h };
        assert!(matches!(
            CameraFrameHeader::decode(&big.encode()),
            Err(CameraHeaderError::TooLarge { .. })
        ));
    }
}
