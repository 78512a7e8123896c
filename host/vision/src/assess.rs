//! Judging a measurement: the reasons a pose is not to be trusted (flags), a confidence from
//! how well the blob matches the peg's known shape, and orientation continuity across a
//! sequence (the ellipse fit only knows the axis, i.e. θ modulo π).

use std::f64::consts::PI;

use crate::moments::Moments;
use crate::tip::TipFlag;
use mesopush_core::geom::{Pose, Vec2};

/// Why a measurement is flagged as low-confidence.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Flag {
    /// No blob of the peg's size was found.
    NoPeg,
    /// The peg touches the image border: part of it is out of the field.
    OutOfField,
    /// The peg's blob overlaps a fixture wall (merged with it after subtraction).
    Wall,
    /// The probe's needle lies over the peg and hides part of it.
    ProbeOcclusion,
    /// The blob's area or second moments disagree with the peg's shape.
    ShapeMismatch,
    /// The peg's outline is too round for the ellipse to give an orientation.
    AmbiguousOrientation,
    /// The pose moved or turned more since the previous good frame than a push can.
    Jump,
}

impl Flag {
    /// The flag as written in pose.csv.
    pub fn as_str(&self) -> &'static str {
        match self {
            Flag::NoPeg => "no_peg",
            Flag::OutOfField => "out_of_field",
            Flag::Wall => "wall",
            Flag::ProbeOcclusion => "probe_occludes",
            Flag::ShapeMismatch => "shape_mismatch",
            Flag::AmbiguousOrientation => "ambiguous_orientation",
            Flag::Jump => "jump",
        }
    }
}

/// One frame's result.
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    /// The peg's pose in the fixture frame (µm, rad), `None` when no peg was found.
    pub pose: Option<Pose>,
    /// Centre of the probe tip's rounded end, fixture frame, µm: `None` when no needle was
    /// seen or when its tip was withheld (`tip_flag`).
    pub probe_tip_um: Option<Vec2>,
    /// Why a needle's tip that was seen is not reported (the image does not pin it down).
    pub tip_flag: Option<TipFlag>,
    /// 0 (no information) … 1 (blob matches the peg exactly). Flagged frames stay ≤ 0.25.
    pub confidence: f64,
    /// Why the pose should not be trusted; empty when it can be.
    pub flags: Vec<Flag>,
    /// The darkening threshold used (share of the plate's light).
    pub threshold: f32,
    /// Measured peg area, µm² (0 without a peg).
    pub area_um2: f64,
}

impl Measurement {
    /// Whether any flag is set.
    pub fn is_flagged(&self) -> bool {
        !self.flags.is_empty()
    }

    /// The flags joined with `;` (empty when none), as written in pose.csv.
    pub fn flag_text(&self) -> String {
        self.flags.iter().map(Flag::as_str).collect::<Vec<_>>().join(";")
    }
}

/// Highest confidence a flagged measurement may carry.
pub const FLAGGED_CONFIDENCE_CAP: f64 = 0.25;

/// Shape agreement in (0, 1]: a Gaussian score of the relative errors of the area and of the
/// two principal second moments against the peg's, with tolerances `area_tol`, `moment_tol`.
pub fn shape_confidence(
    measured: &Moments,
    expected: &Moments,
    area_tol: f64,
    moment_tol: f64,
) -> f64 {
    let (m1, m2) = measured.principal();
    let (e1, e2) = expected.principal();
    let da = measured.area_um2 / expected.area_um2 - 1.0;
    let d1 = m1 / e1 - 1.0;
    let d2 = m2 / e2 - 1.0;
    (-0.5 * ((da / area_tol).powi(2) + (d1 / moment_tol).powi(2) + (d2 / moment_tol).powi(2))).exp()
}

/// `theta` moved by a multiple of π to lie within π/2 of `reference`.
pub fn nearest_branch(theta: f64, reference: f64) -> f64 {
    theta - PI * ((theta - reference) / PI).round()
}

/// Whether `pose` is further from `prev` than one frame allows.
pub fn is_jump(pose: &Pose, prev: &Pose, max_step_um: f64, max_step_rad: f64) -> bool {
    (pose.position() - prev.position()).norm() > max_step_um
        || (pose.theta_rad - prev.theta_rad).abs() > max_step_rad
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn branch_follows_the_reference_across_the_half_turn() {
        assert!((nearest_branch(-1.5, 1.5) - (PI - 1.5)).abs() < 1e-12);
        assert!((nearest_branch(0.2, 0.0) - 0.2).abs() < 1e-12);
        assert!((nearest_branch(0.2, 2.0 * PI) - (0.2 + 2.0 * PI)).abs() < 1e-12);
    }

    #[test]
    fn confidence_drops_with_area_error() {
        let e = Moments { area_um2: 100.0, centroid: Vec2::zeros(), second: (10.0, 5.0, 0.0) };
        assert!((shape_confidence(&e, &e, 0.02, 0.02) - 1.0).abs() < 1e-12);
        let m = Moments { area_um2: 90.0, ..e };
        assert!(shape_confidence(&m, &e, 0.02, 0.02) < 0.01);
        let flags = Measurement {
            pose: None,
            probe_tip_um: None,
            tip_flag: None,
            confidence: 0.0,
            flags: vec![Flag::NoPeg, Flag::Wall],
            threshold: 0.2,
            area_um2: 0.0,
        };
        assert_eq!(flags.flag_text(), "no_peg;wall");
    }
}
