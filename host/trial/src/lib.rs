//! Trial logs: one directory per trial, the measured data every later stage reads
//! (identification, diagnosis, batch reports). The format is documented, versioned and
//! pandas-friendly (`docs/trial-log.md`): `trial.json` metadata, `probe.csv`, `frames.csv`,
//! `events.csv`, `pose.csv`, and the frames in one multi-page TIFF, `frames.tif`
//! (`mesopush_framestore`; older trials: PNG files under `frames/`). [`import`] converts
//! foreign recordings of real pushes into the same format.
//!
//! Time: every `t_us` column is microseconds since the trial's start (the executor's time
//! base for the project's own trials); lengths in µm, angles in rad.
//!
//! May depend on: `mesopush-protocol` (unit conversions), `mesopush-core`, `mesopush-sim` (the
//! part, pusher, plan and fixture a trial records), `mesopush-vision` (its calibration) and
//! the executor's recording schema and frame store (`mesopush-framestore`). Never on
//! identification, planning, diagnosis, the rig or batches, which all read trial logs.

pub mod calib_file;
mod csv_read;
pub mod discover;
pub mod error;
pub mod import;
pub mod meta;
pub mod pusher_path;
pub mod reader;
pub mod records;
pub mod retention;
pub mod time_order;
pub mod writer;

pub use calib_file::CalibrationFile;
pub use discover::trial_dirs;
pub use error::Error;
pub use meta::{CalibrationRecord, Outcome, TrialMeta, TrialState};
pub use reader::Trial;
pub use records::{EventRow, FrameRow, PoseRow, ProbeRow};
pub use retention::{FrameRetention, FramesKept};
pub use time_order::DroppedRow;
pub use writer::TrialWriter;

/// The format's name in `trial.json`.
pub const FORMAT: &str = "mesopush-trial";
/// The format version this build writes (and the newest it reads).
pub const FORMAT_VERSION: u32 = 2;
/// The oldest format version this build reads (version 1: one probe disc, `probe_radius_um`).
pub const OLDEST_FORMAT_VERSION: u32 = 1;

/// File names inside a trial directory.
pub mod files {
    /// Metadata.
    pub const META: &str = "trial.json";
    /// Probe positions.
    pub const PROBE: &str = "probe.csv";
    pub use mesopush_executor::recording::files::{EVENTS, FRAME_DIR, FRAMES, RECORDING_JSON};
    /// Tracked peg poses.
    pub const POSE: &str = "pose.csv";
}
