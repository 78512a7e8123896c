//! The world's ground truth in the trial log (firmware simulator only): `truth.csv`, the true
//! peg pose, probe tip and needle deflection at every exposure, and a `jam` event for every
//! jam episode of the world (the peg wedged and the needle bent beyond the limit).

use super::truth::TruthSample;
use crate::Error;
use mesopush_trial::{EventRow, TrialWriter};
use std::path::Path;

/// `truth.csv` (firmware simulator only; see docs/trial-log.md): the true peg pose and probe
/// tip at every exposure, `t_us` since the trial's start like every other file.
pub(crate) fn write_truth(dir: &Path, truth: &[TruthSample], t0_us: u64) -> Result<(), Error> {
    let path = dir.join("truth.csv");
    let mut text = String::from("t_us,x_um,y_um,theta_rad,probe_x_um,probe_y_um,deflection_um\n");
    for s in truth {
        let t = s.t_us as i64 - t0_us as i64;
        text.push_str(&format!(
            "{t},{},{},{},{},{},{}\n",
            s.peg.x_um, s.peg.y_um, s.peg.theta_rad, s.probe_um.x, s.probe_um.y, s.deflection_um
        ));
    }
    Ok(mesopush_core::fsx::write_atomic(&path, text.as_bytes())?)
}

/// A `jam` event for every jam episode the world began (at the first exposure that shows
/// it, with the largest deflection filmed during it, against the needle's `limit_um`);
/// returns the number of episodes.
pub(crate) fn write_jams(
    writer: &mut TrialWriter,
    truth: &[TruthSample],
    t0_us: i64,
    limit_um: f64,
) -> Result<u32, Error> {
    let mut seen = 0;
    for (i, s) in truth.iter().enumerate() {
        if s.jams <= seen {
            continue;
        }
        seen = s.jams;
        let peak = truth[i..]
            .iter()
            .take_while(|n| n.jams == s.jams && n.deflection_um > 0.0)
            .map(|n| n.deflection_um)
            .fold(s.deflection_um, f64::max);
        let p = s.peg;
        let detail = format!(
            "needle deflected {peak:.0} µm (limit {limit_um:.0} µm): peg wedged \
             at ({:.0}, {:.0}) µm, {:.1}°",
            p.x_um,
            p.y_um,
            p.theta_rad.to_degrees()
        );
        writer.event(&EventRow { t_us: s.t_us as i64 - t0_us, kind: "jam".into(), detail })?;
    }
    Ok(seen)
}
