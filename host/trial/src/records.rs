//! The rows of a trial's CSV files. Column names are the field names; empty cells are
//! missing values (pandas reads them as NaN).

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

/// `frames.csv`: one row per camera frame, received or detected as dropped.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameRow {
    /// Row index (0, 1, 2, ... in arrival order).
    pub index: u64,
    /// The camera's frame counter.
    pub frame_seq: u32,
    /// Capture (exposure) time, µs since the trial's start; empty for dropped frames.
    pub t_capture_us: Option<i64>,
    /// Arrival time at the executor, µs since the trial's start; empty for dropped frames.
    pub t_arrival_us: Option<i64>,
    /// Where `t_capture_us` came from: `driver` (the source's own stamp) or `arrival`.
    pub stamp_source: String,
    /// The frame was lost (a gap in `frame_seq`, or the recorder fell behind).
    pub dropped: bool,
    /// The frame arrived but was black (no image).
    pub black: bool,
    /// Probe x at the capture instant, as the executor estimated it, µm.
    pub probe_x_um: Option<f64>,
    /// Probe y at the capture instant, µm.
    pub probe_y_um: Option<f64>,
    /// PNG file relative to the trial directory; empty when not stored.
    pub file: Option<String>,
}

/// `events.csv`: faults, aborts, verdicts and anything else worth a line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EventRow {
    /// Time since the trial's start, µs.
    pub t_us: i64,
    /// Short kind, e.g. `started`, `done`, `fault`, `frame_dropped`, `verdict`.
    pub kind: String,
    /// Free text.
    pub detail: String,
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
