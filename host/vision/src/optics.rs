//! The camera side of the synthetic microscope: uneven illumination, Gaussian optical blur,
//! sensor noise (read noise plus shot noise) and 8-bit quantisation.

use rand::Rng;

use crate::raster::Plane;

/// Relative illumination at pixel centre `(u, v)` of a `w × h` image: a linear gradient plus
/// radial vignetting, 1 at the image centre.
pub(crate) fn illumination(
    u: f64,
    v: f64,
    w: f64,
    h: f64,
    gradient: (f64, f64),
    vignetting: f64,
) -> f64 {
    let x = (u - 0.5 * w) / w;
    let y = (v - 0.5 * h) / h;
    // corners are at x² + y² = 0.5
    1.0 + gradient.0 * x + gradient.1 * y - vignetting * 2.0 * (x * x + y * y)
}

/// Normalised 1-D Gaussian kernel with radius `ceil(3σ)`; `[1.0]` for σ = 0.
pub(crate) fn gaussian_kernel(sigma_px: f64) -> Vec<f32> {
    if sigma_px <= 0.0 {
        return vec![1.0];
    }
    let r = (3.0 * sigma_px).ceil() as i32;
    let k: Vec<f64> = (-r..=r).map(|i| (-0.5 * (f64::from(i) / sigma_px).powi(2)).exp()).collect();
    let sum: f64 = k.iter().sum();
    k.iter().map(|v| (v / sum) as f32).collect()
}

/// Separable convolution with `kernel`, edges clamped (replicated).
pub(crate) fn blur(plane: &Plane, kernel: &[f32]) -> Plane {
    if kernel.len() == 1 {
        return plane.clone();
    }
    let (w, h) = (plane.width, plane.height);
    let r = kernel.len() / 2;
    let mut tmp = Plane::filled(w, h, 0.0);
    for j in 0..h {
        let row = &plane.data[j * w..(j + 1) * w];
        let out = &mut tmp.data[j * w..(j + 1) * w];
        for (i, o) in out.iter_mut().enumerate() {
            let mut acc = 0.0;
            for (k, kv) in kernel.iter().enumerate() {
                let x = (i + k).saturating_sub(r).min(w - 1);
                acc += kv * row[x];
            }
            *o = acc;
        }
    }
    let mut out = Plane::filled(w, h, 0.0);
    for j in 0..h {
        for (k, kv) in kernel.iter().enumerate() {
            let y = (j + k).saturating_sub(r).min(h - 1);
            let src = &tmp.data[y * w..(y + 1) * w];
            let dst = &mut out.data[j * w..(j + 1) * w];
            for (d, s) in dst.iter_mut().zip(src) {
                *d += kv * s;
            }
        }
    }
    out
}

/// Half-open pixel rectangle `[x0, x1) × [y0, y1)`.
pub(crate) type Region = (usize, usize, usize, usize);

/// The bounding box of the pixels where `a` and `b` differ (`None` when equal).
pub(crate) fn changed_region(a: &Plane, b: &Plane) -> Option<Region> {
    debug_assert_eq!((a.width, a.height), (b.width, b.height));
    let w = a.width;
    let (mut x0, mut x1, mut y0, mut y1) = (usize::MAX, 0, usize::MAX, 0);
    for (j, (ra, rb)) in a.data.chunks_exact(w).zip(b.data.chunks_exact(w)).enumerate() {
        let Some(first) = ra.iter().zip(rb).position(|(p, q)| p != q) else { continue };
        let last = w - 1 - ra.iter().zip(rb).rev().position(|(p, q)| p != q).unwrap_or(0);
        (x0, x1, y0, y1) = (x0.min(first), x1.max(last + 1), y0.min(j), y1.max(j + 1));
    }
    (x0 < x1).then_some((x0, x1, y0, y1))
}

/// Re-blurs the part of `out` (= `blur(old)`) that changes when `old` becomes `plane`, which
/// differs from `old` only inside `changed`: the pixels within the kernel radius of it. Each
/// pixel is computed with the very operations, in the same order, as [`blur`], so the result
/// is bit-identical to `blur(plane, kernel)` at a fraction of the cost when `changed` is small.
pub(crate) fn reblur_region(plane: &Plane, kernel: &[f32], changed: Region, out: &mut Plane) {
    let (w, h) = (plane.width, plane.height);
    debug_assert_eq!((out.width, out.height), (w, h));
    let r = kernel.len() / 2;
    let (x0, x1) = (changed.0.saturating_sub(r), (changed.1 + r).min(w));
    let (y0, y1) = (changed.2.saturating_sub(r), (changed.3 + r).min(h));
    // Horizontal pass on the rows the vertical pass reads, columns x0..x1 only.
    let (t0, t1) = (y0.saturating_sub(r), (y1 + r).min(h));
    let cols = x1 - x0;
    let mut tmp = vec![0.0f32; (t1 - t0) * cols];
    for y in t0..t1 {
        let row = &plane.data[y * w..(y + 1) * w];
        for (c, o) in tmp[(y - t0) * cols..(y - t0 + 1) * cols].iter_mut().enumerate() {
            let mut acc = 0.0;
            for (k, kv) in kernel.iter().enumerate() {
                acc += kv * row[(x0 + c + k).saturating_sub(r).min(w - 1)];
            }
            *o = acc;
        }
    }
    for j in y0..y1 {
        let dst = &mut out.data[j * w + x0..j * w + x1];
        dst.fill(0.0);
        for (k, kv) in kernel.iter().enumerate() {
            let y = (j + k).saturating_sub(r).min(h - 1);
            let src = &tmp[(y - t0) * cols..(y - t0 + 1) * cols];
            for (d, s) in dst.iter_mut().zip(src) {
                *d += kv * s;
            }
        }
    }
}

/// A standard normal deviate from one 64-bit draw: the sum of four 16-bit uniforms, rescaled
/// (Irwin–Hall; tails end at ±3.46σ, plenty for sensor noise and cheap enough for 30 Hz).
pub(crate) fn normal(rng: &mut impl Rng) -> f32 {
    let bits = rng.next_u64();
    let sum: u32 = (0..4).map(|k| ((bits >> (16 * k)) & 0xffff) as u32).sum();
    let u = sum as f32 / 65536.0 - 2.0;
    u * 3f32.sqrt()
}

/// Adds read noise (σ = `read_dn`) and shot noise (variance `gain * signal`), then rounds and
/// clamps to 8 bits.
pub(crate) fn expose(
    radiance: &Plane,
    read_dn: f64,
    shot_gain: f64,
    rng: &mut impl Rng,
) -> Vec<u8> {
    let (read2, gain) = ((read_dn * read_dn) as f32, shot_gain as f32);
    radiance
        .data
        .iter()
        .map(|&s| {
            let sigma = (read2 + gain * s.max(0.0)).sqrt();
            let v = s + sigma * normal(rng);
            v.round().clamp(0.0, 255.0) as u8
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn kernel_is_normalised_and_blur_preserves_the_sum() {
        let k = gaussian_kernel(1.2);
        assert!((k.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        let mut p = Plane::filled(32, 32, 0.0);
        p.data[16 * 32 + 16] = 100.0;
        let b = blur(&p, &k);
        assert!((b.data.iter().sum::<f32>() - 100.0).abs() < 1e-3);
        assert!(b.data[16 * 32 + 16] < 20.0);
    }

    #[test]
    fn reblurring_the_changed_region_is_bit_identical_to_a_full_blur() {
        let k = gaussian_kernel(1.3);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let base = Plane {
            width: 40,
            height: 30,
            data: (0..1200).map(|_| normal(&mut rng).abs() * 50.0).collect(),
        };
        let blurred = blur(&base, &k);
        // Changes in the middle, at a corner (clamped edges) and nowhere.
        for (xs, ys) in [(10..17, 8..12), (0..3, 26..30), (5..5, 5..5)] {
            let mut p = base.clone();
            for y in ys.clone() {
                for x in xs.clone() {
                    p.data[y * 40 + x] *= 0.3;
                }
            }
            let mut out = blurred.clone();
            if let Some(region) = changed_region(&base, &p) {
                assert_eq!(region, (xs.start, xs.end, ys.start, ys.end));
                reblur_region(&p, &k, region, &mut out);
            }
            let full = blur(&p, &k);
            assert!(out.data.iter().zip(&full.data).all(|(a, b)| a.to_bits() == b.to_bits()));
        }
    }

    #[test]
    fn noise_has_unit_variance() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let n = 100_000;
        let xs: Vec<f32> = (0..n).map(|_| normal(&mut rng)).collect();
        let mean = xs.iter().sum::<f32>() / n as f32;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / n as f32;
        assert!(mean.abs() < 0.02, "mean {mean}");
        assert!((var - 1.0).abs() < 0.03, "variance {var}");
    }

    #[test]
    fn illumination_is_one_at_the_centre_and_darker_in_corners() {
        assert!((illumination(320.0, 240.0, 640.0, 480.0, (0.1, 0.1), 0.2) - 1.0).abs() < 1e-12);
        assert!(illumination(0.0, 480.0, 640.0, 480.0, (0.0, 0.0), 0.2) < 0.81);
    }
}
