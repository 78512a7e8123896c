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

    /// The three-point support equivalent to a uniform pressure over `part` (what a
    /// flat-bottomed part on a flat plate is usually assumed to have): three equal loads
    /// whose first and second moments about the COM equal the uniform area's, i.e. the points
    /// √2·Σ^½·u_k for the area's covariance Σ and three unit vectors u_k 120° apart, the first
    /// along the major axis. Same rotational friction and centre as the uniform pressure, for
    /// any convex part and scale; a part whose points would fall outside it is refused
    /// by [`SupportDistribution::validate`].
    pub fn uniform_pressure(part: &crate::Part, mu_surface: f64) -> Self {
        let [sxx, syy, sxy] = area_covariance(part.polygon());
        let phi = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        let (c, s) = (phi.cos(), phi.sin());
        // Eigenvalues along the rotated axes (major first).
        let l1 = c * c * sxx + 2.0 * c * s * sxy + s * s * syy;
        let l2 = s * s * sxx - 2.0 * c * s * sxy + c * c * syy;
        let (a, b) = ((2.0 * l1.max(0.0)).sqrt(), (2.0 * l2.max(0.0)).sqrt());
        let points_um = [0.0f64, 1.0, 2.0].map(|k| {
            let t = std::f64::consts::TAU * k / 3.0;
            let (u, v) = (a * t.cos(), b * t.sin());
            [c * u - s * v, s * u + c * v]
        });
        Self { points_um, mu_surface: [mu_surface; 3] }
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

/// The covariance `[Σxx, Σyy, Σxy]` (µm²) of a uniform area over `poly` about the origin.
fn area_covariance(poly: &ConvexPolygon) -> [f64; 3] {
    let v = poly.vertices();
    let (mut a2, mut ixx, mut iyy, mut ixy) = (0.0, 0.0, 0.0, 0.0);
    for i in 0..v.len() {
        let (p, q) = (v[i], v[(i + 1) % v.len()]);
        let w = p.x * q.y - q.x * p.y;
        a2 += w;
        ixx += w * (p.x * p.x + p.x * q.x + q.x * q.x);
        iyy += w * (p.y * p.y + p.y * q.y + q.y * q.y);
        ixy += w * (p.x * q.y + 2.0 * p.x * p.y + 2.0 * q.x * q.y + q.x * p.y);
    }
    // ∫x² = Σ w (…)/12, ∫xy = Σ w (…)/24, area = Σ w / 2 (all with the winding's sign).
    let area = a2 / 2.0;
    [ixx / 12.0 / area, iyy / 12.0 / area, ixy / 24.0 / area]
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

    #[test]
    fn uniform_pressure_has_equal_loads_and_the_areas_second_moments() {
        let (a, b) = (50_000.0, 35_000.0);
        let part = crate::Part::from_polygon(&ConvexPolygon::rectangle(a, b).unwrap());
        let sup = SupportDistribution::uniform_pressure(&part, 0.3);
        sup.validate(part.polygon()).unwrap();
        for f in sup.normal_forces().unwrap() {
            assert!((f - 1.0 / 3.0).abs() < 1e-9, "{f}");
        }
        let pts = sup.points();
        let m = |f: &dyn Fn(&Vec2) -> f64| pts.iter().map(f).sum::<f64>() / 3.0;
        assert!((m(&|p| p.x * p.x) - a * a / 12.0).abs() < 1e-6 * a * a);
        assert!((m(&|p| p.y * p.y) - b * b / 12.0).abs() < 1e-6 * a * a);
        assert!(m(&|p| p.x * p.y).abs() < 1e-6 * a * a);
        // A turned part gets the turned support.
        let th = 0.7_f64;
        let pose = mesopush_core::geom::Pose::new(0.0, 0.0, th);
        let turned = crate::Part::from_polygon(&part.polygon().transformed(&pose));
        let t = SupportDistribution::uniform_pressure(&turned, 0.3);
        let moment =
            |s: &SupportDistribution| s.points().iter().map(|p| p.norm_squared()).sum::<f64>();
        assert!((moment(&t) - moment(&sup)).abs() < 1e-6 * a * a);
        let rotated: Vec<Vec2> = sup.points().iter().map(|p| pose.rotate(p)).collect();
        for p in t.points() {
            let near = rotated.iter().map(|r| (r - p).norm()).fold(f64::MAX, f64::min);
            assert!(near < 1e-6 * a, "{p:?} not among {rotated:?}");
        }
    }
}
