//! A V4L2 camera (cargo feature `v4l`): mmap streaming of GREY or YUYV frames converted to
//! 8-bit luma ([`crate::format`]), each stamped with the driver's buffer time on
//! `CLOCK_MONOTONIC` ([`crate::stamp`]; start of exposure when the driver flags it so) and
//! numbered with its sequence number, drops counted from the gaps ([`crate::drops`]).
//! Buffers the driver marks as corrupted are skipped (their number is then a gap). The only
//! part that needs a device; tested in CI only for its refusals (there is no camera there).

use std::path::Path;
use std::time::Duration;

use v4l::buffer::{Flags, Type};
use v4l::io::mmap::Stream;
use v4l::io::traits::CaptureStream;
use v4l::video::Capture;
use v4l::{Device, FourCC};

use crate::Error;
use crate::drops::DropCounter;
use crate::format::{FrameLayout, PixelFormat};
use crate::frame::{CapturedFrame, FrameSource};
use crate::stamp::DriverStamp;

/// Buffers streamed through (one held by the program while it converts, the rest queued).
const BUFFERS: u32 = 4;
/// The first frame must come within this after the stream starts.
pub const FIRST_FRAME_TIMEOUT: Duration = Duration::from_secs(5);

/// A V4L2 capture device streaming through mmap buffers.
pub struct V4l2Source {
    device: String,
    card: String,
    stream: Stream<'static>,
    layout: FrameLayout,
    started: bool,
    drops: DropCounter,
}

impl std::fmt::Debug for V4l2Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("V4l2Source")
            .field("device", &self.device)
            .field("card", &self.card)
            .field("layout", &self.layout)
            .finish_non_exhaustive()
    }
}

impl V4l2Source {
    /// Opens `path` (e.g. `/dev/video0`) for capture at `size` (width, height; `None`: the
    /// size the device is set to) in GREY or, failing that, YUYV, with mmap buffers.
    pub fn open(path: &Path, size: Option<(u32, u32)>) -> Result<Self, Error> {
        let device = path.display().to_string();
        let cam = |m: String| Error::camera(&device, m);
        if !path.exists() {
            return Err(cam("no such device (is the camera connected and its driver loaded? \
                            `v4l2-ctl --list-devices` lists the cameras)"
                .into()));
        }
        let dev = Device::with_path(path).map_err(|e| cam(format!("cannot open: {e}")))?;
        let caps = dev.query_caps().map_err(|e| cam(format!("not a V4L2 device: {e}")))?;
        use v4l::capability::Flags as Cap;
        if !caps.capabilities.contains(Cap::VIDEO_CAPTURE | Cap::STREAMING) {
            return Err(cam(format!("{} cannot stream video capture", caps.card)));
        }
        let layout = negotiate(&dev, &device, size)?;
        let mut stream = Stream::with_buffers(&dev, Type::VideoCapture, BUFFERS)
            .map_err(|e| cam(format!("mmap streaming refused: {e}")))?;
        stream.set_timeout(FIRST_FRAME_TIMEOUT);
        Ok(Self {
            device,
            card: caps.card,
            stream,
            layout,
            started: false,
            drops: DropCounter::new(),
        })
    }

    /// The negotiated layout (format, size, bytes per line).
    pub fn layout(&self) -> FrameLayout {
        self.layout
    }

    /// The device's name as its driver gives it.
    pub fn card(&self) -> &str {
        &self.card
    }

    /// The next frame, or `Ok(None)` when none came within `wait` (so a reader thread can
    /// check for a stop between frames). The first frame is waited for up to
    /// [`FIRST_FRAME_TIMEOUT`] whatever `wait` is; its absence is an error.
    pub fn next_frame_within(&mut self, wait: Duration) -> Result<Option<CapturedFrame>, Error> {
        loop {
            if self.started {
                // A done buffer is waiting when POLLIN is set; `next` then returns at once.
                let ms = i32::try_from(wait.as_millis()).unwrap_or(i32::MAX);
                let ready = self.stream.handle().poll(libc::POLLIN, ms);
                match ready {
                    Ok(0) => return Ok(None),
                    Ok(_) => {}
                    Err(e) => return Err(Error::camera(&self.device, format!("poll failed: {e}"))),
                }
            }
            let (buf, meta) = CaptureStream::next(&mut self.stream).map_err(|e| {
                let hint = if self.started {
                    String::new()
                } else {
                    format!(
                        " (no frame within {FIRST_FRAME_TIMEOUT:?} of starting the stream: \
                         is the camera waiting for an external trigger?)"
                    )
                };
                Error::camera(&self.device, format!("capture failed: {e}{hint}"))
            })?;
            self.started = true;
            if meta.flags.contains(Flags::ERROR) {
                continue; // corrupted: its sequence number becomes a gap, counted as a drop
            }
            // time_t is 32 bits on some targets
            #[allow(clippy::unnecessary_cast)]
            let (sec, usec) = (meta.timestamp.sec as i64, meta.timestamp.usec as i64);
            let stamp = DriverStamp::decode(meta.flags.bits(), sec, usec)
                .map_err(|e| Error::camera(&self.device, e.to_string()))?;
            let used = (meta.bytesused as usize).min(buf.len());
            let mut pixels = Vec::new();
            self.layout
                .to_luma(&buf[..used], &mut pixels)
                .map_err(|e| Error::camera(&self.device, e.to_string()))?;
            let sequence = meta.sequence;
            return Ok(Some(CapturedFrame {
                width: self.layout.width,
                height: self.layout.height,
                pixels,
                t_capture_us: stamp.mono_us,
                stamp: stamp.instant,
                sequence,
                dropped_before: self.drops.observe(sequence),
            }));
        }
    }
}

/// Asks for GREY, then YUYV, at the size wanted; refuses anything else, listing the offers.
fn negotiate(dev: &Device, device: &str, size: Option<(u32, u32)>) -> Result<FrameLayout, Error> {
    let current =
        dev.format().map_err(|e| Error::camera(device, format!("cannot read the format: {e}")))?;
    let (width, height) = size.unwrap_or((current.width, current.height));
    for format in PixelFormat::ALL {
        let want = v4l::Format { width, height, fourcc: FourCC::new(&format.fourcc()), ..current };
        let Ok(got) = dev.set_format(&want) else { continue };
        if got.fourcc == want.fourcc && got.width == width && got.height == height {
            let stride = got.stride as usize;
            let bpl = if stride == 0 { format.row_bytes(width) } else { stride };
            return FrameLayout::new(format, width, height, bpl)
                .map_err(|e| Error::camera(device, e.to_string()));
        }
    }
    let offered: Vec<String> = dev
        .enum_formats()
        .map(|fs| fs.iter().map(|f| f.fourcc.to_string()).collect())
        .unwrap_or_default();
    Err(Error::camera(
        device,
        format!(
            "unsupported format: need GREY or YUYV at {width}×{height}; the device offers \
             {offered:?}"
        ),
    ))
}

impl FrameSource for V4l2Source {
    fn next_frame(&mut self) -> Result<Option<CapturedFrame>, Error> {
        loop {
            if let Some(f) = self.next_frame_within(Duration::from_secs(1))? {
                return Ok(Some(f));
            }
        }
    }

    fn dropped_total(&self) -> u64 {
        self.drops.total()
    }
}
