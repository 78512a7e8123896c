//! A tracked frame as the trial log stores it: the host tracker's measurement of one frame
//! as a pose.csv row, and angles folded for comparing tracked poses. Shared by the
//! completion of a recorded trial (`complete_trial`) and the in-process recorder (in the
//! drive module), so both write the same rows from the same measurement.

use mesopush_trial::PoseRow;
use mesopush_vision::Measurement;

/// The pose.csv row of frame `frame_index` captured at `t_us` (trial time), when the tracker
/// found the peg in it.
pub fn pose_row(t_us: i64, frame_index: u64, m: &Measurement) -> Option<PoseRow> {
    let pose = m.pose?;
    Some(PoseRow {
        t_us,
        x_um: pose.x_um,
        y_um: pose.y_um,
        theta_rad: pose.theta_rad,
        frame_index: Some(frame_index),
        residual_px: None,
        probe_tip_x_um: m.probe_tip_um.map(|t| t.x),
        probe_tip_y_um: m.probe_tip_um.map(|t| t.y),
    })
}

/// An angle folded into (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let r = a.rem_euclid(t);
    if r > std::f64::consts::PI { r - t } else { r }
}
