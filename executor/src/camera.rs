//! Camera frame stamping: time base, probe position at exposure, dropped-frame check.
//!
//! Time base: `frame_stamp_us` is in the executor's clock. When the frame source has a
//! driver timestamp (already converted to the executor's clock by the source, e.g. V4L2's
//! monotonic buffer time) it is used; otherwise the frame's arrival time (`now_us` of the
//! input) is used, which is later than the exposure by the transfer latency. Which one was
//! used is reported in [`StampedFrame::source`].
//!
//! Drop check: frames carry the camera's counter `frame_seq`; a jump of more than one means
//! frames were dropped (counted), a repeat or step back is reported as out of order and the
//! expected counter restarts from it (a camera restart).

use mesopush_protocol::host::FrameStamp;

/// A frame as the frame source delivers it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CameraFrame {
    /// The camera's frame counter.
    pub frame_seq: u32,
    /// Exposure time from the driver, µs in the executor's clock, if the source has one.
    pub driver_stamp_us: Option<u64>,
    /// The frame is all black (lamp off, sensor fault); it is stamped but flagged.
    pub black: bool,
}

/// Which clock reading a stamp came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StampSource {
    /// The driver's exposure timestamp.
    Driver,
    /// Arrival at the executor (no driver timestamp).
    Arrival,
}

/// Continuity of the frame counter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeqCheck {
    /// First frame, or exactly one after the previous.
    InOrder,
    /// `dropped` frames are missing before this one.
    Gap {
        /// Frames missing.
        dropped: u32,
    },
    /// The counter repeated or went back (camera restart); counting restarts here.
    OutOfOrder,
}

/// Where a frame's probe position came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PositionSource {
    /// Interpolated between the two controller position reports around the exposure.
    Interpolated,
    /// The commanded position from the in-flight setpoint schedule (exposure after the
    /// latest report while a trial runs).
    Scheduled,
    /// The latest position report (nothing better available).
    LatestReport,
    /// No position known yet (reported as 0, 0).
    Unknown,
}

/// A stamped frame, for the host and the recorder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StampedFrame {
    /// The wire stamp (time, sequence, probe position).
    pub stamp: FrameStamp,
    /// Where the time came from.
    pub source: StampSource,
    /// Counter continuity.
    pub seq: SeqCheck,
    /// The frame was black.
    pub black: bool,
    /// Where the probe position came from.
    pub position: PositionSource,
}

/// Counter state and totals.
#[derive(Debug, Default, Clone, Copy)]
pub struct FrameStamper {
    expected_seq: Option<u32>,
    /// Frames stamped.
    pub frames: u64,
    /// Frames found missing from counter gaps.
    pub dropped: u64,
    /// Black frames seen.
    pub black: u64,
}

impl FrameStamper {
    /// No frame seen yet.
    pub const fn new() -> Self {
        Self { expected_seq: None, frames: 0, dropped: 0, black: 0 }
    }

    /// The exposure time of `frame` arriving at `now_us`, and its source.
    pub fn stamp_time(frame: &CameraFrame, now_us: u64) -> (u64, StampSource) {
        match frame.driver_stamp_us {
            Some(t) => (t, StampSource::Driver),
            None => (now_us, StampSource::Arrival),
        }
    }

    /// Stamps `frame` with the probe position `probe_nm` at its exposure time.
    pub fn stamp(
        &mut self,
        frame: &CameraFrame,
        now_us: u64,
        probe: (PositionSource, (i32, i32)),
    ) -> StampedFrame {
        let (position, probe_nm) = probe;
        let (frame_stamp_us, source) = Self::stamp_time(frame, now_us);
        let seq = match self.expected_seq {
            None => SeqCheck::InOrder,
            Some(e) if frame.frame_seq == e => SeqCheck::InOrder,
            Some(e) if frame.frame_seq.wrapping_sub(e) < u32::MAX / 2 => {
                SeqCheck::Gap { dropped: frame.frame_seq.wrapping_sub(e) }
            }
            Some(_) => SeqCheck::OutOfOrder,
        };
        if let SeqCheck::Gap { dropped } = seq {
            self.dropped += u64::from(dropped);
        }
        self.expected_seq = Some(frame.frame_seq.wrapping_add(1));
        self.frames += 1;
        self.black += u64::from(frame.black);
        let stamp = FrameStamp {
            frame_seq: frame.frame_seq,
            frame_stamp_us,
            probe_x_nm: probe_nm.0,
            probe_y_nm: probe_nm.1,
        };
        StampedFrame { stamp, source, seq, black: frame.black, position }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P0: (PositionSource, (i32, i32)) = (PositionSource::Unknown, (0, 0));

    fn frame(frame_seq: u32, driver_stamp_us: Option<u64>) -> CameraFrame {
        CameraFrame { frame_seq, driver_stamp_us, black: false }
    }

    #[test]
    fn driver_stamp_wins_over_arrival() {
        let mut s = FrameStamper::new();
        let a = s.stamp(&frame(0, Some(900)), 1_000, (PositionSource::LatestReport, (1, 2)));
        assert_eq!((a.stamp.frame_stamp_us, a.source), (900, StampSource::Driver));
        let b = s.stamp(&frame(1, None), 34_000, (PositionSource::LatestReport, (1, 2)));
        assert_eq!((b.stamp.frame_stamp_us, b.source), (34_000, StampSource::Arrival));
    }

    #[test]
    fn gaps_are_counted_and_restarts_flagged() {
        let mut s = FrameStamper::new();
        assert_eq!(s.stamp(&frame(u32::MAX, None), 0, P0).seq, SeqCheck::InOrder);
        assert_eq!(s.stamp(&frame(0, None), 1, P0).seq, SeqCheck::InOrder, "wraps");
        assert_eq!(s.stamp(&frame(3, None), 2, P0).seq, SeqCheck::Gap { dropped: 2 });
        assert_eq!(s.stamp(&frame(3, None), 3, P0).seq, SeqCheck::OutOfOrder);
        assert_eq!(s.stamp(&frame(4, None), 4, P0).seq, SeqCheck::InOrder);
        assert_eq!((s.frames, s.dropped), (5, 2));
    }
}
