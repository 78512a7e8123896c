//! The commanded pusher path in probe.csv: the pusher's reference point and, from format
//! version 2, its angle (`cmd_theta_rad`). The angle column is all or nothing: absent, or
//! empty on every row, means θ = 0 throughout; filled on some rows but not others is refused,
//! naming the first row without it, because guessing an angle there would invent a motion.

use crate::Error;
use crate::records::ProbeRow;
use serde::Serialize;
use std::path::Path;

/// One waypoint of the commanded pusher path (linear interpolation between waypoints).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PusherPoint {
    /// Time since the trial's start, s.
    pub t_s: f64,
    /// The pusher's reference point (its frame's origin), x, µm.
    pub x_um: f64,
    /// The reference point, y, µm.
    pub y_um: f64,
    /// The pusher's angle (its frame's x axis from the world's, towards +y), rad.
    pub theta_rad: f64,
}

/// Refuses a probe.csv whose `cmd_theta_rad` is filled on some rows and empty on others.
pub(crate) fn check_theta_column(path: &Path, rows: &[(u64, ProbeRow)]) -> Result<(), Error> {
    let Some((first_line, first)) = rows.iter().find(|(_, r)| r.cmd_theta_rad.is_some()) else {
        return Ok(());
    };
    if let Some((row, (line, _))) =
        rows.iter().enumerate().find(|(_, (_, r))| r.cmd_theta_rad.is_none())
    {
        return Err(Error::parse(
            path,
            format!(
                "row {} (line {line}): column cmd_theta_rad is empty, but line {first_line} \
                 gives {}; allowed: a value on every row, or on none (θ = 0 throughout)",
                row + 1,
                first.cmd_theta_rad.unwrap_or_default()
            ),
        ));
    }
    Ok(())
}

/// The commanded path of `rows` (θ = 0 where the column is absent).
pub(crate) fn pusher_path(rows: &[ProbeRow]) -> Vec<PusherPoint> {
    rows.iter()
        .map(|r| PusherPoint {
            t_s: r.t_us as f64 * 1e-6,
            x_um: r.cmd_x_um,
            y_um: r.cmd_y_um,
            theta_rad: r.cmd_theta_rad.unwrap_or(0.0),
        })
        .collect()
}
