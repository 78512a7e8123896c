//! One run file of the Zhou & Mason 2017 logs, parsed as written: per line `t_s, obj_x_mm,
//! obj_y_mm, obj_theta_rad, pusher_x_mm, pusher_y_mm, pusher_theta_rad, action` (Unix time,
//! table frame, the index of the push action). Nothing is converted or dropped here; a line
//! that does not parse is refused naming the file, line, field and value.

use crate::Error;
use mesopush_core::check::show;
use std::path::Path;

/// The columns of a run file, in order.
pub const COLUMNS: [&str; 8] = [
    "t_s",
    "obj_x_mm",
    "obj_y_mm",
    "obj_theta_rad",
    "pusher_x_mm",
    "pusher_y_mm",
    "pusher_theta_rad",
    "action",
];

/// What each numeric column allows (inclusive): Unix times from 1970 to year ~5000, table
/// positions within ±10 m, angles within ±10 000 rad (unwrapped angles stay far inside);
/// anything beyond is a corrupt file, not a push.
const ALLOWED: [(f64, f64, &str); 7] = [
    (0.0, 1e11, "s"),
    (-1e4, 1e4, "mm"),
    (-1e4, 1e4, "mm"),
    (-1e4, 1e4, "rad"),
    (-1e4, 1e4, "mm"),
    (-1e4, 1e4, "mm"),
    (-1e4, 1e4, "rad"),
];

/// One line of a run file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunRow {
    /// Its line in the file (1-based).
    pub line: u64,
    /// Unix time, s.
    pub t_s: f64,
    /// Object pose from vision: x mm, y mm, θ rad (all 0: vision had no pose).
    pub obj: [f64; 3],
    /// Hand pose from the robot: x mm, y mm, θ rad.
    pub hand: [f64; 3],
    /// The push action in use.
    pub action: i64,
}

impl RunRow {
    /// Whether vision had no pose for this row (the log writes the object as (0, 0, 0)).
    pub fn is_vision_dropout(&self) -> bool {
        self.obj == [0.0; 3]
    }
}

fn bad(path: &Path, line: u64, message: String) -> Error {
    Error::parse(path, format!("line {line}: {message}"))
}

/// Parses one non-empty line.
fn parse_line(path: &Path, line: u64, text: &str) -> Result<RunRow, Error> {
    let cells: Vec<&str> = text.split(',').map(str::trim).collect();
    if cells.len() != COLUMNS.len() {
        return Err(bad(
            path,
            line,
            format!(
                "{} fields; a run line has {}: {}",
                cells.len(),
                COLUMNS.len(),
                COLUMNS.join(", ")
            ),
        ));
    }
    let mut v = [0.0; 7];
    for (i, cell) in cells[..7].iter().enumerate() {
        let (lo, hi, unit) = ALLOWED[i];
        v[i] = match cell.parse::<f64>() {
            Ok(x) if x.is_finite() && (lo..=hi).contains(&x) => x,
            Ok(x) if x.is_finite() => {
                return Err(bad(
                    path,
                    line,
                    format!("field {} = {}; allowed: [{lo}, {hi}] {unit}", COLUMNS[i], show(x)),
                ));
            }
            _ => {
                return Err(bad(
                    path,
                    line,
                    format!("field {} = {cell:?}; allowed: a finite number", COLUMNS[i]),
                ));
            }
        };
    }
    let action = cells[7].parse::<i64>().map_err(|_| {
        bad(path, line, format!("field action = {:?}; allowed: an integer", cells[7]))
    })?;
    Ok(RunRow { line, t_s: v[0], obj: [v[1], v[2], v[3]], hand: [v[4], v[5], v[6]], action })
}

/// Reads every row of the run file `path` (blank lines skipped), refusing a file whose times
/// go backwards or that has fewer than two rows (the first is discarded on conversion).
pub fn read_run(path: &Path) -> Result<Vec<RunRow>, Error> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let mut rows: Vec<RunRow> = Vec::new();
    for (i, l) in text.lines().enumerate() {
        if l.trim().is_empty() {
            continue;
        }
        let row = parse_line(path, i as u64 + 1, l)?;
        if let Some(prev) = rows.last()
            && row.t_s < prev.t_s
        {
            return Err(bad(
                path,
                row.line,
                format!(
                    "field t_s = {} goes back from {} (line {}); allowed: times in order",
                    row.t_s, prev.t_s, prev.line
                ),
            ));
        }
        rows.push(row);
    }
    if rows.len() < 2 {
        return Err(Error::parse(
            path,
            format!("{} row(s); a run needs at least two (the first is discarded)", rows.len()),
        ));
    }
    Ok(rows)
}
