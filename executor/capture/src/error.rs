//! The capture crate's one error: a frame layout or buffer that does not fit (naming the
//! sizes), a driver stamp that cannot be used, and a camera that cannot be opened or read.

use crate::format::PixelFormat;

/// Everything capturing and converting frames can fail with.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A frame layout or value is invalid; the message names the value and what is allowed.
    #[error("invalid {what}: {message}")]
    Invalid {
        /// The field or object.
        what: &'static str,
        /// The value and the rule it breaks.
        message: String,
    },
    /// A buffer holds fewer bytes than its frame needs.
    #[error(
        "short frame: {got} bytes, but a {width}×{height} {format} frame with {bytes_per_line} \
         bytes per line needs {need}"
    )]
    ShortFrame {
        /// Bytes the buffer holds (the driver's `bytesused`).
        got: usize,
        /// Bytes the frame needs.
        need: usize,
        /// Width, px.
        width: u32,
        /// Height, px.
        height: u32,
        /// Bytes per line.
        bytes_per_line: usize,
        /// Pixel format.
        format: PixelFormat,
    },
    /// A camera could not be opened, configured or read.
    #[error("camera {device}: {message}")]
    Camera {
        /// The device (e.g. `/dev/video0`) or source name.
        device: String,
        /// What went wrong, and what to do when known.
        message: String,
    },
}

impl Error {
    /// Shorthand for [`Error::Invalid`].
    pub fn invalid(what: &'static str, message: impl Into<String>) -> Self {
        Error::Invalid { what, message: message.into() }
    }

    /// Shorthand for [`Error::Camera`].
    pub fn camera(device: &str, message: impl Into<String>) -> Self {
        Error::Camera { device: device.to_string(), message: message.into() }
    }
}
