//! Camera capture, shared by the executor (`mesopush-executor run --camera v4l:/dev/videoN`)
//! and the host's vision (`mesopush_vision::capture`), so that neither copies the other's
//! types and the executor never depends on a host crate.
//!
//! - [`format`](mod@format): how a driver lays out a frame (GREY or YUYV, bytes per line) and its
//!   conversion to 8-bit luma — pure functions, tested on recorded buffers without a camera.
//! - [`stamp`]: the driver's buffer timestamp (`CLOCK_MONOTONIC`, start of exposure or end of
//!   frame) decoded from a V4L2 buffer's flags and time.
//! - [`drops`]: dropped frames from gaps in the driver's sequence numbers.
//! - [`frame`]: a captured frame and the [`FrameSource`] trait.
//! - `v4l2` (cargo feature `v4l`): a V4L2 device streaming through mmap buffers.
//!
//! A leaf crate beside the executor. May depend on: `thiserror` and, with the feature, `v4l`
//! and `libc` (poll's event bits). Never on a mesopush crate.

pub mod drops;
pub mod error;
pub mod format;
pub mod frame;
pub mod stamp;
#[cfg(feature = "v4l")]
pub mod v4l2;

pub use drops::DropCounter;
pub use error::Error;
pub use format::{FrameLayout, PixelFormat};
pub use frame::{CapturedFrame, FrameSource};
pub use stamp::{DriverStamp, StampInstant};
