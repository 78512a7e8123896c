//! Placing the probe tip, or withholding it. The needle's end is located from the darkening
//! mass where its silhouette ends ([`crate::probe`]); this module decides whether the image
//! pins that end down. A tip it does not pin down is withheld with a [`TipFlag`]: no tip is
//! better than a wrong one, because `diagnose` reads the imaged tip as a measurement.
//!
//! The rules, each from the geometry of a straight needle that cannot enter the peg:
//! - The tip of a straight needle lies on its axis. A located tip more than a pixel from the
//!   axis of the shaft just behind it is a piece of something else (a corner of the peg that
//!   the opening took away with the needle): [`TipFlag::OffAxis`].
//! - A tip whose round end overlaps the peg's outline (at the measured pose) by more than the
//!   contact band is not where a needle can be: [`TipFlag::InsidePeg`].
//! - Plate seen just beyond the tip (all around its front half, 1.5 px out): its end is seen
//!   against the plate, and the located tip is reported as it is.
//! - Otherwise the tip's silhouette merges with the peg's (they join within about the band,
//!   1.5 px), and either the tip touches the peg (its silhouette's end is then cut short by
//!   the peg's pixels) or it stops within the band of it (the located end is right). The two
//!   readings give two places along the shaft: the located end, and the contact, where the
//!   tip moved along its shaft meets the outline. Where they agree within the band the tip is
//!   pinned down either way and is reported midway; where they do not, the image cannot tell
//!   which holds: [`TipFlag::Unconfirmed`]. The contact is only defined where the shaft meets
//!   the outline steeply: within 30° of the outline (`|d gap / d s|` < 1/2, so that a band
//!   of gap spans more than two bands along the shaft) the tip is [`TipFlag::Grazing`].
//! - A merged tip with no trusted outline to meet (the peg's pose flagged, or no peg, the
//!   tip merged with a wall): [`TipFlag::Merged`].

use crate::calib::Calibration;
use mesopush_core::geom::{ConvexPolygon, Vec2};

/// A merged tip touches the peg or stops within this many pixels of its outline.
const BAND_PX: f64 = 1.5;
/// A located tip further than this from the shaft's axis just behind it is withheld, px.
const MAX_OFF_AXIS_PX: f64 = 1.0;
/// A contact where a band of gap spans more than this many bands along the shaft
/// (`|d gap / d s|` < 1/2: the shaft within 30° of the outline) is grazing.
const MAX_BANDS_ALONG: f64 = 2.0;

/// Why a probe tip that was seen is not reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum TipFlag {
    /// The located tip is off the needle's axis.
    OffAxis,
    /// The located tip's round end overlaps the peg's outline.
    InsidePeg,
    /// Merged with the peg at a grazing angle: its place along the shaft is not pinned down.
    Grazing,
    /// Merged with the peg, and where its silhouette ends disagrees with where it would touch.
    Unconfirmed,
    /// Merged with a peg whose pose is not trusted, or with something else.
    Merged,
}

impl TipFlag {
    /// The flag's name, as the track summary counts it.
    pub fn as_str(&self) -> &'static str {
        match self {
            TipFlag::OffAxis => "tip_off_axis",
            TipFlag::InsidePeg => "tip_inside_peg",
            TipFlag::Grazing => "tip_grazing",
            TipFlag::Unconfirmed => "tip_unconfirmed",
            TipFlag::Merged => "tip_merged",
        }
    }
}

/// The needle's end as the probe removal located it (continuous pixel coordinates).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LocatedTip {
    /// Centre of the round tip, px.
    pub(crate) centre_px: Vec2,
    /// Unit direction of the shaft towards the tip, px.
    pub(crate) toward_tip: Vec2,
    /// Distance of the centre from the shaft's axis just behind it, px.
    pub(crate) off_axis_px: f64,
    /// Whether something other than the needle lies just beyond the tip's front half.
    pub(crate) merged: bool,
}

/// The peg as the tip is judged against.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PegView<'a> {
    /// Its outline at the measured pose.
    pub(crate) outline: &'a ConvexPolygon,
    /// Whether that pose is trusted (unflagged).
    pub(crate) trusted: bool,
}

/// The tip's centre in the fixture frame (µm), or why it is withheld.
pub(crate) fn place_tip(
    tip: &LocatedTip,
    calib: &Calibration,
    peg: Option<PegView<'_>>,
    radius_um: f64,
) -> Result<Vec2, TipFlag> {
    if tip.off_axis_px.abs() > MAX_OFF_AXIS_PX {
        return Err(TipFlag::OffAxis);
    }
    let centre = calib.px_to_um(&tip.centre_px);
    let band_um = BAND_PX * calib.mean_um_per_px();
    let Some(peg) = peg else {
        return if tip.merged { Err(TipFlag::Merged) } else { Ok(centre) };
    };
    let gap = |p: &Vec2| peg.outline.signed_distance(p) - radius_um;
    if gap(&centre) < -band_um {
        return Err(TipFlag::InsidePeg);
    }
    if !tip.merged {
        return Ok(centre);
    }
    if !peg.trusted {
        return Err(TipFlag::Merged);
    }
    let u = Vec2::new(tip.toward_tip.x * calib.sx_um_per_px, tip.toward_tip.y * calib.sy_um_per_px);
    let u = u.try_normalize(1e-12).ok_or(TipFlag::OffAxis)?;
    let contact = along_shaft_to_contact(centre, u, gap)?;
    if (contact - centre).norm() > band_um {
        return Err(TipFlag::Unconfirmed);
    }
    Ok((centre + contact) * 0.5)
}

/// Where the tip, moved along its shaft (`toward_tip`, unit, µm), has `gap` zero (Newton);
/// a grazing approach is refused.
fn along_shaft_to_contact(
    tip_um: Vec2,
    toward_tip: Vec2,
    gap: impl Fn(&Vec2) -> f64,
) -> Result<Vec2, TipFlag> {
    let mut p = tip_um;
    for _ in 0..6 {
        let g = gap(&p);
        let slope = gap(&(p + toward_tip)) - g;
        if slope > -1.0 / MAX_BANDS_ALONG {
            return Err(TipFlag::Grazing);
        }
        p -= toward_tip * (g / slope);
    }
    if gap(&p).abs() > 1e-3 { Err(TipFlag::Grazing) } else { Ok(p) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A peg occupying x ≤ 500 µm (and 0 ≤ y ≤ 1000), 5 µm pixels, a 10 µm tip.
    fn setup() -> (Calibration, ConvexPolygon) {
        let calib = Calibration::new(5.0, 5.0, Vec2::zeros()).unwrap();
        let peg = ConvexPolygon::rectangle(1000.0, 1000.0).unwrap();
        (calib, peg.translated(&Vec2::new(0.0, 500.0)))
    }

    fn located(x_um: f64, approach_deg: f64, merged: bool) -> LocatedTip {
        let a = approach_deg.to_radians();
        LocatedTip {
            centre_px: Vec2::new(x_um / 5.0, 100.5),
            toward_tip: Vec2::new(-a.cos(), a.sin()),
            off_axis_px: 0.0,
            merged,
        }
    }

    fn trusted(peg: &ConvexPolygon) -> Option<PegView<'_>> {
        Some(PegView { outline: peg, trusted: true })
    }

    #[test]
    fn a_merged_tip_close_to_its_contact_is_placed_midway() {
        let (calib, peg) = setup();
        // located 4 µm short of touching (band 7.5 µm): midway between 514 and 510
        let p = place_tip(&located(514.0, 0.0, true), &calib, trusted(&peg), 10.0).unwrap();
        assert!((p.x - 512.0).abs() < 1e-6, "{p:?}");
        // 12 µm short: the two readings disagree by more than the band
        let far = place_tip(&located(522.0, 0.0, true), &calib, trusted(&peg), 10.0);
        assert_eq!(far, Err(TipFlag::Unconfirmed));
        // plate seen beyond it: reported where it was located
        let free = place_tip(&located(522.0, 0.0, false), &calib, trusted(&peg), 10.0).unwrap();
        assert!((free.x - 522.0).abs() < 1e-9);
    }

    #[test]
    fn unsure_tips_are_withheld() {
        let (calib, peg) = setup();
        let tip = located(514.0, 0.0, true);
        let untrusted = Some(PegView { outline: &peg, trusted: false });
        assert_eq!(place_tip(&tip, &calib, untrusted, 10.0), Err(TipFlag::Merged));
        assert_eq!(place_tip(&tip, &calib, None, 10.0), Err(TipFlag::Merged));
        let inside = located(500.0, 0.0, true);
        assert_eq!(place_tip(&inside, &calib, trusted(&peg), 10.0), Err(TipFlag::InsidePeg));
        let off = LocatedTip { off_axis_px: 1.5, ..tip };
        assert_eq!(place_tip(&off, &calib, trusted(&peg), 10.0), Err(TipFlag::OffAxis));
        // shaft 70° from the edge's normal, 3 µm short of touching: grazing; 45°: placed
        let grazing = located(513.0, 70.0, true);
        assert_eq!(place_tip(&grazing, &calib, trusted(&peg), 10.0), Err(TipFlag::Grazing));
        let steep = place_tip(&located(513.0, 45.0, true), &calib, trusted(&peg), 10.0).unwrap();
        assert!((steep.x - 511.5).abs() < 1e-6, "{steep:?}");
    }
}
