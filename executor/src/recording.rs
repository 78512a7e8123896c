//! The recording schema, defined once: the rows of `frames.csv` and `events.csv` and the
//! `recording.json` marker that the executor's recorder writes, and that the host's trial log
//! (`mesopush-trial`) reads and writes with the same types — the executor never depends on
//! the host, so the definition lives here and the host builds on it. Column names are the
//! field names (serde); empty cells are missing values (pandas reads them as NaN). Documented
//! in `docs/trial-log.md`.

use serde::{Deserialize, Serialize};
use std::string::String;

/// File and directory names inside a trial directory that the recorder writes.
pub mod files {
    /// Camera frames.
    pub const FRAMES: &str = "frames.csv";
    /// Events (faults, aborts, verdicts).
    pub const EVENTS: &str = "events.csv";
    /// Directory of PNG frames (trials recorded before the frame store; read, no longer
    /// written: frames go to `frames.tif`, `mesopush_framestore`).
    pub const FRAME_DIR: &str = "frames";
    /// The raw recording's marker, written atomically when the directory is closed.
    pub const RECORDING_JSON: &str = "recording.json";
}

/// `recording.json`'s format name.
pub const RECORDING_FORMAT: &str = "mesopush-exec-recording";
/// `recording.json`'s format version.
pub const RECORDING_FORMAT_VERSION: u32 = 1;

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
    /// Where `t_capture_us` came from: `driver` (the source's own stamp) or `arrival`;
    /// empty for dropped frames.
    pub stamp_source: String,
    /// The frame was lost (a gap in `frame_seq`, or the recorder fell behind).
    pub dropped: bool,
    /// The frame arrived but was black (no image).
    pub black: bool,
    /// Probe x at the capture instant, as the executor estimated it, µm.
    pub probe_x_um: Option<f64>,
    /// Probe y at the capture instant, µm.
    pub probe_y_um: Option<f64>,
    /// Where the image is: `frames.tif#PAGE` (the trial's frame store) or, in trials recorded
    /// before it, a PNG file relative to the trial directory; empty when not stored.
    pub file: Option<String>,
}

impl FrameRow {
    /// The row of a frame detected as missing (a gap in the frame counter).
    pub fn dropped(index: u64, frame_seq: u32) -> Self {
        Self {
            index,
            frame_seq,
            t_capture_us: None,
            t_arrival_us: None,
            stamp_source: String::new(),
            dropped: true,
            black: false,
            probe_x_um: None,
            probe_y_um: None,
            file: None,
        }
    }
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

/// `recording.json`: which trial, the executor clock's epoch, counts, how it ended.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Recording {
    /// [`RECORDING_FORMAT`].
    pub format: String,
    /// [`RECORDING_FORMAT_VERSION`].
    pub format_version: u32,
    /// The flashed plan's id.
    pub plan_id: u32,
    /// The trial's start on the executor clock, µs.
    pub t0_exec_us: u64,
    /// The executor clock's epoch on `CLOCK_MONOTONIC`, µs.
    pub exec_epoch_mono_us: u64,
    /// How the trial ended: `done`, `aborted`, `faulted`, or `none` (not seen).
    pub end: String,
    /// For a faulted trial, what happened and what to try, in words.
    #[serde(default)]
    pub end_reason: Option<String>,
    /// When it ended, µs since the trial's start.
    pub end_t_us: Option<i64>,
    /// Whether the recorder saw the end and the tail after it.
    pub complete: bool,
    /// Frames recorded.
    pub frames: u64,
    /// Frames missing from the camera's counter.
    pub dropped_frames: u64,
    /// Frames whose image never reached the recorder.
    pub images_missing: u64,
}
