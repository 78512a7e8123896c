//! "Estimate the initial pose from a camera frame, then adapt or choose the plan": the sim
//! runner's camera. It renders the first frames of a trial with the synthetic microscope
//! (peg at the world's true start, probe at its start), injects the batch's camera faults
//! (dropped and black frames, seeded), detects them (a gap in the frame counter; a frame
//! with no light), and tracks the first good frame.
//!
//! Plan policy: among the batch's plans choose the one whose nominal start is nearest the
//! estimate (position distance plus the part's characteristic length × angle difference),
//! then shift its probe start by the estimate's offset from that nominal start, so the
//! probe meets the peg where the plan expects. Orientation errors are not compensated (the
//! moves stay axis-aligned); the plan's own robustness has to cover them.

use super::spec::CameraSpec;
use crate::Error;
use crate::geom::{ConvexPolygon, Pose, Vec2};
use crate::sim::Plan;
use crate::trial::FrameRow;
use crate::vision::{RenderSettings, Renderer, Scene, TrackSettings, Tracker};
use image::GrayImage;
use rand::{Rng, RngExt, SeedableRng};

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
    spec: CameraSpec,
}

/// What the camera phase found.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Estimate {
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
        spec: &CameraSpec,
    ) -> Result<Self, Error> {
        let calibration = settings.calibration;
        let mut renderer = Renderer::new(settings, walls)?;
        let empty = Scene { walls, peg: None, peg_pose: Pose::default(), probe_tip: None };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x0bac_0bac);
        let bg = renderer.render_averaged(&empty, 16, &mut rng).image;
        let track =
            TrackSettings { peg: peg.clone(), theta_hint_rad, calibration, ..Default::default() };
        let tracker = Tracker::new(&bg, track)?;
        Ok(Self { renderer, tracker, walls: walls.to_vec(), peg: peg.clone(), spec: spec.clone() })
    }

    /// Takes frames of the peg at `truth` (probe at `probe_um`) until one gives a pose or
    /// `max_frames` are spent.
    pub fn estimate(&mut self, truth: Pose, probe_um: Vec2, rng: &mut impl Rng) -> Estimate {
        let mut e = Estimate::default();
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

/// Index of the plan whose nominal start is nearest `pose` (`char_len_um` weighs angles).
pub fn nearest_plan(plans: &[Plan], pose: &Pose, char_len_um: f64) -> usize {
    let cost = |p: &Plan| {
        let s = p.peg_start_pose();
        let d = (s.position() - pose.position()).norm();
        let a = (s.theta_rad - pose.theta_rad).sin().abs();
        d + char_len_um * a
    };
    (0..plans.len()).min_by(|a, b| cost(&plans[*a]).total_cmp(&cost(&plans[*b]))).unwrap_or(0)
}

/// `plan` shifted so it starts from `pose`: probe start moved by the position offset, the
/// nominal start replaced by the estimate (moves unchanged).
pub fn adapt(plan: &Plan, pose: &Pose) -> Plan {
    let s = plan.peg_start_pose();
    let (dx, dy) = (pose.x_um - s.x_um, pose.y_um - s.y_um);
    let mut out = plan.clone();
    out.probe_start_um = [plan.probe_start_um[0] + dx, plan.probe_start_um[1] + dy];
    out.peg_start.x_um = pose.x_um;
    out.peg_start.y_um = pose.y_um;
    out.name = format!("{} (shifted by {dx:+.1}, {dy:+.1} µm)", plan.name);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adapt_moves_probe_start_with_the_peg() {
        let plan = Plan::table2();
        let s = plan.peg_start_pose();
        let a = adapt(&plan, &Pose::new(s.x_um + 10.0, s.y_um - 20.0, s.theta_rad));
        assert_eq!(a.probe_start_um, [3060.0, 1220.0]);
        assert_eq!(a.moves_um, plan.moves_um);
    }

    #[test]
    fn nearest_plan_picks_the_closer_start() {
        let a = Plan::table2();
        let mut b = a.clone();
        b.peg_start.x_um += 500.0;
        let near_b =
            Pose::new(b.peg_start.x_um - 10.0, b.peg_start.y_um, a.peg_start_pose().theta_rad);
        assert_eq!(nearest_plan(&[a.clone(), b.clone()], &near_b, 900.0), 1);
        assert_eq!(nearest_plan(&[a.clone(), b], &a.peg_start_pose(), 900.0), 0);
    }
}
