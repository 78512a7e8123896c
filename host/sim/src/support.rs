//! Three-point support distribution (Mason): the unknown pressure between peg and plate is
//! replaced by three support points whose normal forces follow from statics once the centre
//! of mass is fixed. Forces are in units of the part's weight (they sum to 1).

use crate::Error;
use mesopush_core::geom::{ConvexPolygon, Vec2, cross};
use serde::{Deserialize, Serialize};

/// Three support points relative to the centre of mass (body frame, µm) with a surface
/// friction coefficient each.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SupportDistribution {
    /// Support points r1..r3 relative to the COM, body frame, µm.
    pub points_um: [[f64; 2]; 3],
    /// Surface (peg–plate) friction coefficient at each support.
    pub mu_surface: [f64; 3],
}

impl SupportDistribution {
    /// A symmetric default for a part: an isosceles triangle around the COM.
    pub fn symmetric(half_width_um: f64, half_height_um: f64, mu_surface: f64) -> Self {
        let (w, h) = (half_width_um, half_height_um);
        Self { points_um: [[-w, -h], [-w, h], [2.0 * w, 0.0]], mu_surface: [mu_surface; 3] }
    }

    /// The support points as vectors.
    pub fn points(&self) -> [Vec2; 3] {
        self.points_um.map(|[x, y]| Vec2::new(x, y))
    }

    /// Normal forces from statics (Σλ = 1, Σλ·r = 0). Fails with a clear error when the COM
    /// is not strictly inside the support triangle (a force would be ≤ 0) or the triangle is
    /// degenerate.
    pub fn normal_forces(&self) -> Result<[f64; 3], Error> {
        let [a, b, c] = self.points();
        let twice_area = cross(&(b - a), &(c - a));
        let scale = (b - a).norm() * (c - a).norm();
        if !(twice_area.is_finite()) || twice_area.abs() <= 1e-9 * scale.max(1e-300) {
            return Err(Error::invalid("support", "the three support points are collinear"));
        }
        // Barycentric coordinates of the COM (the origin) in the triangle.
        let o = Vec2::zeros();
        let la = cross(&(b - o), &(c - o)) / twice_area;
        let lb = cross(&(c - o), &(a - o)) / twice_area;
        let lc = 1.0 - la - lb;
        let forces = [la, lb, lc];
        if forces.iter().any(|f| f.is_nan() || *f <= 1e-6) {
            return Err(Error::invalid(
                "support",
                format!(
                    "the centre of mass must lie strictly inside the support triangle \
                     (normal forces would be {la:.4}, {lb:.4}, {lc:.4})"
                ),
            ));
        }
        Ok(forces)
    }

    /// Full validation against the part: points inside the part, friction in [0, 2], COM in
    /// the triangle.
    pub fn validate(&self, part: &ConvexPolygon) -> Result<[f64; 3], Error> {
        for (i, p) in self.points().iter().enumerate() {
            if !(p.x.is_finite() && p.y.is_finite()) {
                return Err(Error::invalid("support", format!("point r{} is not finite", i + 1)));
            }
            if !part.contains(p, 1e-6) {
                return Err(Error::invalid(
                    "support",
                    format!("point r{} = ({:.1}, {:.1}) µm lies outside the part", i + 1, p.x, p.y),
                ));
            }
        }
        for (i, mu) in self.mu_surface.iter().enumerate() {
            if !(mu.is_finite() && (0.0..=2.0).contains(mu)) {
                return Err(Error::invalid(
                    "support",
                    format!("mu_surface[{i}] = {mu} must be within [0, 2]"),
                ));
            }
        }
        self.normal_forces()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forces_balance_weight_and_moment() {
        let s = SupportDistribution {
            points_um: [[-300.0, -200.0], [-100.0, 350.0], [500.0, -50.0]],
            mu_surface: [0.3; 3],
        };
        let f = s.normal_forces().unwrap();
        assert!((f.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        let m = s.points().iter().zip(f).fold(Vec2::zeros(), |acc, (p, l)| acc + p * l);
        assert!(m.norm() < 1e-9, "moment {m:?}");
    }

    #[test]
    fn com_outside_triangle_is_a_clear_error() {
        let s = SupportDistribution {
            points_um: [[100.0, 100.0], [300.0, 100.0], [200.0, 300.0]],
            mu_surface: [0.3; 3],
        };
        let e = s.normal_forces().unwrap_err().to_string();
        assert!(e.contains("centre of mass"), "{e}");
    }

    #[test]
    fn support_outside_part_is_refused() {
        let part = ConvexPolygon::rectangle(1615.0, 985.0).unwrap();
        let s = SupportDistribution::symmetric(300.0, 600.0, 0.3);
        let e = s.validate(&part).unwrap_err().to_string();
        assert!(e.contains("outside the part"), "{e}");
        assert!(SupportDistribution::symmetric(300.0, 300.0, 0.3).validate(&part).is_ok());
    }
}
