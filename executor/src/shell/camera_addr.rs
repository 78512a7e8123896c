//! The camera channel's address, `--camera`: `unix:PATH`, a camera serving frames on a Unix
//! socket (`mesopush-fwsim`; [`super::camera_source`]), or `v4l:/dev/videoN`, a V4L2 camera
//! read in this process (`camera_v4l`, cargo feature `v4l`). Both readers stamp frames with
//! the driver's `CLOCK_MONOTONIC` time converted into the executor's clock and feed the same
//! [`CameraSinks`]. An executor built without the feature refuses a `v4l:` address with the
//! command that builds one with it.

use super::camera_source::{CameraEnd, CameraSinks, spawn_camera_reader};
use std::format;
use std::io;
use std::path::PathBuf;
use std::string::String;
use std::thread::JoinHandle;

/// What an executor built without the `v4l` feature says about a `v4l:` address.
pub const NO_V4L_HINT: &str = "this mesopush-executor was built without V4L2 capture: build it \
     with `cargo build --release -p mesopush-executor --features v4l` (needs libclang-dev: \
     `apt-get install libclang-dev`)";

/// Where camera frames come from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CameraAddr {
    /// A camera serving frames on this Unix socket.
    Unix(PathBuf),
    /// A V4L2 capture device (e.g. `/dev/video0`).
    V4l(PathBuf),
}

impl CameraAddr {
    /// Parses `unix:PATH` or `v4l:DEVICE`; anything else is refused, naming the text and the
    /// forms allowed.
    pub fn parse(text: &str) -> Result<Self, String> {
        let (kind, rest) = text.split_once(':').unwrap_or(("", text));
        match kind {
            "unix" if !rest.is_empty() => Ok(Self::Unix(PathBuf::from(rest))),
            "v4l" if !rest.is_empty() => Ok(Self::V4l(PathBuf::from(rest))),
            _ => Err(format!(
                "--camera wants unix:PATH (a camera socket, e.g. mesopush-fwsim's) or \
                 v4l:DEVICE (a V4L2 camera, e.g. v4l:/dev/video0), got {text:?}"
            )),
        }
    }

    /// Starts the reader thread for this camera; `size` (width, height) asks a V4L2 camera
    /// for that size (`None`: the size it is set to) and is refused for a socket, which sends
    /// its own. Errors name the address and what to do.
    pub fn spawn(
        &self,
        size: Option<(u32, u32)>,
        sinks: CameraSinks,
    ) -> io::Result<JoinHandle<CameraEnd>> {
        match self {
            Self::Unix(path) => {
                if size.is_some() {
                    return Err(io::Error::new(
                        io::ErrorKind::InvalidInput,
                        "--camera-size applies to a V4L2 camera (v4l:DEVICE) only; a camera \
                         socket sends frames of its own size",
                    ));
                }
                spawn_camera_reader(path, sinks)
            }
            Self::V4l(device) => spawn_v4l(device, size, sinks),
        }
    }
}

/// Parses a frame size `WxH` (e.g. `640x480`), each side 1..=16384 px.
pub fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let bad = || format!("want WxH with sides in 1..=16384 px (e.g. 640x480), got {text:?}");
    let (w, h) = text.split_once(['x', 'X', '×']).ok_or_else(bad)?;
    let side = |s: &str| s.trim().parse::<u32>().ok().filter(|v| (1..=16_384).contains(v));
    Ok((side(w).ok_or_else(bad)?, side(h).ok_or_else(bad)?))
}

#[cfg(feature = "v4l")]
fn spawn_v4l(
    device: &std::path::Path,
    size: Option<(u32, u32)>,
    sinks: CameraSinks,
) -> io::Result<JoinHandle<CameraEnd>> {
    super::camera_v4l::spawn_v4l_reader(device, size, sinks)
}

#[cfg(not(feature = "v4l"))]
fn spawn_v4l(
    device: &std::path::Path,
    _size: Option<(u32, u32)>,
    _sinks: CameraSinks,
) -> io::Result<JoinHandle<CameraEnd>> {
    Err(io::Error::new(
        io::ErrorKind::Unsupported,
        format!("--camera v4l:{}: {NO_V4L_HINT}", device.display()),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::MonotonicClock;
    use crate::shell::camera_source::CameraCounters;
    use std::string::ToString;
    use std::sync::Arc;
    use std::sync::atomic::AtomicBool;

    fn sinks() -> CameraSinks {
        CameraSinks {
            clock: Arc::new(MonotonicClock::new()),
            to_loop: crate::shell::rt_queue::bounded(1).0,
            to_recorder: None,
            counters: Arc::new(CameraCounters::default()),
            stop: Arc::new(AtomicBool::new(false)),
        }
    }

    #[test]
    fn addresses_parse_and_bad_ones_name_the_forms() {
        assert_eq!(
            CameraAddr::parse("unix:/tmp/c.sock"),
            Ok(CameraAddr::Unix("/tmp/c.sock".into()))
        );
        assert_eq!(CameraAddr::parse("v4l:/dev/video2"), Ok(CameraAddr::V4l("/dev/video2".into())));
        for bad in ["/dev/video0", "v4l:", "tcp:host:1", ""] {
            let e = CameraAddr::parse(bad).unwrap_err();
            assert!(e.contains("unix:PATH") && e.contains("v4l:DEVICE"), "{bad}: {e}");
        }
    }

    #[test]
    fn sizes_parse_within_range() {
        assert_eq!(parse_size("640x480"), Ok((640, 480)));
        assert_eq!(parse_size("928×480"), Ok((928, 480)));
        for bad in ["640", "0x480", "640x", "99999x1", "axb"] {
            assert!(parse_size(bad).unwrap_err().contains("WxH"), "{bad}");
        }
    }

    #[test]
    fn a_size_for_a_socket_camera_is_refused() {
        let e = CameraAddr::Unix("/nonexistent.sock".into()).spawn(Some((640, 480)), sinks());
        assert!(e.unwrap_err().to_string().contains("--camera-size"));
    }

    #[cfg(not(feature = "v4l"))]
    #[test]
    fn without_the_feature_a_v4l_camera_says_how_to_build_with_it() {
        let e = CameraAddr::V4l("/dev/video0".into()).spawn(None, sinks()).unwrap_err().to_string();
        assert!(e.contains("/dev/video0") && e.contains("--features v4l"), "{e}");
        assert!(e.contains("libclang-dev"), "{e}");
    }

    #[cfg(feature = "v4l")]
    #[test]
    fn opening_a_missing_v4l_device_is_a_clear_error() {
        let e = CameraAddr::V4l("/dev/video-mesopush-missing".into())
            .spawn(Some((640, 480)), sinks())
            .unwrap_err()
            .to_string();
        assert!(e.contains("/dev/video-mesopush-missing") && e.contains("no such device"), "{e}");
    }
}
