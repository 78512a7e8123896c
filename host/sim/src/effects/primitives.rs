//! The stateful and stateless primitives of the kinematic and measurement effects, shared by
//! the firmware simulator's world (which applies them to make data) and by diagnosis (which
//! applies them inside the extended model to explain data).

use mesopush_core::geom::{Pose, Vec2};

/// Lost motion of one stage axis: a deadband of full width `width_um` between the drive
/// (the commanded / encoder position) and the tip. The tip stays put until the drive has
/// taken up the slack, then follows it at `width/2` behind; a reversal loses `width` of
/// motion. The tip starts centred on the drive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BacklashAxis {
    half_um: f64,
    tip_um: Option<f64>,
}

impl BacklashAxis {
    /// An axis with a deadband of `width_um` (≥ 0; negative counts as 0).
    pub fn new(width_um: f64) -> Self {
        Self { half_um: width_um.max(0.0) / 2.0, tip_um: None }
    }

    /// Moves the drive to `drive_um` and returns where the tip is, µm.
    pub fn update(&mut self, drive_um: f64) -> f64 {
        let tip = match self.tip_um {
            None => drive_um,
            Some(t) => t.clamp(drive_um - self.half_um, drive_um + self.half_um),
        };
        self.tip_um = Some(tip);
        tip
    }
}

/// Backlash on both stage axes (x, y), independent per axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Backlash {
    axes: [BacklashAxis; 2],
}

impl Backlash {
    /// Deadband widths per axis [x, y], µm.
    pub fn new(width_um: [f64; 2]) -> Self {
        Self { axes: width_um.map(BacklashAxis::new) }
    }

    /// Moves the stage to `stage_um` and returns the tip position, µm.
    pub fn update(&mut self, stage_um: Vec2) -> Vec2 {
        Vec2::new(self.axes[0].update(stage_um.x), self.axes[1].update(stage_um.y))
    }

    /// The tip path for a whole commanded path (in order).
    pub fn apply(width_um: [f64; 2], stage_um: &[Vec2]) -> Vec<Vec2> {
        let mut b = Self::new(width_um);
        stage_um.iter().map(|s| b.update(*s)).collect()
    }
}

/// The timestamp a frame exposed at `capture_us` carries when the camera stamps it
/// `latency_us` late (stamp = capture + latency, rounded to the µs).
pub fn stamp_with_latency_us(capture_us: i64, latency_us: f64) -> i64 {
    capture_us + latency_us.round() as i64
}

/// A point as an image with scale error `err` [x, y] about `origin_um` measures it:
/// `origin + (p − origin)·(1 + err)`.
pub fn apply_scale_error(p_um: Vec2, err: [f64; 2], origin_um: [f64; 2]) -> Vec2 {
    Vec2::new(
        origin_um[0] + (p_um.x - origin_um[0]) * (1.0 + err[0]),
        origin_um[1] + (p_um.y - origin_um[1]) * (1.0 + err[1]),
    )
}

/// The inverse of [`apply_scale_error`]: the true point behind a measured one.
pub fn remove_scale_error(p_um: Vec2, err: [f64; 2], origin_um: [f64; 2]) -> Vec2 {
    Vec2::new(
        origin_um[0] + (p_um.x - origin_um[0]) / (1.0 + err[0]),
        origin_um[1] + (p_um.y - origin_um[1]) / (1.0 + err[1]),
    )
}

/// A peg pose as measured through a scale error: the centre maps like a point; the angle of
/// the body x axis changes by the aspect error, `atan2((1+ey) sin θ, (1+ex) cos θ)`.
pub fn scale_pose(pose: &Pose, err: [f64; 2], origin_um: [f64; 2]) -> Pose {
    let c = apply_scale_error(pose.position(), err, origin_um);
    let th = pose.theta_rad;
    let d = ((1.0 + err[1]) * th.sin()).atan2((1.0 + err[0]) * th.cos()) - th;
    // Keep the angle continuous with the true one (no 2π wrap).
    let d = (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    Pose::new(c.x, c.y, th + d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn backlash_loses_its_width_at_a_reversal_and_lags_by_half_of_it() {
        let mut a = BacklashAxis::new(10.0);
        assert_eq!(a.update(0.0), 0.0);
        assert_eq!(a.update(3.0), 0.0);
        assert_eq!(a.update(20.0), 15.0);
        // Reversal: the first 10 µm back move nothing.
        assert_eq!(a.update(12.0), 15.0);
        assert_eq!(a.update(10.0), 15.0);
        assert_eq!(a.update(4.0), 9.0);
    }

    #[test]
    fn scale_error_round_trips_and_is_zero_at_the_origin() {
        let o = [100.0, 50.0];
        let p = Vec2::new(1100.0, 2050.0);
        let m = apply_scale_error(p, [0.02, -0.01], o);
        assert!((m.x - 1120.0).abs() < 1e-9 && (m.y - 2030.0).abs() < 1e-9);
        assert!((remove_scale_error(m, [0.02, -0.01], o) - p).norm() < 1e-9);
        assert_eq!(
            apply_scale_error(Vec2::new(100.0, 50.0), [0.03, 0.03], o),
            Vec2::new(100.0, 50.0)
        );
        let pose = scale_pose(&Pose::new(0.0, 0.0, 0.5), [0.02, 0.02], [0.0, 0.0]);
        assert!((pose.theta_rad - 0.5).abs() < 1e-12, "isotropic scale keeps angles");
    }

    #[test]
    fn latency_stamps_late() {
        assert_eq!(stamp_with_latency_us(1_000, 49_999.6), 51_000);
    }
}
