//! What an import was asked to do and what it did: the options, one summary per run (also
//! the rows of `runs.csv`, the index written beside the trials) and the totals.

use super::convert::RowCounts;
use crate::Error;
use mesopush_core::fsx::write_atomic;
use serde::Serialize;
use std::path::Path;

/// The vision stream's lag behind the robot's, s: three independent estimates (hand/object
/// speed correlation, velocity correlation, settling after the hand stops) give 0.13–0.18.
pub const DEFAULT_VISION_LATENCY_S: f64 = 0.15;

/// The columns of `runs.csv`.
pub const INDEX_COLUMNS: [&str; 10] = [
    "trial_dir",
    "set_up",
    "start",
    "file",
    "file_rows",
    "first_row_dropped",
    "vision_dropouts",
    "stale_repeats",
    "pose_rows",
    "probe_rows",
];

/// How to import.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImportOptions {
    /// How much later than the hand pose the object pose of the same instant is logged, s;
    /// pose.csv stamps are moved earlier by this (0: keep the logged pairing).
    pub vision_latency_s: f64,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self { vision_latency_s: DEFAULT_VISION_LATENCY_S }
    }
}

impl ImportOptions {
    /// Refuses a latency that is not a finite number in [0, 1] s.
    pub fn validate(&self) -> Result<(), Error> {
        let l = self.vision_latency_s;
        if !(l.is_finite() && (0.0..=1.0).contains(&l)) {
            return Err(Error::invalid(
                "vision latency",
                format!("{l} s; allowed: a number of seconds in [0, 1]"),
            ));
        }
        Ok(())
    }
}

/// One imported run (a row of runs.csv).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunSummary {
    /// The trial directory, relative to the output folder (also the trial id).
    pub trial_dir: String,
    /// The set-up folder's name.
    pub set_up: String,
    /// The start condition (`x_mm_y_mm_theta_deg` relative to the goal, `neg` = minus).
    pub start: String,
    /// The run file, relative to the data root (`<set-up>/<start folder>/log….txt`).
    pub file: String,
    /// Where its rows went.
    #[serde(flatten)]
    pub counts: RowCounts,
}

/// The whole import.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImportReport {
    /// Every run, in file order.
    pub runs: Vec<RunSummary>,
    /// The counts summed over the runs.
    pub totals: RowCounts,
    /// The options used.
    pub vision_latency_s: f64,
}

impl ImportReport {
    /// The report of `runs`.
    pub fn new(runs: Vec<RunSummary>, options: &ImportOptions) -> Self {
        let mut t = RowCounts {
            file_rows: 0,
            first_row_dropped: 0,
            vision_dropouts: 0,
            stale_repeats: 0,
            pose_rows: 0,
            probe_rows: 0,
        };
        for r in &runs {
            let c = r.counts;
            t.file_rows += c.file_rows;
            t.first_row_dropped += c.first_row_dropped;
            t.vision_dropouts += c.vision_dropouts;
            t.stale_repeats += c.stale_repeats;
            t.pose_rows += c.pose_rows;
            t.probe_rows += c.probe_rows;
        }
        Self { runs, totals: t, vision_latency_s: options.vision_latency_s }
    }

    /// Writes the runs as `path` (CSV, one row per run: [`RunSummary`] with its counts
    /// flattened), atomically.
    pub fn write_index(&self, path: &Path) -> Result<(), Error> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(INDEX_COLUMNS).map_err(|e| Error::parse(path, e))?;
        for r in &self.runs {
            let c = r.counts;
            let row = (
                &r.trial_dir,
                &r.set_up,
                &r.start,
                &r.file,
                (c.file_rows, c.first_row_dropped, c.vision_dropouts),
                (c.stale_repeats, c.pose_rows, c.probe_rows),
            );
            w.serialize(row).map_err(|e| Error::parse(path, e))?;
        }
        let bytes = w.into_inner().map_err(|e| Error::parse(path, e))?;
        Ok(write_atomic(path, &bytes)?)
    }
}
