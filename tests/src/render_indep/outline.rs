//! The rough-edged peg: a rectangle whose every edge is displaced along its normal by a
//! random profile (a sum of sinusoids with wavelengths from 12 to 400 µm, scaled to a given
//! RMS), sampled every micrometre. The roughness fades out within 20 µm of the corners so
//! the outline closes. The centre of mass is the area centroid of the sampled outline.

use super::pt::Pt;
use crate::indep::rng::Rng;

/// Sinusoids per edge profile.
const WAVES: usize = 16;
/// Outline sample spacing, µm.
const STEP_UM: f64 = 1.0;
/// The roughness fades to zero over this distance from each corner, µm.
const CORNER_FADE_UM: f64 = 20.0;

/// A peg's outline in its body frame (nominal rectangle centred on the origin).
#[derive(Debug, Clone, PartialEq)]
pub struct RoughPeg {
    /// Nominal size, µm (length along body x, width along body y).
    pub size_um: (f64, f64),
    /// The rough outline, body frame, µm (closed: the last point joins the first).
    pub outline: Vec<Pt>,
    /// The area centroid of the rough outline, body frame, µm.
    pub centroid: Pt,
    /// The largest displacement of the outline from the nominal rectangle, µm.
    pub max_deviation_um: f64,
}

/// One edge's profile: `Σ a sin(2π s / λ + φ)`.
#[derive(Debug, Clone)]
struct Profile(Vec<(f64, f64, f64)>);

impl Profile {
    fn random(rng: &mut Rng) -> Self {
        let (lo, hi): (f64, f64) = (12.0, 400.0);
        Profile(
            (0..WAVES)
                .map(|_| {
                    let lambda = (lo.ln() + (hi.ln() - lo.ln()) * rng.unit()).exp();
                    let amp = (lambda / hi).sqrt() * (0.5 + rng.unit());
                    (amp, lambda, rng.range(0.0, std::f64::consts::TAU))
                })
                .collect(),
        )
    }

    fn at(&self, s: f64) -> f64 {
        self.0.iter().map(|&(a, l, p)| a * (std::f64::consts::TAU * s / l + p).sin()).sum()
    }
}

impl RoughPeg {
    /// A `length × width` µm peg whose edges are rough with `rms_um` RMS.
    pub fn new(length_um: f64, width_um: f64, rms_um: f64, rng: &mut Rng) -> Self {
        let (a, b) = (0.5 * length_um, 0.5 * width_um);
        let corners = [Pt::new(-a, -b), Pt::new(a, -b), Pt::new(a, b), Pt::new(-a, b)];
        let profiles: Vec<Profile> = (0..4).map(|_| Profile::random(rng)).collect();
        // raw samples: (corner index, arc length, raw displacement)
        let mut raw = Vec::new();
        for (i, &c) in corners.iter().enumerate() {
            let len = (corners[(i + 1) % 4] - c).norm();
            let n = (len / STEP_UM).ceil() as usize;
            for k in 0..n {
                let s = k as f64 * len / n as f64;
                let fade = smoothstep(s.min(len - s) / CORNER_FADE_UM);
                raw.push((i, s, fade * profiles[i].at(s)));
            }
        }
        let rms_raw = (raw.iter().map(|r| r.2 * r.2).sum::<f64>() / raw.len() as f64).sqrt();
        let k = if rms_raw > 0.0 { rms_um / rms_raw } else { 0.0 };
        let outline: Vec<Pt> = raw
            .iter()
            .map(|&(i, s, d)| {
                let c = corners[i];
                let dir = (corners[(i + 1) % 4] - c) * (1.0 / (corners[(i + 1) % 4] - c).norm());
                let out = Pt::new(dir.y, -dir.x);
                c + dir * s + out * (k * d)
            })
            .collect();
        let max_deviation_um = raw.iter().map(|r| (k * r.2).abs()).fold(0.0, f64::max);
        let centroid = area_centroid(&outline);
        Self { size_um: (length_um, width_um), outline, centroid, max_deviation_um }
    }
}

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// The area centroid of a closed polygon (shoelace).
pub fn area_centroid(p: &[Pt]) -> Pt {
    let (mut a2, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for (i, &u) in p.iter().enumerate() {
        let v = p[(i + 1) % p.len()];
        let c = u.x * v.y - v.x * u.y;
        a2 += c;
        cx += (u.x + v.x) * c;
        cy += (u.y + v.y) * c;
    }
    Pt::new(cx / (3.0 * a2), cy / (3.0 * a2))
}
