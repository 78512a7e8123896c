//! The V4L2 device (feature `v4l`): without a camera (CI has none) only its refusals can be
//! exercised — a missing device and a file that is not a V4L2 device give errors naming them.
#![cfg(feature = "v4l")]

use mesopush_capture::v4l2::V4l2Source;
use std::path::Path;

#[test]
fn a_missing_camera_is_a_clear_error() {
    let e = V4l2Source::open(Path::new("/dev/video-mesopush-missing"), Some((640, 480)))
        .unwrap_err()
        .to_string();
    assert!(e.contains("/dev/video-mesopush-missing") && e.contains("no such device"), "{e}");
    let not_a_camera = V4l2Source::open(Path::new("/dev/null"), None).unwrap_err().to_string();
    assert!(not_a_camera.contains("/dev/null"), "{not_a_camera}");
}
