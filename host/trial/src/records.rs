//! The rows of a trial's CSV files. Column names are the field names; empty cells are
//! missing values (pandas reads them as NaN). `frames.csv` and `events.csv` are the
//! executor's recording ([`mesopush_executor::recording`], defined once there); `probe.csv`
//! and `pose.csv` are the host's.

pub use mesopush_executor::recording::{EventRow, FrameRow};
use serde::{Deserialize, Serialize};

/// `probe.csv`: the pusher's reference point (the origin of its frame, `trial.json` `pusher`)
/// and angle, commanded (the executor's setpoint schedule; interpolated linearly between
/// rows), and the position the controller reported.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ProbeRow {
    /// Time since the trial's start, µs (executor time base).
    pub t_us: i64,
    /// Commanded x of the pusher's reference point, µm.
    pub cmd_x_um: f64,
    /// Commanded y of the pusher's reference point, µm.
    pub cmd_y_um: f64,
    /// Reported (encoder) probe x, µm; empty when no report belongs to this row.
    pub rep_x_um: Option<f64>,
    /// Reported probe y, µm.
    pub rep_y_um: Option<f64>,
    /// Commanded pusher angle, rad (format version 2, optional column): absent, or empty on
    /// every row, means 0 throughout; filled on one row means filled on every row. Written
    /// only when set (so a trial without it keeps version 1's five columns).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cmd_theta_rad: Option<f64>,
}

/// `pose.csv`: the tracked peg pose per frame: the position of the part's body-frame origin
/// (its COM: the area centroid of `part.vertices_um`, or `com_um`) and its angle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseRow {
    /// Capture time of the frame, µs since the trial's start.
    pub t_us: i64,
    /// Peg COM x, µm.
    pub x_um: f64,
    /// Peg COM y, µm.
    pub y_um: f64,
    /// Peg orientation, rad.
    pub theta_rad: f64,
    /// The frame's row index in frames.csv, when tracked from frames.
    pub frame_index: Option<u64>,
    /// RMS edge residual of the fit, px, when tracked from frames.
    pub residual_px: Option<f64>,
    /// The probe tip as imaged, x, µm, when the tracker found it (absent in older logs).
    #[serde(default)]
    pub probe_tip_x_um: Option<f64>,
    /// The probe tip as imaged, y, µm.
    #[serde(default)]
    pub probe_tip_y_um: Option<f64>,
}
