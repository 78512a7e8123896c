//! Where frames come from: a small [`FrameSource`] trait with a replaying source (rendered or
//! recorded frames, for tests and the simulator) and, behind the `v4l` cargo feature, a V4L2
//! camera (`capture_v4l`). Every frame carries the driver's timestamp, its sequence number and
//! how many frames were dropped before it (from gaps in the sequence).

use image::GrayImage;

use crate::Error;

/// Which instant of the exposure a timestamp marks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StampInstant {
    /// Start of exposure (the driver says so: `V4L2_BUF_FLAG_TSTAMP_SRC_SOE`).
    StartOfExposure,
    /// End of frame (V4L2's default when the driver says nothing else).
    EndOfFrame,
}

/// One captured frame.
#[derive(Debug, Clone)]
pub struct CapturedFrame {
    /// 8-bit grayscale image.
    pub image: GrayImage,
    /// Capture time on the monotonic clock, µs (`frame_stamp_us`).
    pub t_capture_us: u64,
    /// Which instant `t_capture_us` marks.
    pub stamp: StampInstant,
    /// The driver's frame sequence number.
    pub sequence: u32,
    /// Frames lost just before this one (gap in the sequence numbers).
    pub dropped_before: u32,
}

/// A source of camera frames.
pub trait FrameSource {
    /// Blocks until the next frame; `Ok(None)` when the source has ended.
    fn next_frame(&mut self) -> Result<Option<CapturedFrame>, Error>;

    /// Frames dropped so far.
    fn dropped_total(&self) -> u64;
}

/// Detects dropped frames from gaps in (wrapping, 32-bit) sequence numbers.
#[derive(Debug, Clone, Default)]
pub struct DropCounter {
    last: Option<u32>,
    total: u64,
}

impl DropCounter {
    /// A counter that has seen no frame.
    pub const fn new() -> Self {
        Self { last: None, total: 0 }
    }

    /// Records frame `sequence`; returns how many were skipped since the previous one. A
    /// sequence that goes backwards (driver restart) counts as no drop and restarts the count.
    pub fn observe(&mut self, sequence: u32) -> u32 {
        let gap = match self.last {
            Some(prev) => {
                let step = sequence.wrapping_sub(prev);
                if step == 0 || step > u32::MAX / 2 { 0 } else { step - 1 }
            }
            None => 0,
        };
        self.last = Some(sequence);
        self.total += u64::from(gap);
        gap
    }

    /// Frames dropped so far.
    pub fn total(&self) -> u64 {
        self.total
    }
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
    fn next_frame(&mut self) -> Result<Option<CapturedFrame>, Error> {
        while self.drop_sequences.contains(&self.next_sequence) {
            self.next_sequence += 1;
        }
        let Some(image) = self.frames.get(self.next_index).cloned() else { return Ok(None) };
        let sequence = self.next_sequence;
        self.next_index += 1;
        self.next_sequence += 1;
        Ok(Some(CapturedFrame {
            image,
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
    fn gaps_count_as_drops_and_wrap_around() {
        let mut d = DropCounter::new();
        assert_eq!(d.observe(5), 0);
        assert_eq!(d.observe(6), 0);
        assert_eq!(d.observe(9), 2);
        assert_eq!(d.observe(3), 0, "a restart is not a drop");
        let mut w = DropCounter::new();
        w.observe(u32::MAX - 1);
        assert_eq!(w.observe(1), 2);
        assert_eq!(d.total(), 2);
    }

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
}
