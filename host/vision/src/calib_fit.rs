//! The camera's calibration fitted from the probe tip seen at known stage positions (what
//! `mesopush calibrate` measures on a rig): the pixel size along each image axis, the
//! camera's rotation relative to the stage's axes, and where the fixture origin lies in the
//! image. Pure: positions in, fit out; the rig workflow is `mesopush_rig::client::calibrate`.
//!
//! Model: a tip at fixture-frame position `p` (µm; stage position minus the stage
//! registration) images at pixel `q` with `p = R(φ) · diag(sx, sy) · (q − o)`: [`Calibration`]'s
//! per-axis scale and origin, turned by the camera's rotation φ. Least squares over all
//! positions: for a given φ the scales are linear (closed form); φ is searched about the
//! rotation of the general affine fit; the origin follows from the centroids. Three
//! positions (a move along x, then along y) leave one degree of freedom, which the residual
//! reports (the stage axes' skew as the camera sees it, plus the tip's error). A fit whose
//! scale along an axis comes out negative is refused: the image is mirrored relative to the
//! stage, which no [`Calibration`] expresses.

use crate::Error;
use crate::calib::Calibration;
use mesopush_core::geom::Vec2;
use serde::{Deserialize, Serialize};

/// One position: where the tip was (fixture frame, µm) and where it was seen (px).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipSample {
    /// The tip's position in the fixture frame, µm (stage position − registration).
    pub fixture_um: Vec2,
    /// Where the tracker located it, continuous pixel coordinates.
    pub tip_px: Vec2,
}

/// The fitted calibration and how well it fits.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationFit {
    /// µm per pixel along image columns.
    pub sx_um_per_px: f64,
    /// µm per pixel along image rows.
    pub sy_um_per_px: f64,
    /// The camera's rotation relative to the stage axes, rad (image axes turned by this to
    /// give the stage's). The tracker assumes 0.
    pub rotation_rad: f64,
    /// The fixture origin in the image, continuous px.
    pub origin_px: [f64; 2],
    /// Root-mean-square distance between the positions and the fit's image of their tips, µm.
    pub residual_um_rms: f64,
    /// Largest such distance, µm.
    pub residual_um_max: f64,
    /// Positions fitted.
    pub positions: usize,
}

impl CalibrationFit {
    /// The calibration the tracker uses (scales and origin; the rotation is not part of it).
    pub fn calibration(&self) -> Result<Calibration, Error> {
        let [ox, oy] = self.origin_px;
        Calibration::new(self.sx_um_per_px, self.sy_um_per_px, Vec2::new(ox, oy))
    }
}

/// Fits the calibration to `samples` (at least three, spanning both axes).
pub fn fit_calibration(samples: &[TipSample]) -> Result<CalibrationFit, Error> {
    let n = samples.len();
    if n < 3 {
        return Err(Error::invalid("calibration fit", format!("needs 3 positions, got {n}")));
    }
    if samples.iter().any(|s| !(s.fixture_um.iter().chain(s.tip_px.iter()).all(|v| v.is_finite())))
    {
        return Err(Error::invalid("calibration fit", "a position is not finite"));
    }
    let p_mean = samples.iter().map(|s| s.fixture_um).sum::<Vec2>() / n as f64;
    let q_mean = samples.iter().map(|s| s.tip_px).sum::<Vec2>() / n as f64;
    let d: Vec<(Vec2, Vec2)> =
        samples.iter().map(|s| (s.fixture_um - p_mean, s.tip_px - q_mean)).collect();
    let phi0 = affine_rotation(&d)?;
    let phi = golden_min(|phi| scales_at(&d, phi).2, phi0 - 0.5, phi0 + 0.5);
    let (sx, sy, cost) = scales_at(&d, phi);
    if !(sx > 0.0 && sy > 0.0) {
        return Err(mirrored());
    }
    let r_inv_p = rotate(p_mean, -phi);
    let origin = q_mean - Vec2::new(r_inv_p.x / sx, r_inv_p.y / sy);
    let model = |q: Vec2| rotate(Vec2::new(sx * (q.x - origin.x), sy * (q.y - origin.y)), phi);
    let residual_um_max =
        samples.iter().map(|s| (s.fixture_um - model(s.tip_px)).norm()).fold(0.0, f64::max);
    Ok(CalibrationFit {
        sx_um_per_px: sx,
        sy_um_per_px: sy,
        rotation_rad: phi,
        origin_px: [origin.x, origin.y],
        residual_um_rms: (cost / n as f64).sqrt(),
        residual_um_max,
        positions: n,
    })
}

fn mirrored() -> Error {
    Error::invalid(
        "calibration fit",
        "the image is mirrored relative to the stage (a stage move along one axis moves the \
         tip the other way in the image than the other axis does): flip the camera image or \
         the stage axis so that both agree",
    )
}

fn rotate(v: Vec2, phi: f64) -> Vec2 {
    let (s, c) = phi.sin_cos();
    Vec2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

/// The rotation nearest the general affine map of the centred tip positions onto the
/// centred stage positions (the starting point of the search); refuses positions that do
/// not span both axes and a mirrored image.
fn affine_rotation(d: &[(Vec2, Vec2)]) -> Result<f64, Error> {
    let (mut pq, mut qq) = (nalgebra::Matrix2::<f64>::zeros(), nalgebra::Matrix2::<f64>::zeros());
    for (p, q) in d {
        pq += p * q.transpose();
        qq += q * q.transpose();
    }
    let spread = qq.trace();
    if spread <= 0.0 || qq.determinant() <= 1e-9 * spread * spread {
        return Err(Error::invalid(
            "calibration fit",
            "the tip positions lie on a line (or coincide): the moves must go along both \
             stage axes and move the tip visibly",
        ));
    }
    let m = pq * qq.try_inverse().ok_or_else(|| Error::invalid("calibration fit", "singular"))?;
    if m.determinant() <= 0.0 {
        return Err(mirrored());
    }
    Ok((m[(1, 0)] - m[(0, 1)]).atan2(m[(0, 0)] + m[(1, 1)]))
}

/// The least-squares scales at rotation `phi` and the sum of squared residuals, µm².
fn scales_at(d: &[(Vec2, Vec2)], phi: f64) -> (f64, f64, f64) {
    let (mut ax, mut ay, mut qx, mut qy) = (0.0, 0.0, 0.0, 0.0);
    for (p, q) in d {
        let a = rotate(*p, -phi);
        ax += a.x * q.x;
        ay += a.y * q.y;
        qx += q.x * q.x;
        qy += q.y * q.y;
    }
    let (sx, sy) = (ax / qx, ay / qy);
    let cost = d
        .iter()
        .map(|(p, q)| (rotate(*p, -phi) - Vec2::new(sx * q.x, sy * q.y)).norm_squared())
        .sum();
    (sx, sy, cost)
}

/// The minimum of `f` on `[lo, hi]` by golden-section search (to 1e-12 rad).
fn golden_min(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut fa, mut fb) = (f(a), f(b));
    for _ in 0..200 {
        if hi - lo < 1e-12 {
            break;
        }
        if fa <= fb {
            hi = b;
            (b, fb) = (a, fa);
            a = hi - g * (hi - lo);
            fa = f(a);
        } else {
            lo = a;
            (a, fa) = (b, fb);
            b = lo + g * (hi - lo);
            fb = f(b);
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Where a camera with scales `s`, rotation `phi_deg` and origin `o` images fixture point
    /// `p` (the forward model written out, independent of the fit's algebra).
    fn image_of(p: Vec2, s: (f64, f64), phi_deg: f64, o: Vec2) -> Vec2 {
        let (sn, c) = phi_deg.to_radians().sin_cos();
        // undo the rotation, then the scales
        let u = Vec2::new(c * p.x + sn * p.y, -sn * p.x + c * p.y);
        Vec2::new(u.x / s.0 + o.x, u.y / s.1 + o.y)
    }

    fn samples(points: &[[f64; 2]], s: (f64, f64), phi_deg: f64, o: Vec2) -> Vec<TipSample> {
        points
            .iter()
            .map(|&[x, y]| {
                let p = Vec2::new(x, y);
                TipSample { fixture_um: p, tip_px: image_of(p, s, phi_deg, o) }
            })
            .collect()
    }

    #[test]
    fn an_exact_camera_is_recovered_from_three_positions() {
        let o = Vec2::new(285.0, -12.5);
        for phi_deg in [0.0, 2.0, -7.5, 89.0] {
            let pts = [[2000.0, 2000.0], [3000.0, 2000.0], [3000.0, 1000.0]];
            let fit = fit_calibration(&samples(&pts, (5.16, 5.147), phi_deg, o)).unwrap();
            assert!((fit.sx_um_per_px - 5.16).abs() < 1e-9, "{phi_deg}: {fit:?}");
            assert!((fit.sy_um_per_px - 5.147).abs() < 1e-9, "{phi_deg}: {fit:?}");
            assert!((fit.rotation_rad.to_degrees() - phi_deg).abs() < 1e-7, "{fit:?}");
            assert!((Vec2::from(fit.origin_px) - o).norm() < 1e-6, "{fit:?}");
            assert!(fit.residual_um_max < 1e-6, "{fit:?}");
        }
    }

    #[test]
    fn tip_errors_show_in_the_residual_and_bound_the_scale_error() {
        let o = Vec2::new(285.0, 0.0);
        let pts = [[2000.0, 2000.0], [3000.0, 2000.0], [3000.0, 1000.0]];
        let mut s = samples(&pts, (5.0, 5.0), 1.0, o);
        // 0.2 px off at the middle position, across the first move
        s[1].tip_px.y += 0.2;
        let fit = fit_calibration(&s).unwrap();
        assert!(fit.residual_um_rms > 0.05, "{fit:?}");
        // a 0.2 px error over a 200 px move: at most 0.1 % of scale and 0.06° of rotation
        for sc in [fit.sx_um_per_px, fit.sy_um_per_px] {
            assert!((sc / 5.0 - 1.0).abs() < 1e-3, "{fit:?}");
        }
        assert!((fit.rotation_rad.to_degrees() - 1.0).abs() < 0.06, "{fit:?}");
    }

    #[test]
    fn unusable_positions_are_refused_saying_why() {
        let o = Vec2::zeros();
        let line = samples(&[[0.0, 0.0], [100.0, 0.0], [200.0, 0.0]], (5.0, 5.0), 0.0, o);
        assert!(fit_calibration(&line).unwrap_err().to_string().contains("line"));
        let two = samples(&[[0.0, 0.0], [100.0, 0.0]], (5.0, 5.0), 0.0, o);
        assert!(fit_calibration(&two).unwrap_err().to_string().contains("3 positions"));
        let mut flipped = samples(&[[0.0, 0.0], [100.0, 0.0], [100.0, 100.0]], (5.0, 5.0), 0.0, o);
        for s in &mut flipped {
            s.tip_px.y = -s.tip_px.y;
        }
        assert!(fit_calibration(&flipped).unwrap_err().to_string().contains("mirrored"));
        let mut nan = line.clone();
        nan[0].tip_px.x = f64::NAN;
        assert!(fit_calibration(&nan).unwrap_err().to_string().contains("finite"));
    }
}
