//! A captured frame (8-bit luma, the driver's stamp, sequence number and the drops before
//! it) and the [`FrameSource`] trait every frame source implements: the V4L2 camera here
//! (feature `v4l`) and the host's replay of rendered or recorded frames
//! (`mesopush_vision::capture::ReplaySource`).

use crate::Error;
use crate::stamp::StampInstant;

/// A frame none of whose pixels is brighter than this is black (lamp off, sensor fault): 8 of
/// 255, about a sensor's black level; a lit plate under the microscope is far brighter.
pub const BLACK_LEVEL: u8 = 8;

/// One captured frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CapturedFrame {
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// 8-bit luma, row-major, `width × height` bytes.
    pub pixels: Vec<u8>,
    /// Capture time on `CLOCK_MONOTONIC`, µs (for a replay: its own time base).
    pub t_capture_us: u64,
    /// Which instant `t_capture_us` marks.
    pub stamp: StampInstant,
    /// The driver's frame sequence number.
    pub sequence: u32,
    /// Frames lost just before this one (gap in the sequence numbers).
    pub dropped_before: u32,
}

impl CapturedFrame {
    /// Whether no pixel is brighter than [`BLACK_LEVEL`].
    pub fn is_black(&self) -> bool {
        is_black(&self.pixels)
    }
}

/// Whether no pixel of `pixels` is brighter than [`BLACK_LEVEL`] (an empty frame is black).
pub fn is_black(pixels: &[u8]) -> bool {
    pixels.iter().all(|&p| p <= BLACK_LEVEL)
}

/// A source of camera frames.
pub trait FrameSource {
    /// Blocks until the next frame; `Ok(None)` when the source has ended.
    fn next_frame(&mut self) -> Result<Option<CapturedFrame>, Error>;

    /// Frames dropped so far.
    fn dropped_total(&self) -> u64;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn black_means_nothing_above_the_black_level() {
        assert!(is_black(&[0, 3, BLACK_LEVEL]));
        assert!(!is_black(&[0, BLACK_LEVEL + 1]));
        assert!(is_black(&[]));
    }
}
