//! Calibration between image pixels and the fixture frame (µm).
//!
//! Pixel convention: pixel `(i, j)` (column, row) covers the square `[i, i+1) × [j, j+1)` of
//! continuous pixel coordinates `(u, v)`, so its centre is at `(i + 0.5, j + 0.5)`. The fixture
//! frame point is `x_um = (u - origin_u) * sx`, `y_um = (v - origin_v) * sy`: x right, y down,
//! with a separate scale per axis. The default is the paper's 4× objective: a 3370 × 2520 µm
//! field over 640 × 480 pixels with the fixture origin at the image's top-left corner.

use crate::Error;
use mesopush_core::geom::Vec2;

/// The paper's field of view, µm (3.37 × 2.52 mm).
pub const DEFAULT_FIELD_UM: (f64, f64) = (3370.0, 2520.0);
/// The paper's image size, px.
pub const DEFAULT_SIZE_PX: (u32, u32) = (640, 480);

/// Maps continuous pixel coordinates to the fixture frame and back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    /// µm per pixel along x (image columns).
    pub sx_um_per_px: f64,
    /// µm per pixel along y (image rows).
    pub sy_um_per_px: f64,
    /// Where the fixture frame's origin lies in the image, continuous pixel coordinates.
    pub origin_px: Vec2,
}

impl Default for Calibration {
    /// 3370 × 2520 µm over 640 × 480 px, origin at the image's top-left corner.
    fn default() -> Self {
        Self::from_field(
            DEFAULT_FIELD_UM.0,
            DEFAULT_FIELD_UM.1,
            DEFAULT_SIZE_PX.0,
            DEFAULT_SIZE_PX.1,
        )
        .expect("the default field is valid")
    }
}

impl Calibration {
    /// Scales per axis (µm/px) with the origin at pixel coordinates `origin_px`.
    pub fn new(sx_um_per_px: f64, sy_um_per_px: f64, origin_px: Vec2) -> Result<Self, Error> {
        for (name, s) in [("x", sx_um_per_px), ("y", sy_um_per_px)] {
            if !(s.is_finite() && s > 0.0) {
                return Err(Error::invalid(
                    "calibration",
                    format!("µm per pixel along {name} must be finite and > 0, got {s}"),
                ));
            }
        }
        if !(origin_px.x.is_finite() && origin_px.y.is_finite()) {
            return Err(Error::invalid("calibration", "origin must be finite"));
        }
        Ok(Self { sx_um_per_px, sy_um_per_px, origin_px })
    }

    /// A field of `width_um × height_um` spread over a `width_px × height_px` image, origin at
    /// the image's top-left corner.
    pub fn from_field(
        width_um: f64,
        height_um: f64,
        width_px: u32,
        height_px: u32,
    ) -> Result<Self, Error> {
        if width_px == 0 || height_px == 0 {
            return Err(Error::invalid("calibration", "image size must be non-zero"));
        }
        Self::new(width_um / f64::from(width_px), height_um / f64::from(height_px), Vec2::zeros())
    }

    /// The same scales with a different origin (continuous pixel coordinates).
    pub fn with_origin(self, origin_px: Vec2) -> Result<Self, Error> {
        Self::new(self.sx_um_per_px, self.sy_um_per_px, origin_px)
    }

    /// Continuous pixel coordinates → fixture frame, µm.
    pub fn px_to_um(&self, px: &Vec2) -> Vec2 {
        Vec2::new(
            (px.x - self.origin_px.x) * self.sx_um_per_px,
            (px.y - self.origin_px.y) * self.sy_um_per_px,
        )
    }

    /// Fixture frame (µm) → continuous pixel coordinates.
    pub fn um_to_px(&self, um: &Vec2) -> Vec2 {
        Vec2::new(
            um.x / self.sx_um_per_px + self.origin_px.x,
            um.y / self.sy_um_per_px + self.origin_px.y,
        )
    }

    /// Mean pixel size, µm (for tolerances given in µm).
    pub fn mean_um_per_px(&self) -> f64 {
        0.5 * (self.sx_um_per_px + self.sy_um_per_px)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_the_papers_field() {
        let c = Calibration::default();
        let corner = c.px_to_um(&Vec2::new(640.0, 480.0));
        assert!((corner - Vec2::new(3370.0, 2520.0)).norm() < 1e-9);
        assert!((c.sx_um_per_px - 5.265625).abs() < 1e-12);
    }

    #[test]
    fn round_trip_with_origin_and_anisotropic_scale() {
        let c = Calibration::new(5.0, 6.0, Vec2::new(12.5, -3.0)).unwrap();
        let p = Vec2::new(101.25, 77.5);
        assert!((c.um_to_px(&c.px_to_um(&p)) - p).norm() < 1e-12);
        assert!(c.px_to_um(&Vec2::new(12.5, -3.0)).norm() < 1e-12);
    }

    #[test]
    fn bad_scales_are_refused() {
        assert!(Calibration::new(0.0, 5.0, Vec2::zeros()).is_err());
        assert!(Calibration::new(5.0, f64::NAN, Vec2::zeros()).is_err());
        assert!(Calibration::from_field(3370.0, 2520.0, 0, 480).is_err());
    }
}
