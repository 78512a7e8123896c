//! The loop in real time (filled in below).
use super::trial::{Progress, TrialReport, TrialSpec};
use crate::Error;
use std::path::Path;

/// Runs a trial in real time.
pub fn run_realtime(
    _spec: &TrialSpec,
    _out_dir: &Path,
    _progress: &mut dyn FnMut(Progress),
) -> Result<TrialReport, Error> {
    Err(Error::invalid("clock", "real-time mode is not built yet"))
}
