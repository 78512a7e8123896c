//! The rows of a trial's CSV files. Column names are the field names; empty cells are
//! missing values (pandas reads them as NaN). `frames.csv` and `events.csv` are the
//! executor's recording ([`mesopush_executor::recording`], defined once there); `probe.csv`
//! and `pose.csv` are the host's.

pub use mesopush_executor::recording::{EventRow, FrameRow};
use serde::{Deserialize, Serialize};

/// `probe.csv`: the probe, commanded (the executor's setpoint schedule) and as the
/// controller reported it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ProbeRow {
    /// Time since the trial's start, µs (executor time base).
    pub t_us: i64,
    /// Commanded probe x, µm.
    pub cmd_x_um: f64,
    /// Commanded probe y, µm.
    pub cmd_y_um: f64,
    /// Reported (encoder) probe x, µm; empty when no report belongs to this row.
    pub rep_x_um: Option<f64>,
    /// Reported probe y, µm.
    pub rep_y_um: Option<f64>,
}

/// `pose.csv`: the tracked peg pose per frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseRow {
    /// Capture time of the frame, µs since the trial's start.
    pub t_us: i64,
    /// Peg centre x, µm.
    pub x_um: f64,
    /// Peg centre y, µm.
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
