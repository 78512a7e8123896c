//! Thresholding of the darkening image: Otsu's method by default (on a histogram over the
//! plausible darkening range), or a fixed level the user chooses.

/// How the darkening image is split into object and background.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Threshold {
    /// Otsu's threshold, but never below `min` (so a frame of pure noise yields no object).
    Auto {
        /// Lowest acceptable threshold, share of the plate's light.
        min: f32,
    },
    /// A fixed darkening level, share of the plate's light (e.g. 0.25).
    Fixed(f32),
}

impl Default for Threshold {
    /// Otsu, at least 0.12 of the plate's light.
    fn default() -> Self {
        Threshold::Auto { min: 0.12 }
    }
}

const BINS: usize = 256;
const LO: f32 = -0.25;
const HI: f32 = 1.25;

/// The threshold for `darkening` (values are shares of the plate's light).
pub fn threshold_level(t: Threshold, darkening: &[f32]) -> f32 {
    match t {
        Threshold::Fixed(v) => v,
        Threshold::Auto { min } => otsu(darkening).max(min),
    }
}

/// Otsu's threshold: maximises the between-class variance of the histogram (of every eighth
/// value of a large image: still tens of thousands of samples, an eighth of the time).
pub fn otsu(values: &[f32]) -> f32 {
    let mut hist = [0u32; BINS];
    let scale = BINS as f32 / (HI - LO);
    let step = if values.len() >= 65_536 { 8 } else { 1 };
    let mut total = 0.0f64;
    for &v in values.iter().step_by(step) {
        total += 1.0;
        let b = ((v - LO) * scale).clamp(0.0, (BINS - 1) as f32) as usize;
        hist[b] += 1;
    }
    let sum_all: f64 = hist.iter().enumerate().map(|(i, &c)| i as f64 * f64::from(c)).sum();
    let (mut w0, mut sum0, mut best, mut best_bin) = (0.0, 0.0, -1.0, 0usize);
    for (i, &c) in hist.iter().enumerate() {
        w0 += f64::from(c);
        sum0 += i as f64 * f64::from(c);
        let w1 = total - w0;
        if w0 == 0.0 || w1 == 0.0 {
            continue;
        }
        let (m0, m1) = (sum0 / w0, (sum_all - sum0) / w1);
        let between = w0 * w1 * (m0 - m1).powi(2);
        if between > best {
            best = between;
            best_bin = i;
        }
    }
    LO + (best_bin as f32 + 1.0) / scale
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn otsu_splits_two_populations() {
        let mut v = vec![0.0f32; 9000];
        v.extend(std::iter::repeat_n(0.5f32, 1000));
        let t = otsu(&v);
        assert!(t > 0.0 && t < 0.5, "threshold {t}");
        assert_eq!(threshold_level(Threshold::Fixed(0.3), &v), 0.3);
        let noise_only = vec![0.01f32; 100];
        assert!(threshold_level(Threshold::default(), &noise_only) >= 0.12);
    }
}
