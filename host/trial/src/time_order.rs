//! The time order of a trial's rows. probe.csv is a schedule: a row earlier than the one
//! before it is a writer's bug and refused. pose.csv is a measurement, and real stamps jitter
//! (motion capture by up to 20 ms): a pose row stamped earlier than the last row kept, by at
//! most [`POSE_STEP_BACK_TOLERANCE_US`], is left out and reported in
//! [`crate::Trial::pose_rows_dropped`]; a larger step back is refused, naming the row. Equal
//! stamps are kept (as version 1 did).

use crate::Error;
use serde::Serialize;
use std::path::Path;

/// The largest step back in time a pose.csv row may take before the file is refused, µs.
pub const POSE_STEP_BACK_TOLERANCE_US: i64 = 20_000;

/// A pose.csv row the loader left out because its time went back.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct DroppedRow {
    /// Its line in the file (the header is line 1).
    pub line: u64,
    /// Its `t_us`.
    pub t_us: i64,
    /// The `t_us` of the last row kept before it.
    pub after_t_us: i64,
}

/// Refuses the first row of `path` whose `t_us` is earlier than the one before it.
pub(crate) fn check_ordered(path: &Path, rows: &[(u64, i64)]) -> Result<(), Error> {
    for (row, w) in rows.windows(2).enumerate() {
        let ((_, last), (line, t)) = (w[0], w[1]);
        if t < last {
            return Err(Error::parse(
                path,
                format!(
                    "row {} (line {line}): column t_us = {t} goes backwards (after {last}); \
                     rows must be in time order",
                    row + 2
                ),
            ));
        }
    }
    Ok(())
}

/// Keeps the rows of `path` in time order (see the module header), returning them and the
/// rows left out.
pub(crate) fn drop_steps_back<T>(
    path: &Path,
    rows: Vec<(u64, T)>,
    t_us: impl Fn(&T) -> i64,
) -> Result<(Vec<T>, Vec<DroppedRow>), Error> {
    let (mut kept, mut dropped) = (Vec::with_capacity(rows.len()), Vec::new());
    let mut last: Option<i64> = None;
    for (row, (line, r)) in rows.into_iter().enumerate() {
        let t = t_us(&r);
        match last {
            Some(l) if t < l => {
                let back = l.saturating_sub(t);
                if back > POSE_STEP_BACK_TOLERANCE_US {
                    return Err(Error::parse(
                        path,
                        format!(
                            "row {} (line {line}): column t_us = {t} goes back {back} µs (after \
                             {l}); allowed: at most {POSE_STEP_BACK_TOLERANCE_US} µs (such a \
                             row is dropped and counted)",
                            row + 1
                        ),
                    ));
                }
                dropped.push(DroppedRow { line, t_us: t, after_t_us: l });
            }
            _ => {
                last = Some(t);
                kept.push(r);
            }
        }
    }
    Ok((kept, dropped))
}
