//! Frame sources: replayed rendered frames feed the tracker with timestamps and drop counts;
//! with the `v4l` feature, a missing camera gets a clear error naming the device through the
//! vision crate's error (the V4L2 source itself is `mesopush-capture`'s).

use mesopush_core::geom::Pose;
use mesopush_vision::capture::{FrameSource, ReplaySource, gray_image};
use mesopush_vision::demo::demo_sequence_frame;
use mesopush_vision::{
    DemoFixture, RenderSettings, Renderer, Scene, TrackSettings, Tracker, paper_peg,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

#[test]
fn replayed_frames_are_tracked_with_their_times_and_drops() {
    let walls = DemoFixture::default().walls().unwrap();
    let peg = paper_peg();
    let settings = RenderSettings::default();
    let needle = settings.needle;
    let mut renderer = Renderer::new(settings, &walls).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let empty = Scene { walls: &walls, peg: None, peg_pose: Pose::default(), probe_tip: None };
    let bg = renderer.render_averaged(&empty, 16, &mut rng).image;
    let n = 6;
    let mut truths = Vec::new();
    let frames = (0..n)
        .map(|k| {
            let (pose, tip) = demo_sequence_frame(&peg, &needle, k, 30);
            truths.push(pose);
            let scene = Scene { peg: Some(&peg), peg_pose: pose, probe_tip: Some(tip), ..empty };
            renderer.render(&scene, &mut rng).image
        })
        .collect();
    let mut source = ReplaySource::new(frames, 33_333, 5_000).unwrap().with_drops(&[2]);
    let mut tracker = Tracker::new(&bg, TrackSettings::default()).unwrap();
    let mut k = 0;
    while let Some(f) = source.next_frame().unwrap() {
        let (sequence, dropped_before, t_capture_us) =
            (f.sequence, f.dropped_before, f.t_capture_us);
        let m = tracker.track(&gray_image(f).unwrap()).unwrap();
        assert!(m.flags.is_empty(), "frame {k}: {m:?}");
        let err = (m.pose.unwrap().position() - truths[k].position()).norm();
        assert!(err < 1.0, "frame {k}: {err} µm");
        assert_eq!(dropped_before, u32::from(sequence == 3));
        assert_eq!(t_capture_us, 5_000 + u64::from(sequence) * 33_333);
        k += 1;
    }
    assert_eq!(k, n);
    assert_eq!(source.dropped_total(), 1);
}

#[cfg(feature = "v4l")]
#[test]
fn a_missing_camera_is_a_clear_error() {
    use mesopush_vision::capture::V4l2Source;
    let e = V4l2Source::open(std::path::Path::new("/dev/video-mesopush-missing"), Some((640, 480)))
        .map(|_| ())
        .map_err(mesopush_vision::Error::from)
        .unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("/dev/video-mesopush-missing") && text.contains("no such device"),
        "{text}"
    );
    // a file that is not a V4L2 device is refused too, not a panic
    let not_a_camera = V4l2Source::open(std::path::Path::new("/dev/null"), None).unwrap_err();
    assert!(not_a_camera.to_string().contains("/dev/null"), "{not_a_camera}");
}
