//! Writes a replay's trajectory as CSV a pandas user can load:
//! `t_s, move, probe_x_um, probe_y_um, peg_x_um, peg_y_um, peg_theta_rad, probe_force, contacts`.

use super::replay::Replay;
use crate::Error;
use std::io::Write;
use std::path::Path;

/// The CSV header line.
pub const HEADER: &str =
    "t_s,move,probe_x_um,probe_y_um,peg_x_um,peg_y_um,peg_theta_rad,probe_force,contacts";

/// Writes the trajectory to `w`.
pub fn write_csv(replay: &Replay, mut w: impl Write) -> std::io::Result<()> {
    writeln!(w, "{HEADER}")?;
    for s in &replay.samples {
        writeln!(
            w,
            "{:.6},{},{:.4},{:.4},{:.4},{:.4},{:.8},{:.6},{}",
            s.t_s,
            s.move_index,
            s.probe_um[0],
            s.probe_um[1],
            s.peg.x_um,
            s.peg.y_um,
            s.peg.theta_rad,
            s.probe_force,
            s.contacts
        )?;
    }
    Ok(())
}

/// Writes the trajectory CSV to a file.
pub fn save_csv(replay: &Replay, path: &Path) -> Result<(), Error> {
    let f = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
    let mut w = std::io::BufWriter::new(f);
    write_csv(replay, &mut w).and_then(|()| w.flush()).map_err(|e| Error::io(path, e))
}
