//! Where frames come from: the [`FrameSource`] seam, with a replaying source here (rendered
//! or recorded frames, for tests and the simulator) and, behind the `v4l` cargo feature, a
//! V4L2 camera (`V4l2Source`). Every frame carries its timestamp, which instant of the
//! exposure that marks, its sequence number and how many frames were dropped before it
//! (gaps in the sequence).
//!
//! The frame type, the trait, the drop counter and the V4L2 camera live in
//! `mesopush-capture`, shared with the executor (which must not depend on a host crate); this
//! module re-exports them and adds what only the host needs: the replay and the frame as an
//! [`image::GrayImage`] for the tracker ([`gray_image`]).

use image::GrayImage;

use crate::Error;

pub use mesopush_capture::frame::is_black;
#[cfg(feature = "v4l")]
pub use mesopush_capture::v4l2::V4l2Source;
pub use mesopush_capture::{CapturedFrame, DropCounter, FrameSource, StampInstant};

/// The frame's pixels as an image (no copy); a pixel count that does not match the size is
/// refused naming both.
pub fn gray_image(frame: CapturedFrame) -> Result<GrayImage, Error> {
    let (w, h, n) = (frame.width, frame.height, frame.pixels.len());
    GrayImage::from_raw(w, h, frame.pixels).ok_or_else(|| {
        Error::invalid("captured frame", format!("{n} pixels do not make a {w}×{h} image"))
    })
}

/// Replays frames at a fixed period, as a camera would deliver them; chosen frames can be
/// dropped (their sequence numbers skipped) to exercise drop handling.
#[derive(Debug, Clone)]
pub struct ReplaySource {
    frames: Vec<GrayImage>,
    period_us: u64,
    start_us: u64,
    drop_sequences: Vec<u32>,
    next_sequence: u32,
    next_index: usize,
    drops: DropCounter,
}

impl ReplaySource {
    /// Frames delivered every `period_us` from `start_us`, sequence numbers from 0.
    pub fn new(frames: Vec<GrayImage>, period_us: u64, start_us: u64) -> Result<Self, Error> {
        if period_us == 0 {
            return Err(Error::invalid("replay period_us", "must be > 0"));
        }
        Ok(Self {
            frames,
            period_us,
            start_us,
            drop_sequences: Vec::new(),
            next_sequence: 0,
            next_index: 0,
            drops: DropCounter::new(),
        })
    }

    /// Loses the frames that would carry these sequence numbers (the camera exposed them, the
    /// host never got them).
    pub fn with_drops(mut self, sequences: &[u32]) -> Self {
        self.drop_sequences = sequences.to_vec();
        self
    }
}

impl FrameSource for ReplaySource {
    fn next_frame(&mut self) -> Result<Option<CapturedFrame>, mesopush_capture::Error> {
        while self.drop_sequences.contains(&self.next_sequence) {
            self.next_sequence += 1;
        }
        let Some(image) = self.frames.get(self.next_index) else { return Ok(None) };
        let sequence = self.next_sequence;
        self.next_index += 1;
        self.next_sequence += 1;
        Ok(Some(CapturedFrame {
            width: image.width(),
            height: image.height(),
            pixels: image.as_raw().clone(),
            t_capture_us: self.start_us + u64::from(sequence) * self.period_us,
            stamp: StampInstant::StartOfExposure,
            sequence,
            dropped_before: self.drops.observe(sequence),
        }))
    }

    fn dropped_total(&self) -> u64 {
        self.drops.total()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replay_skips_dropped_sequences_and_reports_them() {
        let frames = vec![GrayImage::new(4, 4); 4];
        let mut src = ReplaySource::new(frames, 33_333, 1_000).unwrap().with_drops(&[1, 2]);
        let a = src.next_frame().unwrap().unwrap();
        let b = src.next_frame().unwrap().unwrap();
        assert_eq!((a.sequence, a.dropped_before, a.t_capture_us), (0, 0, 1_000));
        assert_eq!((b.sequence, b.dropped_before, b.t_capture_us), (3, 2, 1_000 + 3 * 33_333));
        assert_eq!(src.dropped_total(), 2);
        src.next_frame().unwrap().unwrap();
        src.next_frame().unwrap().unwrap();
        assert!(src.next_frame().unwrap().is_none());
        assert!(ReplaySource::new(vec![], 0, 0).is_err());
    }

    #[test]
    fn a_frame_becomes_an_image_only_when_its_size_fits() {
        let mut src = ReplaySource::new(vec![GrayImage::new(3, 2)], 1, 0).unwrap();
        let f = src.next_frame().unwrap().unwrap();
        assert_eq!(gray_image(f.clone()).unwrap().dimensions(), (3, 2));
        let bad = CapturedFrame { pixels: vec![0; 5], ..f };
        let e = gray_image(bad).unwrap_err().to_string();
        assert!(e.contains("5 pixels") && e.contains("3×2"), "{e}");
    }
}
