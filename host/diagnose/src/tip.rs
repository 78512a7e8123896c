//! The imaged probe tip's residual, as far as a tracker can vouch for it. The imaged tip
//! carries what the peg alone cannot show (the stage's lost motion, a needle bending under
//! load, a late time stamp on a free probe), but a tracker sees a free tip, a tip touching the
//! peg and a tip just short of it very differently; this module says which part of each
//! frame's tip residual is evidence, from measured quantities only (the commanded probe and
//! the measured peg), so the selection never depends on the model being fitted.

use super::data::{Measured, TrialData};
use super::memo::cached;
use super::predict::{Prediction, probe_at};
use mesopush_core::geom::Vec2;
use mesopush_core::stats;
use mesopush_sim::contact::closest_on_polygon;
use std::convert::Infallible;

/// Fewest free frames with an imaged tip that estimate a trial's tip registration offset.
pub(crate) const MIN_REGISTRATION_FRAMES: usize = 3;

/// Where the commanded probe is relative to the measured peg in a frame (both measured, so
/// which frames count, and how, does not depend on the model being fitted).
#[derive(Debug, Clone, Copy, PartialEq)]
enum TipZone {
    /// Clear of the peg's outline by at least a tip radius: the tip is imaged on its own.
    Free,
    /// Within a tip radius of the outline: the tip's image merges with the peg's, and a
    /// tracker cannot tell touching from a small gap.
    Near,
    /// At the outline or pressing into it (by up to a tip radius of contact allowance), with
    /// the outline's outward normal there.
    Touching(Vec2),
}

/// A gap below this fraction of the tip radius counts as touching.
const TOUCH_FRACTION: f64 = 0.2;

fn tip_zone(data: &TrialData, m: &Measured) -> TipZone {
    let cmd = probe_at(&data.cmd, m.t_s);
    let outline = data.part.polygon().transformed(&m.pose);
    let (dist_um, _, n_out) = closest_on_polygon(&outline, &cmd);
    let gap_um = dist_um - data.probe_radius_um;
    if gap_um <= TOUCH_FRACTION * data.probe_radius_um {
        TipZone::Touching(n_out)
    } else if gap_um < data.probe_radius_um {
        TipZone::Near
    } else {
        TipZone::Free
    }
}

/// The imaged-tip residual of every frame (measured minus predicted), as far as a tracker
/// can vouch for it, by where the commanded probe is relative to the measured peg:
/// - **free, registered**: the trial's median free residual is subtracted — a constant
///   offset between where the stage says the tip is and where the image shows it is a
///   calibration (or the tracker's sub-pixel bias on a free tip, about (−0.8, +1.5) µm on
///   the simulated rig), not a missing effect; an effect's signature (a lag after reversals,
///   a lag while moving, a scale across the plate) varies within the trial and stays;
/// - **near, dropped**: within a tip radius of the peg the tip's image merges with the
///   peg's, and a tracker cannot tell a small gap from touching (the clean simulated rig:
///   10–14 µm off along the shaft);
/// - **touching, the normal component only**: the tracker puts a touching tip against the
///   imaged outline (so no free-tip offset applies), and where it sits *along* the edge
///   comes from the needle's shaft, several µm off (clean simulated rig: 2–4 µm); a needle's
///   deflection under load, or a stage's lost motion while pushing, lies along the normal.
pub fn tip_residuals(data: &TrialData, pred: &Prediction) -> Vec<Option<[f64; 2]>> {
    let zones = zones(data);
    let raw: Vec<Option<Vec2>> = data
        .frames
        .iter()
        .enumerate()
        .map(|(i, m)| m.tip_um.map(|t| t - pred.tips_um[i]))
        .collect();
    let free = |a: usize| -> Vec<f64> {
        raw.iter()
            .zip(zones.iter())
            .filter_map(|(d, z)| if *z == TipZone::Free { d.map(|d| d[a]) } else { None })
            .collect()
    };
    let offset = match (median(free(0)), median(free(1))) {
        (Some(x), Some(y)) => Vec2::new(x, y),
        _ => Vec2::zeros(),
    };
    raw.iter()
        .zip(zones.iter())
        .map(|(d, z)| {
            let d = (*d)?;
            let d = match z {
                TipZone::Free => d - offset,
                TipZone::Near => return None,
                TipZone::Touching(n) => n * d.dot(n),
            };
            Some([d.x, d.y])
        })
        .collect()
}

/// Where the commanded probe is relative to the measured peg in every frame: the trial's
/// alone, the same at every evaluation, so kept ([`super::memo`]).
fn zones(data: &TrialData) -> std::sync::Arc<Vec<TipZone>> {
    let Ok(zones) = cached(data, "tip_zones", || {
        Ok::<_, Infallible>(data.frames.iter().map(|m| tip_zone(data, m)).collect::<Vec<_>>())
    });
    zones
}

/// The frames whose imaged tip is free of the peg (clear of its measured outline by a tip
/// radius) and tracked, in order: where the image shows the tip on its own, so its place
/// depends on the stage and the camera only, never on the part's physics
/// ([`crate::free_tip`]).
pub fn free_tip_frames(data: &TrialData) -> Vec<usize> {
    zones(data)
        .iter()
        .enumerate()
        .filter(|(k, z)| **z == TipZone::Free && data.frames[*k].tip_um.is_some())
        .map(|(k, _)| k)
        .collect()
}

/// The median of `v` ([`mesopush_core::stats::median`]: the mean of the middle two for an
/// even count) when it has at least [`MIN_REGISTRATION_FRAMES`] values.
pub(crate) fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.len() < MIN_REGISTRATION_FRAMES {
        return None;
    }
    stats::median(&mut v)
}
