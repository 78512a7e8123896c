//! Image formation of the independent microscope: coverage of each pixel by an outline
//! (scanlines at five sub-rows per pixel, exact along each sub-row) or by the needle (6 × 6
//! samples near its outline), transmissions that multiply, illumination with a linear
//! gradient and cos⁴ vignetting about an off-centre optical axis, Gaussian blur, photon and
//! read noise, and 8-bit rounding.

use super::pt::Pt;
use super::wedge::Wedge;
use crate::indep::rng::Rng;

/// Sub-rows per pixel row in the polygon scanline.
const SUB_ROWS: usize = 5;
/// Samples per pixel side near the needle's outline.
const SUB_NEEDLE: usize = 6;

/// An image of `f64` values, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Plane {
    /// Width, px.
    pub width: usize,
    /// Height, px.
    pub height: usize,
    /// Values, `width × height`.
    pub data: Vec<f64>,
}

impl Plane {
    /// A plane filled with `v`.
    pub fn filled(width: usize, height: usize, v: f64) -> Self {
        Self { width, height, data: vec![v; width * height] }
    }

    /// Multiplies each pixel by `1 − coverage · (1 − transmission)`.
    pub fn attenuate(&mut self, coverage: &Plane, transmission: f64) {
        for (v, c) in self.data.iter_mut().zip(&coverage.data) {
            *v *= 1.0 - c * (1.0 - transmission);
        }
    }
}

/// Share of each pixel inside the closed polygon `poly` (pixel coordinates).
pub fn polygon_coverage(poly: &[Pt], width: usize, height: usize) -> Plane {
    let mut cov = Plane::filled(width, height, 0.0);
    let (lo, hi) =
        poly.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.y), b.max(p.y)));
    let j0 = lo.floor().max(0.0) as usize;
    let j1 = (hi.ceil().max(0.0) as usize).min(height);
    let mut xs: Vec<f64> = Vec::new();
    for j in j0..j1 {
        for k in 0..SUB_ROWS {
            let y = j as f64 + (k as f64 + 0.5) / SUB_ROWS as f64;
            xs.clear();
            for (i, &a) in poly.iter().enumerate() {
                let b = poly[(i + 1) % poly.len()];
                if (a.y <= y) != (b.y <= y) {
                    xs.push(a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y));
                }
            }
            xs.sort_by(f64::total_cmp);
            let row = &mut cov.data[j * width..(j + 1) * width];
            for span in xs.chunks_exact(2) {
                add_span(row, span[0], span[1], 1.0 / SUB_ROWS as f64);
            }
        }
    }
    cov
}

/// Adds `weight × overlap` of `[x0, x1)` with each pixel `[i, i+1)` of `row`.
fn add_span(row: &mut [f64], x0: f64, x1: f64, weight: f64) {
    let x0 = x0.max(0.0);
    let x1 = x1.min(row.len() as f64);
    if x1 <= x0 {
        return;
    }
    let (i0, i1) = (x0.floor() as usize, (x1.ceil() as usize).min(row.len()));
    for (i, v) in row.iter_mut().enumerate().take(i1).skip(i0) {
        let overlap = (x1.min(i as f64 + 1.0) - x0.max(i as f64)).max(0.0);
        *v += weight * overlap;
    }
}

/// Share of each pixel inside the needle; `um_per_px` maps pixel coordinates to µm.
pub fn needle_coverage(w: &Wedge, um_per_px: (f64, f64), width: usize, height: usize) -> Plane {
    let mut cov = Plane::filled(width, height, 0.0);
    let (sx, sy) = um_per_px;
    let half_diag = 0.5 * (sx * sx + sy * sy).sqrt();
    for j in 0..height {
        for i in 0..width {
            let c = Pt::new((i as f64 + 0.5) * sx, (j as f64 + 0.5) * sy);
            let d = w.distance_bound(c);
            cov.data[j * width + i] = if d > half_diag {
                0.0
            } else if d < -half_diag && w.contains(c) {
                1.0
            } else {
                let mut inside = 0;
                for b in 0..SUB_NEEDLE {
                    for a in 0..SUB_NEEDLE {
                        let u = i as f64 + (a as f64 + 0.5) / SUB_NEEDLE as f64;
                        let v = j as f64 + (b as f64 + 0.5) / SUB_NEEDLE as f64;
                        inside += usize::from(w.contains(Pt::new(u * sx, v * sy)));
                    }
                }
                inside as f64 / (SUB_NEEDLE * SUB_NEEDLE) as f64
            };
        }
    }
    cov
}

/// The lamp as the camera sees it through the bare plate, DN: `level` at the optical axis,
/// a linear gradient `(gx, gy)` across the field and cos⁴ vignetting with focal length
/// `focal_px` about the axis at `axis_px`.
pub fn illumination(
    width: usize,
    height: usize,
    level: f64,
    gradient: (f64, f64),
    axis_px: Pt,
    focal_px: f64,
) -> Plane {
    let mut p = Plane::filled(width, height, 0.0);
    for j in 0..height {
        for i in 0..width {
            let (u, v) = (i as f64 + 0.5, j as f64 + 0.5);
            let lin = 1.0
                + gradient.0 * (2.0 * u / width as f64 - 1.0)
                + gradient.1 * (2.0 * v / height as f64 - 1.0);
            let r2 = ((Pt::new(u, v) - axis_px).norm() / focal_px).powi(2);
            p.data[j * width + i] = level * lin / (1.0 + r2).powi(2);
        }
    }
    p
}

/// Separable Gaussian blur of σ `sigma_px` (edges repeat the border pixel).
pub fn gaussian_blur(p: &Plane, sigma_px: f64) -> Plane {
    let r = (4.0 * sigma_px).ceil() as isize;
    let k: Vec<f64> = (-r..=r).map(|i| (-0.5 * (i as f64 / sigma_px).powi(2)).exp()).collect();
    let norm: f64 = k.iter().sum();
    let (w, h) = (p.width as isize, p.height as isize);
    let pass = |src: &Plane, horizontal: bool| {
        let mut out = Plane::filled(src.width, src.height, 0.0);
        for y in 0..h {
            for x in 0..w {
                let mut acc = 0.0;
                for (t, kv) in (-r..=r).zip(&k) {
                    let (xx, yy) = if horizontal {
                        ((x + t).clamp(0, w - 1), y)
                    } else {
                        (x, (y + t).clamp(0, h - 1))
                    };
                    acc += kv * src.data[(yy * w + xx) as usize];
                }
                out.data[(y * w + x) as usize] = acc / norm;
            }
        }
        out
    };
    pass(&pass(p, true), false)
}

/// The sensor: photon noise (`electrons_per_dn` electrons per DN), read noise `read_dn` and
/// rounding to 8 bits, averaged over `frames` exposures.
pub fn expose(
    p: &Plane,
    electrons_per_dn: f64,
    read_dn: f64,
    frames: u32,
    rng: &mut Rng,
) -> Vec<u8> {
    let n = f64::from(frames.max(1));
    p.data
        .iter()
        .map(|&v| {
            let shot = (v.max(0.0) / (electrons_per_dn * n)).sqrt();
            let noisy = v + shot * rng.normal() + read_dn / n.sqrt() * rng.normal();
            noisy.round().clamp(0.0, 255.0) as u8
        })
        .collect()
}
