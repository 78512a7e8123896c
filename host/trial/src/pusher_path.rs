//! The commanded pusher path in probe.csv: the pusher's reference point and, from format
//! version 2, its angle (`cmd_theta_rad`; read into `mesopush_sim::ProbePoint` by
//! `Trial::commanded_path`). The angle column is all or nothing: absent, or
//! empty on every row, means θ = 0 throughout; filled on some rows but not others is refused,
//! naming the first row without it, because guessing an angle there would invent a motion.

use crate::Error;
use crate::records::ProbeRow;
use std::path::Path;

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
