//! The probe's needle as the camera sees it: a tapered shaft with a rounded tip of the probe's
//! diameter, entering from the frame edge. Used by the renderer; its parameters are plain data.

use crate::Error;
use crate::calib::Calibration;
use crate::raster::{Plane, half_plane_coverage};
use mesopush_core::geom::Vec2;

/// The needle's shape and where it comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeedleSettings {
    /// Diameter of the rounded tip, µm (the paper's probe: 25 µm).
    pub tip_diameter_um: f64,
    /// Half-angle of the taper, rad: the radius grows by `tan(taper)` per µm from the tip.
    pub taper_half_angle_rad: f64,
    /// Direction from the tip along the shaft towards the frame edge it enters from, rad in
    /// the fixture frame (0 = towards +x; −π/2 = towards the top edge).
    pub shaft_angle_rad: f64,
}

impl Default for NeedleSettings {
    /// 25 µm tip, 1.5° taper half-angle, shaft coming from the upper right (−60°).
    fn default() -> Self {
        Self {
            tip_diameter_um: 25.0,
            taper_half_angle_rad: 1.5f64.to_radians(),
            shaft_angle_rad: (-60f64).to_radians(),
        }
    }
}

impl NeedleSettings {
    /// Checks ranges; names the field that is wrong.
    pub fn validate(&self) -> Result<(), Error> {
        if !(self.tip_diameter_um.is_finite() && self.tip_diameter_um > 0.0) {
            return Err(Error::invalid("needle tip_diameter_um", "must be finite and > 0"));
        }
        if !(0.0..0.5).contains(&self.taper_half_angle_rad) {
            return Err(Error::invalid("needle taper_half_angle_rad", "must be in [0, 0.5) rad"));
        }
        if !self.shaft_angle_rad.is_finite() {
            return Err(Error::invalid("needle shaft_angle_rad", "must be finite"));
        }
        Ok(())
    }

    /// Unit vector from the tip along the shaft.
    pub fn shaft_dir(&self) -> Vec2 {
        Vec2::new(self.shaft_angle_rad.cos(), self.shaft_angle_rad.sin())
    }

    /// Signed distance (µm, negative inside) from `p` to the needle whose tip centre is `tip`,
    /// with the outward unit normal there.
    pub fn signed_distance(&self, tip: &Vec2, p: &Vec2) -> (f64, Vec2) {
        let u = self.shaft_dir();
        let r_tip = 0.5 * self.tip_diameter_um;
        let d = p - tip;
        let s = d.dot(&u);
        if s <= 0.0 {
            let len = d.norm();
            let n = if len > 0.0 { d / len } else { -u };
            return (len - r_tip, n);
        }
        let lat = Vec2::new(-u.y, u.x);
        let l = d.dot(&lat);
        let (tan, cos) = (self.taper_half_angle_rad.tan(), self.taper_half_angle_rad.cos());
        let side = if l >= 0.0 { lat } else { -lat };
        // distance to the tilted flank, measured along its normal
        let n = (side * cos - u * self.taper_half_angle_rad.sin()).normalize();
        ((l.abs() - (r_tip + s * tan)) * cos, n)
    }
}

/// Composites the needle onto `plane` (each pixel moves towards `value` by its coverage).
/// Work is skipped in 8 × 8 blocks the needle cannot reach (the distance is 1-Lipschitz).
pub(crate) fn fill_needle(
    plane: &mut Plane,
    calib: &Calibration,
    needle: &NeedleSettings,
    tip: &Vec2,
    value: f32,
) {
    const B: usize = 8;
    let smax = calib.sx_um_per_px.max(calib.sy_um_per_px);
    let block_reach_um = (B as f64 * 0.5 * std::f64::consts::SQRT_2 + 1.0) * smax;
    for by in (0..plane.height).step_by(B) {
        for bx in (0..plane.width).step_by(B) {
            let centre = calib.px_to_um(&(Vec2::new((bx + B / 2) as f64, (by + B / 2) as f64)));
            if needle.signed_distance(tip, &centre).0 > block_reach_um {
                continue;
            }
            for j in by..(by + B).min(plane.height) {
                for i in bx..(bx + B).min(plane.width) {
                    let p = calib.px_to_um(&Vec2::new(i as f64 + 0.5, j as f64 + 0.5));
                    let (sd, n) = needle.signed_distance(tip, &p);
                    let g = Vec2::new(n.x * calib.sx_um_per_px, n.y * calib.sy_um_per_px);
                    let gn = g.norm();
                    let cov = half_plane_coverage(g.x / gn, g.y / gn, -sd / gn);
                    if cov > 0.0 {
                        let v = &mut plane.data[j * plane.width + i];
                        *v += cov as f32 * (value - *v);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_is_zero_on_the_tip_and_grows_with_taper() {
        let n = NeedleSettings { shaft_angle_rad: 0.0, ..Default::default() };
        let tip = Vec2::new(100.0, 100.0);
        // the rounded end: 12.5 µm behind the tip centre, opposite the shaft
        assert!(n.signed_distance(&tip, &Vec2::new(87.5, 100.0)).0.abs() < 1e-9);
        assert!((n.signed_distance(&tip, &tip).0 + 12.5).abs() < 1e-9);
        // 1000 µm up the shaft the radius is 12.5 + 1000 tan(1.5°) ≈ 38.7 µm
        let r = 12.5 + 1000.0 * 1.5f64.to_radians().tan();
        let on_flank = Vec2::new(1100.0, 100.0 + r);
        assert!(n.signed_distance(&tip, &on_flank).0.abs() < 1e-6);
    }

    #[test]
    fn bad_settings_are_refused() {
        assert!(NeedleSettings { tip_diameter_um: 0.0, ..Default::default() }.validate().is_err());
        let wide = NeedleSettings { taper_half_angle_rad: 1.0, ..Default::default() };
        assert!(wide.validate().is_err());
    }
}
