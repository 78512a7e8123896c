//! The executor's frame source from a V4L2 camera (`--camera v4l:/dev/videoN`, cargo feature
//! `v4l`): a thread that opens the device through `mesopush_capture` (GREY or YUYV converted
//! to 8-bit luma), converts each frame's driver stamp from `CLOCK_MONOTONIC` into the
//! executor's clock exactly as the Unix camera channel does (docs/hil.md: `exec_time_us =
//! mono_us − epoch`; a stamp before the executor's epoch is replaced by the arrival time),
//! and hands frame and image to the loop and the recorder through [`CameraSinks`] — bounded
//! channels, never waited for, drops counted. The driver's sequence number is the frame
//! counter, so its gaps are the executor's dropped frames (`camera::FrameStamper`).

use super::camera_source::{CameraEnd, CameraSinks, FrameImage};
use crate::camera::CameraFrame;
use crate::clock::Clock;
use mesopush_capture::v4l2::V4l2Source;
use mesopush_capture::{CapturedFrame, StampInstant};
use std::io;
use std::path::Path;
use std::string::ToString;
use std::thread::JoinHandle;
use std::time::Duration;
use std::vec::Vec;

/// How long the thread waits for a frame before looking at the stop flag again.
const POLL: Duration = Duration::from_millis(100);

/// Opens the V4L2 device at `path` (at `size`, or the size it is set to) in its own thread
/// and starts reading. Returns once the device is open and streaming is set up; an error
/// (no such device, not a camera, no GREY or YUYV) names the device and what to do.
pub fn spawn_v4l_reader(
    path: &Path,
    size: Option<(u32, u32)>,
    sinks: CameraSinks,
) -> io::Result<JoinHandle<CameraEnd>> {
    let (ready_tx, ready_rx) = crossbeam_channel::bounded(1);
    let path = path.to_path_buf();
    let thread = std::thread::spawn(move || {
        let mut source = match V4l2Source::open(&path, size) {
            Ok(s) => {
                let _ = ready_tx.send(Ok(()));
                s
            }
            Err(e) => {
                let _ = ready_tx.send(Err(e.to_string()));
                return CameraEnd::Stopped;
            }
        };
        let l = source.layout();
        std::eprintln!(
            "camera {} ({}): {}×{} {}, {} bytes per line",
            path.display(),
            source.card(),
            l.width,
            l.height,
            l.format,
            l.bytes_per_line
        );
        read_frames(&mut source, &path, &sinks)
    });
    match ready_rx.recv() {
        Ok(Ok(())) => Ok(thread),
        Ok(Err(message)) => {
            let _ = thread.join();
            Err(io::Error::other(message))
        }
        Err(_) => Err(io::Error::other("the V4L2 camera thread ended while opening the device")),
    }
}

/// Reads frames until a stop is requested or the device fails.
fn read_frames(source: &mut V4l2Source, path: &Path, sinks: &CameraSinks) -> CameraEnd {
    let mut said_instant = false;
    loop {
        if sinks.stopping() {
            return CameraEnd::Stopped;
        }
        let f = match source.next_frame_within(POLL) {
            Ok(Some(f)) => f,
            Ok(None) => continue,
            Err(e) => return CameraEnd::Failed(io::Error::other(e.to_string())),
        };
        if !said_instant {
            said_instant = true;
            if f.stamp == StampInstant::EndOfFrame {
                std::eprintln!(
                    "camera {}: the driver stamps frames at their end, not at the start of \
                     exposure: recorded times are late by the exposure and readout",
                    path.display()
                );
            }
        }
        let arrival_us = sinks.clock.now_us();
        let (frame, image) = executor_frame(f, |m| sinks.clock.from_mono_us(m), arrival_us);
        sinks.deliver(frame, image);
    }
}

/// The loop's frame and the recorder's image of a captured frame: the driver's
/// `CLOCK_MONOTONIC` stamp through `to_exec` (`None` before the executor's epoch: the frame
/// is then stamped on arrival), the sequence number as the frame counter, a black frame
/// flagged and sent without pixels (as on the Unix camera channel).
pub fn executor_frame(
    f: CapturedFrame,
    to_exec: impl Fn(u64) -> Option<u64>,
    arrival_us: u64,
) -> (CameraFrame, FrameImage) {
    let black = f.is_black();
    let frame =
        CameraFrame { frame_seq: f.sequence, driver_stamp_us: to_exec(f.t_capture_us), black };
    let pixels = if black { Vec::new() } else { f.pixels };
    let image = FrameImage {
        frame_seq: f.sequence,
        arrival_us,
        width_px: f.width,
        height_px: f.height,
        pixels,
    };
    (frame, image)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::MonotonicClock;

    fn captured(pixels: Vec<u8>, t_capture_us: u64) -> CapturedFrame {
        CapturedFrame {
            width: 2,
            height: 2,
            pixels,
            t_capture_us,
            stamp: StampInstant::StartOfExposure,
            sequence: 41,
            dropped_before: 0,
        }
    }

    #[test]
    fn driver_stamps_convert_into_the_executor_clock_exactly() {
        let clock = MonotonicClock::new();
        let mono = clock.to_mono_us(2_500);
        let to_exec = |m| clock.from_mono_us(m);
        let (frame, image) =
            executor_frame(captured(std::vec![9, 90, 200, 30], mono), to_exec, 2_600);
        assert_eq!(
            frame,
            CameraFrame { frame_seq: 41, driver_stamp_us: Some(2_500), black: false }
        );
        assert_eq!(
            (image.frame_seq, image.arrival_us, image.pixels),
            (41, 2_600, std::vec![9, 90, 200, 30])
        );
        // before the executor's epoch: no driver stamp (stamped on arrival by the core)
        let early = clock.epoch_mono_us() - 1;
        let (frame, _) = executor_frame(captured(std::vec![50; 4], early), to_exec, 10);
        assert_eq!(frame.driver_stamp_us, None);
    }

    #[test]
    fn black_frames_are_flagged_and_sent_without_pixels() {
        let clock = MonotonicClock::new();
        let (frame, image) =
            executor_frame(captured(std::vec![0, 3, 8, 1], 0), |m| clock.from_mono_us(m), 5);
        assert!(frame.black);
        assert!(image.pixels.is_empty());
    }
}
