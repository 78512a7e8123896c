//! A V4L2 camera as a [`FrameSource`] (cargo feature `v4l`): mmap streaming, the driver's
//! buffer timestamp on the monotonic clock (start of exposure when the driver flags it so),
//! sequence numbers and drops from their gaps. Accepts 8-bit grey (`GREY`) or `YUYV` (the luma
//! is kept); anything else is refused with the formats the device offers.

use std::path::Path;

use image::GrayImage;
use v4l::buffer::{Flags, Type};
use v4l::io::mmap::Stream;
use v4l::io::traits::CaptureStream;
use v4l::video::Capture;
use v4l::{Device, FourCC};

use crate::Error;
use crate::capture::{CapturedFrame, DropCounter, FrameSource, StampInstant};

/// How the driver lays out a pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Layout {
    Grey,
    Yuyv,
}

/// A V4L2 capture device streaming through mmap buffers.
pub struct V4l2Source {
    device: String,
    stream: Stream<'static>,
    width: u32,
    height: u32,
    stride: usize,
    layout: Layout,
    drops: DropCounter,
}

impl std::fmt::Debug for V4l2Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("V4l2Source")
            .field("device", &self.device)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("layout", &self.layout)
            .finish_non_exhaustive()
    }
}

fn camera(device: &str, message: impl Into<String>) -> Error {
    Error::Camera { device: device.to_string(), message: message.into() }
}

impl V4l2Source {
    /// Opens `path` (e.g. `/dev/video0`) for `width × height` capture with 4 mmap buffers.
    pub fn open(path: &Path, width: u32, height: u32) -> Result<Self, Error> {
        let device = path.display().to_string();
        if !path.exists() {
            return Err(camera(
                &device,
                "no such device (is the camera connected and its driver loaded?)",
            ));
        }
        let dev =
            Device::with_path(path).map_err(|e| camera(&device, format!("cannot open: {e}")))?;
        let caps =
            dev.query_caps().map_err(|e| camera(&device, format!("not a V4L2 device: {e}")))?;
        use v4l::capability::Flags as Cap;
        if !caps.capabilities.contains(Cap::VIDEO_CAPTURE | Cap::STREAMING) {
            return Err(camera(&device, format!("{} cannot stream video capture", caps.card)));
        }
        let (layout, fmt) = negotiate(&dev, &device, width, height)?;
        let stream = Stream::with_buffers(&dev, Type::VideoCapture, 4)
            .map_err(|e| camera(&device, format!("mmap streaming refused: {e}")))?;
        let min_stride = width as usize * if layout == Layout::Yuyv { 2 } else { 1 };
        let stride = (fmt.stride as usize).max(min_stride);
        Ok(Self { device, stream, width, height, stride, layout, drops: DropCounter::new() })
    }
}

/// Asks for GREY, then YUYV, at the size wanted; refuses anything else, listing the offers.
fn negotiate(
    dev: &Device,
    device: &str,
    width: u32,
    height: u32,
) -> Result<(Layout, v4l::Format), Error> {
    let current =
        dev.format().map_err(|e| camera(device, format!("cannot read the format: {e}")))?;
    for (code, layout) in [(b"GREY", Layout::Grey), (b"YUYV", Layout::Yuyv)] {
        let want = v4l::Format { width, height, fourcc: FourCC::new(code), ..current };
        let Ok(got) = dev.set_format(&want) else { continue };
        if got.fourcc == want.fourcc && got.width == width && got.height == height {
            return Ok((layout, got));
        }
    }
    let offered: Vec<String> = dev
        .enum_formats()
        .map(|fs| fs.iter().map(|f| f.fourcc.to_string()).collect())
        .unwrap_or_default();
    Err(camera(
        device,
        format!(
            "unsupported format: need GREY or YUYV at {width}×{height}; the device offers {offered:?}"
        ),
    ))
}

impl FrameSource for V4l2Source {
    fn next_frame(&mut self) -> Result<Option<CapturedFrame>, Error> {
        let (w, h, stride, layout) =
            (self.width as usize, self.height as usize, self.stride, self.layout);
        let (buf, meta) = CaptureStream::next(&mut self.stream)
            .map_err(|e| camera(&self.device, format!("capture failed: {e}")))?;
        if (meta.flags & Flags::TIMESTAMP_MASK) != Flags::TIMESTAMP_MONOTONIC {
            return Err(camera(
                &self.device,
                "the driver does not stamp frames on the monotonic clock",
            ));
        }
        let stamp = if (meta.flags & Flags::TSTAMP_SRC_MASK) == Flags::TSTAMP_SRC_SOE {
            StampInstant::StartOfExposure
        } else {
            StampInstant::EndOfFrame
        };
        // time_t is 32 bits on some targets
        #[allow(clippy::unnecessary_cast)]
        let (sec, usec) = (meta.timestamp.sec as i64, meta.timestamp.usec as i64);
        let t_capture_us = u64::try_from(sec * 1_000_000 + usec)
            .map_err(|_| camera(&self.device, "negative buffer timestamp"))?;
        let used = (meta.bytesused as usize).min(buf.len());
        if used < stride * (h - 1) + w * if layout == Layout::Yuyv { 2 } else { 1 } {
            return Err(camera(&self.device, format!("short frame: {used} bytes")));
        }
        let mut pixels = Vec::with_capacity(w * h);
        for row in buf[..used].chunks(stride).take(h) {
            match layout {
                Layout::Grey => pixels.extend_from_slice(&row[..w]),
                Layout::Yuyv => pixels.extend(row[..2 * w].iter().step_by(2)),
            }
        }
        let image = GrayImage::from_raw(self.width, self.height, pixels)
            .ok_or_else(|| camera(&self.device, "frame size mismatch"))?;
        let sequence = meta.sequence;
        let dropped_before = self.drops.observe(sequence);
        Ok(Some(CapturedFrame { image, t_capture_us, stamp, sequence, dropped_before }))
    }

    fn dropped_total(&self) -> u64 {
        self.drops.total()
    }
}
