//! "Estimate the initial pose from a camera frame": the simulated camera that looks at a
//! trial's start before the plan runs. It renders the first frames of a trial with the synthetic microscope
//! (peg at the world's true start, probe at its start), injects the batch's camera faults
//! (dropped and black frames, seeded), detects them (a gap in the frame counter; a frame
//! with no light), and tracks the first good frame.
//! What the batch then does with the estimate is its plan policy (`mesopush_batch::policy`).

use crate::Error;
use image::GrayImage;
use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};
use mesopush_trial::FrameRow;
use mesopush_vision::{RenderSettings, Renderer, Scene, TrackSettings, Tracker};
use rand::{Rng, RngExt, SeedableRng};

/// The camera faults injected while estimating the start, and how long to try.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameFaults {
    /// Frames tried before giving up.
    pub max_frames: u32,
    /// Probability a frame is dropped.
    pub frame_drop: f64,
    /// Probability a frame is black.
    pub frame_black: f64,
}

/// Camera frame period, µs (30 Hz).
pub const FRAME_PERIOD_US: u64 = 33_333;
/// A frame whose mean is below this is black (the plate is ≈ 200 DN), DN.
const BLACK_MEAN_DN: f64 = 20.0;

/// The synthetic camera and the tracker, built once per runner.
#[derive(Debug)]
pub struct Camera {
    renderer: Renderer,
    tracker: Tracker,
    walls: Vec<ConvexPolygon>,
    peg: ConvexPolygon,
    spec: FrameFaults,
}

/// What the camera phase found.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StartEstimate {
    /// The tracked start pose, when a frame gave one.
    pub pose: Option<Pose>,
    /// One row per frame (times before the trial's start: negative).
    pub frames: Vec<FrameRow>,
    /// Dropped or black frames injected.
    pub injected: u64,
    /// Of those, detected.
    pub detected: u64,
    /// Frames that arrived but gave no pose (tracker found no peg).
    pub untracked: u64,
}

impl Camera {
    /// A camera (`settings`: size, optics, calibration) over `walls` looking at `peg`; the
    /// tracker uses the same calibration and starts from `theta_hint_rad`.
    pub fn new(
        settings: RenderSettings,
        walls: &[ConvexPolygon],
        peg: &ConvexPolygon,
        theta_hint_rad: f64,
        spec: FrameFaults,
    ) -> Result<Self, Error> {
        let calibration = settings.calibration;
        let mut renderer = Renderer::new(settings, walls)?;
        let empty = Scene { walls, peg: None, peg_pose: Pose::default(), probe_tip: None };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x0bac_0bac);
        let bg = renderer.render_averaged(&empty, 16, &mut rng).image;
        let track =
            TrackSettings { peg: peg.clone(), theta_hint_rad, calibration, ..Default::default() };
        let tracker = Tracker::new(&bg, track)?;
        Ok(Self { renderer, tracker, walls: walls.to_vec(), peg: peg.clone(), spec })
    }

    /// Takes frames of the peg at `truth` (probe at `probe_um`) until one gives a pose or
    /// `max_frames` are spent.
    pub fn estimate(&mut self, truth: Pose, probe_um: Vec2, rng: &mut impl Rng) -> StartEstimate {
        let mut e = StartEstimate::default();
        let n = self.spec.max_frames;
        for k in 0..n {
            let t_us = -(i64::from(n - k) * FRAME_PERIOD_US as i64);
            let seq = k + 1;
            let dropped = rng.random_bool(self.spec.frame_drop);
            let black = !dropped && rng.random_bool(self.spec.frame_black);
            e.injected += u64::from(dropped || black);
            let scene = Scene {
                walls: &self.walls,
                peg: Some(&self.peg),
                peg_pose: truth,
                probe_tip: Some(probe_um),
            };
            let mut image = self.renderer.render(&scene, rng).image;
            if dropped {
                // Never arrives: its deadline (one period) passes without it, which is how
                // the camera loop detects a lost frame.
                e.detected += 1;
                e.frames.push(row(e.frames.len() as u64, seq, None, true, false));
                continue;
            }
            if black {
                image = GrayImage::new(image.width(), image.height());
            }
            let is_black = mean(&image) < BLACK_MEAN_DN;
            e.detected += u64::from(is_black);
            e.frames.push(row(e.frames.len() as u64, seq, Some(t_us), false, is_black));
            if is_black {
                continue;
            }
            self.tracker.reset();
            match self.tracker.measure(&image).ok().and_then(|m| m.pose) {
                Some(p) => {
                    e.pose = Some(p);
                    break;
                }
                None => e.untracked += 1,
            }
        }
        e
    }
}

fn mean(img: &GrayImage) -> f64 {
    let s: u64 = img.as_raw().iter().map(|v| u64::from(*v)).sum();
    s as f64 / img.as_raw().len().max(1) as f64
}

fn row(index: u64, seq: u32, t_us: Option<i64>, dropped: bool, black: bool) -> FrameRow {
    FrameRow {
        index,
        frame_seq: seq,
        t_capture_us: t_us,
        t_arrival_us: t_us,
        stamp_source: "driver".into(),
        dropped,
        black,
        probe_x_um: None,
        probe_y_um: None,
        file: None,
    }
}
