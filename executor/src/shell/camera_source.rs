//! The executor's frame source on the camera channel: a thread that connects to a camera's
//! Unix socket (`mesopush_protocol::camera`: 32-byte header + 8-bit pixels per frame), turns
//! each frame's driver stamp from `CLOCK_MONOTONIC` into the executor's clock, hands the
//! image to the recorder and the frame to the shell's loop — both through bounded channels,
//! never waiting: a full channel drops the item and counts it.
//!
//! The channels, counters and end states are shared with the V4L2 reader
//! (`camera_v4l`, feature `v4l`); [`super::camera_addr`] picks the reader from the
//! `--camera` address.
//!
//! Time base (`docs/hil.md`): a frame whose header carries `capture_mono_us` is stamped with
//! it (`StampSource::Driver`), converted exactly because both processes read the same
//! `CLOCK_MONOTONIC`; one without it is stamped on arrival (after its last pixel is read).

use crate::camera::CameraFrame;
use crate::clock::{Clock, MonotonicClock};
use crossbeam_channel::{Sender, TrySendError};
use mesopush_protocol::camera::{CAMERA_HEADER_LEN, CameraFrameHeader};
use std::format;
use std::io::{self, ErrorKind, Read};
use std::os::unix::net::UnixStream;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;
use std::vec::Vec;

/// A received image, for the recorder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FrameImage {
    /// The camera's frame counter.
    pub frame_seq: u32,
    /// Arrival at the executor (last byte read), executor µs.
    pub arrival_us: u64,
    /// Width, pixels.
    pub width_px: u32,
    /// Height, pixels.
    pub height_px: u32,
    /// 8-bit grey pixels, row-major (empty for a black frame).
    pub pixels: Vec<u8>,
}

/// Counters of the camera thread (shared, read at the end).
#[derive(Debug, Default)]
pub struct CameraCounters {
    /// Frames received.
    pub received: AtomicU64,
    /// Frames the shell's queue had no room for (never stamped).
    pub loop_dropped: AtomicU64,
    /// Images the recorder's queue had no room for.
    pub recorder_dropped: AtomicU64,
}

/// How the camera thread ended.
#[derive(Debug)]
pub enum CameraEnd {
    /// Stop requested.
    Stopped,
    /// The camera closed the channel.
    Closed,
    /// A read failed or a header was bad.
    Failed(io::Error),
}

impl core::fmt::Display for CameraEnd {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Stopped => f.write_str("stopped"),
            Self::Closed => f.write_str("closed by the camera"),
            Self::Failed(e) => write!(f, "failed ({e})"),
        }
    }
}

/// Where a camera reader thread hands its frames: the shell's loop and the recorder (both
/// bounded channels, never waited for: a full one drops the item and counts it), with the
/// executor's clock, the counters and the stop flag.
#[derive(Debug, Clone)]
pub struct CameraSinks {
    /// The executor's clock (driver stamps are converted into it).
    pub clock: Arc<MonotonicClock>,
    /// Frames for the shell's loop (stamping), on a queue safe for a real-time reader.
    pub to_loop: super::rt_queue::Sender<CameraFrame>,
    /// Images for the recorder (`None`: not recording).
    pub to_recorder: Option<Sender<FrameImage>>,
    /// The thread's counters.
    pub counters: Arc<CameraCounters>,
    /// Set to stop the thread.
    pub stop: Arc<AtomicBool>,
}

impl CameraSinks {
    /// Hands `frame` to the loop and `image` to the recorder without waiting; counts what a
    /// full channel refused.
    pub fn deliver(&self, frame: CameraFrame, image: FrameImage) {
        let c = &self.counters;
        c.received.fetch_add(1, Ordering::Relaxed);
        if let Some(tx) = &self.to_recorder
            && let Err(TrySendError::Full(_)) = tx.try_send(image)
        {
            c.recorder_dropped.fetch_add(1, Ordering::Relaxed);
        }
        if self.to_loop.try_send(frame).is_err() {
            c.loop_dropped.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Whether a stop was requested.
    pub fn stopping(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }
}

/// Connects to the camera at `path` and starts the reader thread.
pub fn spawn_camera_reader(path: &Path, sinks: CameraSinks) -> io::Result<JoinHandle<CameraEnd>> {
    let stream = UnixStream::connect(path).map_err(|e| {
        io::Error::new(e.kind(), format!("connecting to the camera at {}: {e}", path.display()))
    })?;
    stream.set_read_timeout(Some(Duration::from_millis(100)))?;
    Ok(std::thread::spawn(move || {
        let mut reader = Reader { stream, stop: sinks.stop.clone() };
        loop {
            match reader.frame(&sinks.clock) {
                Ok(Some((frame, image))) => sinks.deliver(frame, image),
                Ok(None) => break CameraEnd::Stopped,
                Err(e) if e.kind() == ErrorKind::UnexpectedEof => break CameraEnd::Closed,
                Err(e) => break CameraEnd::Failed(e),
            }
        }
    }))
}

struct Reader {
    stream: UnixStream,
    stop: Arc<AtomicBool>,
}

impl Reader {
    /// Fills `buf`; `Ok(false)` when a stop was requested.
    fn fill(&mut self, buf: &mut [u8]) -> io::Result<bool> {
        let mut got = 0;
        while got < buf.len() {
            if self.stop.load(Ordering::Relaxed) {
                return Ok(false);
            }
            match self.stream.read(&mut buf[got..]) {
                Ok(0) => return Err(ErrorKind::UnexpectedEof.into()),
                Ok(n) => got += n,
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                    ) => {}
                Err(e) => return Err(e),
            }
        }
        Ok(true)
    }

    fn frame(&mut self, clock: &MonotonicClock) -> io::Result<Option<(CameraFrame, FrameImage)>> {
        let mut head = [0u8; CAMERA_HEADER_LEN];
        if !self.fill(&mut head)? {
            return Ok(None);
        }
        let h = CameraFrameHeader::decode(&head).map_err(|e| {
            io::Error::new(ErrorKind::InvalidData, format!("camera frame header: {e}"))
        })?;
        let mut pixels = std::vec![0u8; h.pixel_len()];
        if !self.fill(&mut pixels)? {
            return Ok(None);
        }
        let arrival_us = clock.now_us();
        let frame = CameraFrame {
            frame_seq: h.frame_seq,
            driver_stamp_us: h.capture_mono_us.and_then(|m| clock.from_mono_us(m)),
            black: h.black,
        };
        let image = FrameImage {
            frame_seq: h.frame_seq,
            arrival_us,
            width_px: h.width_px,
            height_px: h.height_px,
            pixels,
        };
        Ok(Some((frame, image)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;
    use std::os::unix::net::UnixListener;

    #[test]
    fn frames_are_stamped_in_the_executor_clock_and_images_forwarded() {
        let path = std::env::temp_dir().join(format!("mp-cam-{}.sock", std::process::id()));
        let _ = std::fs::remove_file(&path);
        let listener = UnixListener::bind(&path).unwrap();
        let clock = Arc::new(MonotonicClock::new());
        let (ftx, frx) = crate::shell::rt_queue::bounded(4);
        let (itx, irx) = crossbeam_channel::bounded(4);
        let counters = Arc::new(CameraCounters::default());
        let stop = Arc::new(AtomicBool::new(false));
        let sinks = CameraSinks {
            clock: clock.clone(),
            to_loop: ftx,
            to_recorder: Some(itx),
            counters,
            stop,
        };
        let t = spawn_camera_reader(&path, sinks).unwrap();
        let (mut cam, _) = listener.accept().unwrap();
        let mono = clock.to_mono_us(1_234);
        let h = CameraFrameHeader {
            frame_seq: 7,
            capture_mono_us: Some(mono),
            black: false,
            width_px: 3,
            height_px: 2,
        };
        cam.write_all(&h.encode()).unwrap();
        cam.write_all(&[1, 2, 3, 4, 5, 6]).unwrap();
        let f = frx.recv_timeout(Duration::from_secs(5)).unwrap();
        assert_eq!(f, CameraFrame { frame_seq: 7, driver_stamp_us: Some(1_234), black: false });
        let img = irx.recv_timeout(Duration::from_secs(5)).unwrap();
        assert_eq!((img.width_px, img.height_px, img.pixels), (3, 2, std::vec![1, 2, 3, 4, 5, 6]));
        drop(cam);
        assert!(matches!(t.join().unwrap(), CameraEnd::Closed));
        std::fs::remove_file(&path).unwrap();
    }
}
