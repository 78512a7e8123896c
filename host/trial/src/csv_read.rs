//! Reading a trial's CSV files so that a refused row says where and why: the file, the row
//! and line, the column, the value and what is allowed. Parsing never panics on input; a
//! value that parses but is not allowed (a non-finite number) is refused the same way.

use crate::Error;
use crate::records::{EventRow, FrameRow, PoseRow, ProbeRow};
use serde::de::DeserializeOwned;
use std::path::Path;

/// A value a row refuses: its column, the value as read, and what is allowed.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Refusal {
    pub(crate) column: &'static str,
    pub(crate) value: String,
    pub(crate) allowed: &'static str,
}

/// A CSV row that knows which of its parsed values it refuses.
pub(crate) trait CheckedRow: DeserializeOwned {
    /// The first refused value, if any.
    fn refusal(&self) -> Option<Refusal>;
}

const FINITE: &str = "a finite number";

/// The first of `values` (column, value) that is not finite.
fn first_non_finite(values: &[(&'static str, Option<f64>)]) -> Option<Refusal> {
    values.iter().find_map(|&(column, v)| match v {
        Some(v) if !v.is_finite() => {
            Some(Refusal { column, value: v.to_string(), allowed: FINITE })
        }
        _ => None,
    })
}

impl CheckedRow for ProbeRow {
    fn refusal(&self) -> Option<Refusal> {
        first_non_finite(&[
            ("cmd_x_um", Some(self.cmd_x_um)),
            ("cmd_y_um", Some(self.cmd_y_um)),
            ("rep_x_um", self.rep_x_um),
            ("rep_y_um", self.rep_y_um),
            ("cmd_theta_rad", self.cmd_theta_rad),
        ])
    }
}

impl CheckedRow for PoseRow {
    fn refusal(&self) -> Option<Refusal> {
        first_non_finite(&[
            ("x_um", Some(self.x_um)),
            ("y_um", Some(self.y_um)),
            ("theta_rad", Some(self.theta_rad)),
        ])
    }
}

impl CheckedRow for FrameRow {
    fn refusal(&self) -> Option<Refusal> {
        None
    }
}

impl CheckedRow for EventRow {
    fn refusal(&self) -> Option<Refusal> {
        None
    }
}

/// A row's place in its file, as messages give it.
fn place(row: usize, line: u64) -> String {
    format!("row {row} (line {line})")
}

/// The message for a CSV error at data row `row` (1-based), naming the column and value
/// when the error belongs to one.
fn csv_message(
    e: &csv::Error,
    row: usize,
    headers: &csv::StringRecord,
    rec: &csv::StringRecord,
) -> String {
    let line = e.position().map_or(row as u64 + 1, |p| p.line());
    match e.kind() {
        csv::ErrorKind::Deserialize { err, .. } => match err.field() {
            Some(i) => {
                let i = usize::try_from(i).unwrap_or(usize::MAX);
                format!(
                    "{}: column {} = {:?}: {}",
                    place(row, line),
                    headers.get(i).unwrap_or("?"),
                    rec.get(i).unwrap_or(""),
                    err.kind()
                )
            }
            None => format!("{}: {}", place(row, line), err.kind()),
        },
        csv::ErrorKind::UnequalLengths { expected_len, len, .. } => format!(
            "{}: {len} fields, but the header has {expected_len}; every row has one cell per \
             column (empty for a missing value)",
            place(row, line)
        ),
        _ => format!("{}: {e}", place(row, line)),
    }
}

/// Reads every row of `path` with its line number. A missing file is an error when
/// `required`, else `None`.
pub(crate) fn read_csv<T: CheckedRow>(
    path: &Path,
    required: bool,
) -> Result<Option<Vec<(u64, T)>>, Error> {
    if !path.exists() {
        return if required {
            Err(Error::io(path, std::io::ErrorKind::NotFound.into()))
        } else {
            Ok(None)
        };
    }
    let mut r = csv::Reader::from_path(path).map_err(|e| Error::parse(path, e))?;
    let headers = r.headers().map_err(|e| Error::parse(path, format!("header: {e}")))?.clone();
    let mut rows = Vec::new();
    let mut rec = csv::StringRecord::new();
    for row in 1.. {
        match r.read_record(&mut rec) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => return Err(Error::parse(path, csv_message(&e, row, &headers, &rec))),
        }
        let line = rec.position().map_or(row as u64 + 1, |p| p.line());
        let parsed: T = rec
            .deserialize(Some(&headers))
            .map_err(|e| Error::parse(path, csv_message(&e, row, &headers, &rec)))?;
        if let Some(f) = parsed.refusal() {
            return Err(Error::parse(
                path,
                format!(
                    "{}: column {} = {}: allowed: {}",
                    place(row, line),
                    f.column,
                    f.value,
                    f.allowed
                ),
            ));
        }
        rows.push((line, parsed));
    }
    Ok(Some(rows))
}
