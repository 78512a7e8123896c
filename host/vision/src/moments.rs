//! Ellipse fit by second moments (paper §IV): the centroid and principal axes of a gray-level
//! weighted blob, and the same moments of a polygon so the fit can be compared with the peg's
//! known shape. Weights are partial pixel coverages, which is what makes the centroid
//! sub-pixel accurate (a hard binary mask would quantise it).

use mesopush_core::geom::{ConvexPolygon, Vec2, cross};

/// Area, centroid and central second moments (per unit area) of a weighted shape, µm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moments {
    /// Total weight × pixel area, µm².
    pub area_um2: f64,
    /// Centroid, µm.
    pub centroid: Vec2,
    /// Central second moments per unit area: (xx, yy, xy), µm².
    pub second: (f64, f64, f64),
}

impl Moments {
    /// Eigenvalues of the second-moment matrix, larger first, µm².
    pub fn principal(&self) -> (f64, f64) {
        let (a, b, c) = self.second;
        let mean = 0.5 * (a + b);
        let half = (0.25 * (a - b).powi(2) + c * c).sqrt();
        (mean + half, mean - half)
    }

    /// Angle of the major axis from +x towards +y, rad, in (−π/2, π/2].
    pub fn major_axis_angle(&self) -> f64 {
        let (a, b, c) = self.second;
        0.5 * (2.0 * c).atan2(a - b)
    }

    /// How elongated: (λ1 − λ2) / (λ1 + λ2), 0 for a disc, 1 for a line.
    pub fn anisotropy(&self) -> f64 {
        let (l1, l2) = self.principal();
        if l1 + l2 > 0.0 { (l1 - l2) / (l1 + l2) } else { 0.0 }
    }
}

/// Exact moments of a polygon.
pub fn polygon_moments(poly: &ConvexPolygon) -> Moments {
    let v = poly.vertices();
    let c = poly.centroid();
    let (mut a2, mut xx, mut yy, mut xy) = (0.0, 0.0, 0.0, 0.0);
    for i in 0..v.len() {
        let p = v[i] - c;
        let q = v[(i + 1) % v.len()] - c;
        let k = cross(&p, &q);
        a2 += k;
        xx += k * (p.x * p.x + p.x * q.x + q.x * q.x);
        yy += k * (p.y * p.y + p.y * q.y + q.y * q.y);
        xy += k * (2.0 * p.x * p.y + p.x * q.y + q.x * p.y + 2.0 * q.x * q.y);
    }
    let area = 0.5 * a2;
    Moments {
        area_um2: area,
        centroid: c,
        second: (xx / 12.0 / area, yy / 12.0 / area, xy / 24.0 / area),
    }
}

/// Accumulates weighted pixels (continuous pixel coordinates in µm via the calibration
/// scales) relative to a local origin to keep the sums well conditioned.
#[derive(Debug, Clone, Copy)]
pub struct MomentSums {
    origin: Vec2,
    sx: f64,
    sy: f64,
    m: [f64; 6],
}

impl MomentSums {
    /// Sums for pixels near `origin_px`, with `sx`, `sy` µm per pixel.
    pub fn new(origin_px: Vec2, sx: f64, sy: f64) -> Self {
        Self { origin: origin_px, sx, sy, m: [0.0; 6] }
    }

    /// Adds pixel `(i, j)` with weight `w` (its covered share).
    #[inline]
    pub fn add(&mut self, i: usize, j: usize, w: f64) {
        self.add_row(j, i, [w, 0.0, 0.0]);
    }

    /// Adds row `j`'s sums `[Σw, Σw·c, Σw·c²]` over columns `i = col0 + c`.
    pub fn add_row(&mut self, j: usize, col0: usize, [s0, s1, s2]: [f64; 3]) {
        // x = (col0 + c + 0.5 − ox)·sx = (c + a)·sx: expand Σw·x and Σw·x²
        let (a, sx) = (col0 as f64 + 0.5 - self.origin.x, self.sx);
        let sum_x = sx * (s1 + a * s0);
        let sum_xx = sx * sx * (s2 + 2.0 * a * s1 + a * a * s0);
        let y = (j as f64 + 0.5 - self.origin.y) * self.sy;
        let m = &mut self.m;
        m[0] += s0;
        m[1] += sum_x;
        m[2] += y * s0;
        m[3] += sum_xx;
        m[4] += y * y * s0;
        m[5] += y * sum_x;
    }

    /// Adds a row of weights starting at column `col0` (summed in 8 f32 lanes).
    pub fn add_weights(&mut self, j: usize, col0: usize, weights: &[f32]) {
        let (mut s0, mut s1, mut s2) = ([0f32; 8], [0f32; 8], [0f32; 8]);
        let mut chunks = weights.chunks_exact(8);
        let mut base = 0f32;
        for chunk in &mut chunks {
            for l in 0..8 {
                let (w, c) = (chunk[l], base + l as f32);
                s0[l] += w;
                s1[l] += w * c;
                s2[l] += w * c * c;
            }
            base += 8.0;
        }
        let mut sums = [0f64; 3];
        for (l, &w) in chunks.remainder().iter().enumerate() {
            let c = f64::from(base) + l as f64;
            let w = f64::from(w);
            sums[0] += w;
            sums[1] += w * c;
            sums[2] += w * c * c;
        }
        for l in 0..8 {
            sums[0] += f64::from(s0[l]);
            sums[1] += f64::from(s1[l]);
            sums[2] += f64::from(s2[l]);
        }
        self.add_row(j, col0, sums);
    }

    /// The moments in continuous pixel coordinates scaled to µm (add the calibration origin
    /// yourself), or `None` when the total weight is not positive. Each pixel's own extent
    /// (a uniform square) is added to the second moments.
    pub fn finish(&self) -> Option<(f64, Vec2, (f64, f64, f64))> {
        let m = &self.m;
        if m[0] <= 0.0 {
            return None;
        }
        let (cx, cy) = (m[1] / m[0], m[2] / m[0]);
        let xx = m[3] / m[0] - cx * cx + self.sx * self.sx / 12.0;
        let yy = m[4] / m[0] - cy * cy + self.sy * self.sy / 12.0;
        let xy = m[5] / m[0] - cx * cy;
        let c_px = Vec2::new(cx / self.sx + self.origin.x, cy / self.sy + self.origin.y);
        Some((m[0] * self.sx * self.sy, c_px, (xx, yy, xy)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mesopush_core::geom::Pose;

    #[test]
    fn rectangle_moments_are_l2_over_12_and_rotate() {
        let r = ConvexPolygon::rectangle(1615.0, 985.0).unwrap();
        let m = polygon_moments(&r);
        let (l1, l2) = m.principal();
        assert!((l1 - 1615f64.powi(2) / 12.0).abs() < 1e-6);
        assert!((l2 - 985f64.powi(2) / 12.0).abs() < 1e-6);
        let turned = r.transformed(&Pose::new(100.0, 50.0, 0.4));
        let mt = polygon_moments(&turned);
        assert!((mt.major_axis_angle() - 0.4).abs() < 1e-9);
        assert!((mt.centroid - Vec2::new(100.0, 50.0)).norm() < 1e-9);
    }

    #[test]
    fn row_weights_sum_like_single_pixels() {
        let weights: Vec<f32> = (0..21).map(|i| 0.1 * i as f32).collect();
        let mut rows = MomentSums::new(Vec2::new(9.0, 4.0), 5.0, 5.5);
        let mut single = rows;
        rows.add_weights(3, 7, &weights);
        for (c, &w) in weights.iter().enumerate() {
            single.add(7 + c, 3, f64::from(w));
        }
        let (a, ca, sa) = rows.finish().unwrap();
        let (b, cb, sb) = single.finish().unwrap();
        assert!((a / b - 1.0).abs() < 1e-6 && (ca - cb).norm() < 1e-5, "{a} {b} {ca} {cb}");
        assert!(
            (sa.0 / sb.0 - 1.0).abs() < 1e-5 && (sa.2 - sb.2).abs() < 1e-3 * sa.0,
            "{sa:?} {sb:?}"
        );
    }

    #[test]
    fn pixel_sums_of_a_filled_square_match_its_moments() {
        let mut s = MomentSums::new(Vec2::new(5.0, 5.0), 2.0, 3.0);
        for j in 0..10 {
            for i in 0..10 {
                s.add(i, j, 1.0);
            }
        }
        let (area, c, (xx, yy, xy)) = s.finish().unwrap();
        assert!((area - 600.0).abs() < 1e-9);
        assert!((c - Vec2::new(5.0, 5.0)).norm() < 1e-12);
        assert!((xx - 400.0 / 12.0).abs() < 1e-9, "{xx}");
        assert!((yy - 900.0 / 12.0).abs() < 1e-9);
        assert!(xy.abs() < 1e-9);
    }
}
