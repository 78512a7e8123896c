//! The tracking pipeline (paper §IV): background subtraction, thresholding, removal of the
//! probe by its geometry (locating its tip), then the peg's centroid and orientation from the
//! second moments of the remaining blob, weighted by partial pixel coverage. Every result
//! carries a confidence and flags; a sequence keeps its orientation continuous.
//!
//! In a sequence, each frame is compared with the last *trusted* pose: the last frame that
//! was unflagged, or flagged only as a jump (a clean view of a peg that moved further than
//! expected: the tracker reacquires it). Frames flagged for anything else (needle over the
//! peg, a wall, the border) are not trusted and do not move the reference, and the jump
//! tolerance grows with the frame periods since the trusted pose (`max_step_um` per
//! period), so a stretch of flagged or dropped frames during which the peg moved on does not
//! flag the good frames after it.

use image::GrayImage;
use std::f64::consts::FRAC_PI_2;

use crate::Error;
use crate::assess::{
    FLAGGED_CONFIDENCE_CAP, Flag, Measurement, is_jump, nearest_branch, shape_confidence,
};
use crate::background::Background;
use crate::calib::Calibration;
use crate::moments::{Moments, polygon_moments};
use crate::morph::{Roi, label_components_into};
use crate::probe::{ProbeBuffers, ProbeSettings, separate_probe};
use crate::scale_lock::{ScaleLearning, ScaleLock, scaled};
use crate::scene::paper_peg;
use crate::threshold::{Threshold, threshold_level};
use crate::tip::{LocatedTip, PegView, TipFlag, place_tip};
use crate::weigh::{Blob, Weighed, weigh};
use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};

/// Tracker settings. Plain data; see `Default` for the documented values.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackSettings {
    /// Pixels ↔ fixture frame (default: 3370 × 2520 µm over 640 × 480, origin top-left).
    pub calibration: Calibration,
    /// Threshold on the darkening (default: Otsu, at least 0.12 of the plate's light).
    pub threshold: Threshold,
    /// The peg's outline in its body frame (default: the paper's 1615 × 985 µm rectangle).
    /// Used to check the blob's shape and to turn the ellipse's axis into the body's θ.
    pub peg: ConvexPolygon,
    /// What is known of the probe.
    pub probe: ProbeSettings,
    /// Pixels around the thresholded peg included with their gray-level weight (default 3).
    pub band_px: usize,
    /// Relative area error scoring one standard deviation of confidence loss (default 0.02).
    pub area_tolerance: f64,
    /// Relative second-moment error scoring one standard deviation (default 0.025).
    pub moment_tolerance: f64,
    /// Below this shape confidence the frame is flagged `shape_mismatch` (default 0.3).
    pub min_confidence: f64,
    /// Largest plausible move per frame period in a sequence, µm (default 400); the
    /// tolerance against the last trusted pose is this times the periods since it.
    pub max_step_um: f64,
    /// Largest plausible turn per frame period in a sequence, rad (default 0.35); scaled
    /// likewise.
    pub max_step_rad: f64,
    /// Orientation the first frame of a sequence is taken to be near, rad (default 0).
    pub theta_hint_rad: f64,
    /// Learning the peg's apparent size from a sequence's first frames (an image scale a
    /// few per cent off; see [`ScaleLearning`]).
    pub scale_learning: ScaleLearning,
}

impl Default for TrackSettings {
    fn default() -> Self {
        Self {
            calibration: Calibration::default(),
            threshold: Threshold::default(),
            peg: paper_peg(),
            probe: ProbeSettings::default(),
            band_px: 3,
            area_tolerance: 0.02,
            moment_tolerance: 0.025,
            min_confidence: 0.3,
            max_step_um: 400.0,
            max_step_rad: 0.35,
            theta_hint_rad: 0.0,
            scale_learning: ScaleLearning::default(),
        }
    }
}

/// Measures frames against one background. Reuse it: it keeps scratch buffers and, for
/// [`Tracker::track`], the last trusted pose.
#[derive(Debug, Clone)]
pub struct Tracker {
    settings: TrackSettings,
    bg: Background,
    expected: Moments,
    /// The part's moments as they appear (the learned apparent scale applied).
    seen: Moments,
    scale: ScaleLock,
    body_axis_rad: f64,
    buf: Buffers,
    /// The last trusted pose of the sequence and the frame periods since it.
    trusted: Option<(Pose, u32)>,
}

/// Working images reused from frame to frame (a frame allocates nothing large).
#[derive(Debug, Clone, Default)]
struct Buffers {
    dark: Vec<f32>,
    mask: Vec<bool>,
    rest: Vec<bool>,
    labels: Vec<u32>,
    probe: ProbeBuffers,
}

impl Tracker {
    /// A tracker for frames like `background` (the empty fixture, same size and lighting).
    pub fn new(background: &GrayImage, settings: TrackSettings) -> Result<Self, Error> {
        let open_px = settings.probe.max_half_width_um / settings.calibration.mean_um_per_px();
        if !(open_px >= 1.0 && open_px.is_finite()) {
            return Err(Error::invalid("probe max_half_width_um", "must be at least a pixel"));
        }
        if !(settings.area_tolerance > 0.0 && settings.moment_tolerance > 0.0) {
            return Err(Error::invalid("track tolerances", "must be > 0"));
        }
        let bg = Background::new(background)?;
        let expected = polygon_moments(&settings.peg);
        let body_axis_rad = expected.major_axis_angle();
        Ok(Self {
            settings,
            bg,
            expected,
            seen: expected,
            scale: ScaleLock::default(),
            body_axis_rad,
            buf: Buffers::default(),
            trusted: None,
        })
    }

    /// The settings in use.
    pub fn settings(&self) -> &TrackSettings {
        &self.settings
    }

    /// The peg's apparent area ÷ its part file's area, once a sequence has fixed it
    /// ([`ScaleLearning`]): `√r − 1` is the image scale's error in length. `None` until then.
    pub fn apparent_scale(&self) -> Option<f64> {
        self.scale.locked()
    }

    /// Forgets the sequence: the next [`Tracker::track`] starts from the θ hint again (a
    /// learned apparent scale belongs to the camera and is kept).
    pub fn reset(&mut self) {
        self.trusted = None;
    }

    /// Measures one frame on its own: θ is given on the branch nearest the θ hint.
    pub fn measure(&mut self, frame: &GrayImage) -> Result<Measurement, Error> {
        let hint = self.settings.theta_hint_rad;
        Ok(self.measure_near(frame, hint)?.0)
    }

    /// Measures the next frame of a sequence, one frame period after the previous one:
    /// θ continues from the last trusted frame, and a pose further from it than a push can
    /// move the peg in the time since is flagged [`Flag::Jump`].
    pub fn track(&mut self, frame: &GrayImage) -> Result<Measurement, Error> {
        self.track_after(frame, 1)
    }

    /// [`Tracker::track`] for a frame `periods` frame periods after the previous one (the
    /// frames between were dropped or not tracked; 0 counts as 1).
    pub fn track_after(&mut self, frame: &GrayImage, periods: u32) -> Result<Measurement, Error> {
        if let Some((_, n)) = self.trusted.as_mut() {
            *n = n.saturating_add(periods.max(1));
        }
        let reference = self.trusted.map_or(self.settings.theta_hint_rad, |(p, _)| p.theta_rad);
        let (mut m, moments) = self.measure_near(frame, reference)?;
        let whole = m.flags.iter().all(|f| *f == Flag::ShapeMismatch);
        let sample = moments.as_ref().filter(|_| whole && m.pose.is_some());
        if let Some(r) = self.scale.observe(sample, &self.expected, &self.settings.scale_learning) {
            // this frame fixed the peg's apparent size: judge it again against it
            self.seen = scaled(&self.expected, r);
            m = self.measure_near(frame, reference)?.0;
        }
        if let (Some(pose), Some((trusted, n))) = (m.pose, self.trusted) {
            let k = f64::from(n);
            let (max_um, max_rad) = (self.settings.max_step_um, self.settings.max_step_rad);
            if is_jump(&pose, &trusted, k * max_um, (k * max_rad).min(FRAC_PI_2)) {
                m.flags.push(Flag::Jump);
                m.confidence = m.confidence.min(FLAGGED_CONFIDENCE_CAP);
            }
        }
        // A frame whose only fault is the jump is still a good view: reacquire it, so one
        // real jump flags one frame, not the rest of the sequence.
        if let Some(pose) = m.pose
            && m.flags.iter().all(|f| *f == Flag::Jump)
        {
            self.trusted = Some((pose, 0));
        }
        Ok(m)
    }

    fn measure_near(
        &mut self,
        frame: &GrayImage,
        reference_rad: f64,
    ) -> Result<(Measurement, Option<Moments>), Error> {
        let mut buf = std::mem::take(&mut self.buf);
        let res = self
            .bg
            .darkening(frame, &mut buf.dark)
            .map(|()| self.measure_dark(&mut buf, reference_rad));
        self.buf = buf;
        res
    }

    /// The measurement, and the blob's moments when there is one.
    fn measure_dark(
        &self,
        buf: &mut Buffers,
        reference_rad: f64,
    ) -> (Measurement, Option<Moments>) {
        let (w, h) = (self.bg.width(), self.bg.height());
        let calib = &self.settings.calibration;
        let dark = &buf.dark;
        let threshold = threshold_level(self.settings.threshold, dark);
        buf.mask.clear();
        buf.mask.extend(dark.iter().map(|&d| d > threshold));
        let tip_r_px = 0.5 * self.settings.probe.tip_diameter_um / calib.mean_um_per_px();
        let open_px = self.settings.probe.max_half_width_um / calib.mean_um_per_px();
        let tip = separate_probe(&buf.mask, dark, &self.bg, open_px, tip_r_px, &mut buf.probe);
        // the rest lies within the mask's bounds (0 × 0 when the mask is empty)
        let roi = buf.probe.bounds;
        buf.rest.clear();
        buf.rest.resize(w * h, false);
        for y in roi.y0..roi.y1 {
            let span = y * w + roi.x0..y * w + roi.x1;
            let (m, n) = (&buf.mask[span.clone()], &buf.probe.needle[span.clone()]);
            for ((r, &m), &n) in buf.rest[span].iter_mut().zip(m).zip(n) {
                *r = m && !n;
            }
        }
        let comps = label_components_into(&buf.rest, w, h, roi, &mut buf.labels);
        let px_area = calib.sx_um_per_px * calib.sy_um_per_px;
        let min_px = (0.25 * self.expected.area_um2 / px_area) as usize;
        let peg = comps.iter().filter(|c| c.area >= min_px).max_by_key(|c| c.area);
        let blob = peg.map(|peg| Blob {
            peg,
            labels: &buf.labels,
            rest: &buf.rest,
            needle: &buf.probe.needle,
            depth: &buf.probe.depth,
        });
        let weighed =
            blob.map(|b| (b.peg.bbox, weigh(&b, dark, &self.bg, calib, self.settings.band_px)));
        let Some((bbox, weighed @ Weighed { moments: Some(moments), .. })) = weighed else {
            let (probe_tip_um, tip_flag) = self.tip(tip.as_ref(), None);
            let none = Measurement {
                pose: None,
                probe_tip_um,
                tip_flag,
                confidence: 0.0,
                flags: vec![Flag::NoPeg],
                threshold,
                area_um2: 0.0,
            };
            return (none, None);
        };
        let (pose, confidence, flags) = self.judge(&moments, bbox, &weighed, reference_rad);
        let area_um2 = moments.area_um2;
        let outline = self.settings.peg.transformed(&pose);
        let peg = PegView { outline: &outline, trusted: flags.is_empty() };
        let (probe_tip_um, tip_flag) = self.tip(tip.as_ref(), Some(peg));
        let m = Measurement {
            pose: Some(pose),
            probe_tip_um,
            tip_flag,
            confidence,
            flags,
            threshold,
            area_um2,
        };
        (m, Some(moments))
    }

    /// The tip placed against the peg seen (or withheld, with the reason); nothing without a
    /// needle.
    fn tip(
        &self,
        tip: Option<&LocatedTip>,
        peg: Option<PegView<'_>>,
    ) -> (Option<Vec2>, Option<TipFlag>) {
        let r_um = 0.5 * self.settings.probe.tip_diameter_um;
        match tip.map(|t| place_tip(t, &self.settings.calibration, peg, r_um)) {
            None => (None, None),
            Some(Ok(p)) => (Some(p), None),
            Some(Err(f)) => (None, Some(f)),
        }
    }

    /// The pose from the moments, its confidence and its flags.
    fn judge(
        &self,
        moments: &Moments,
        bbox: Roi,
        weighed: &Weighed,
        reference_rad: f64,
    ) -> (Pose, f64, Vec<Flag>) {
        let theta = nearest_branch(moments.major_axis_angle() - self.body_axis_rad, reference_rad);
        let pose = Pose::new(moments.centroid.x, moments.centroid.y, theta);
        let s = &self.settings;
        let mut confidence =
            shape_confidence(moments, &self.seen, s.area_tolerance, s.moment_tolerance);
        let mut flags = Vec::new();
        if self.near_border(bbox, &pose) {
            flags.push(Flag::OutOfField);
        }
        // Flush against a wall is fine when the whole peg is seen; a wall hiding part of it
        // shows as a shape that is a little off (or the blob reaching into the wall).
        if weighed.wall_px >= 3 || (weighed.wall_adjacent_px >= 3 && confidence < 0.9) {
            flags.push(Flag::Wall);
        }
        if weighed.occluded_px >= 12 {
            flags.push(Flag::ProbeOcclusion);
        }
        if confidence < s.min_confidence {
            flags.push(Flag::ShapeMismatch);
        }
        if moments.anisotropy() < 0.05 || self.expected.anisotropy() < 0.05 {
            flags.push(Flag::AmbiguousOrientation);
        }
        if !flags.is_empty() {
            confidence = confidence.min(FLAGGED_CONFIDENCE_CAP);
        }
        (pose, confidence, flags)
    }

    /// Whether the blob reaches the image border, or the peg's outline placed at the measured
    /// pose does (a peg cut by the border measures shifted inwards, but by less than the cut).
    fn near_border(&self, bbox: Roi, pose: &Pose) -> bool {
        let (w, h) = (self.bg.width(), self.bg.height());
        let b = self.settings.band_px;
        if bbox.x0 < b || bbox.y0 < b || bbox.x1 + b > w || bbox.y1 + b > h {
            return true;
        }
        let m = b as f64;
        let calib = &self.settings.calibration;
        self.settings.peg.transformed(pose).vertices().iter().any(|v| {
            let p = calib.um_to_px(v);
            p.x < m || p.y < m || p.x > w as f64 - m || p.y > h as f64 - m
        })
    }
}
