//! The statistics the reports quote, written once: medians and percentiles of samples, and the
//! Wilson score interval for a binomial proportion (the success rate's confidence interval
//! that stays inside [0, 1] and behaves at 0 and n successes, unlike the normal
//! approximation).

/// The median of `v` (the mean of the middle two for an even count); `None` when empty.
/// Sorts `v` in place (NaN last, as `f64::total_cmp` orders it).
pub fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let k = v.len() / 2;
    Some(if v.len() % 2 == 1 { v[k] } else { 0.5 * (v[k - 1] + v[k]) })
}

/// The `q`-quantile of `v` (0 ≤ q ≤ 1) as the sample at rank `round((n − 1)·q)` (no
/// interpolation: the value is one that was measured); `None` when empty. Sorts `v` in place.
pub fn percentile(v: &mut [f64], q: f64) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[rank(v.len(), q)])
}

/// [`percentile`] of integer samples (e.g. µs timings).
pub fn percentile_i64(v: &mut [i64], q: f64) -> Option<i64> {
    if v.is_empty() {
        return None;
    }
    v.sort_unstable();
    Some(v[rank(v.len(), q)])
}

fn rank(n: usize, q: f64) -> usize {
    let q = if q.is_nan() { 0.5 } else { q.clamp(0.0, 1.0) };
    (((n - 1) as f64 * q).round() as usize).min(n - 1)
}

/// z for a two-sided 95 % interval.
pub const Z95: f64 = 1.959_963_984_540_054;

/// Wilson score interval `(low, high)` for `successes` out of `n` at normal quantile `z`.
/// `n = 0` gives the uninformative (0, 1).
pub fn wilson_interval(successes: usize, n: usize, z: f64) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let nf = n as f64;
    let p = successes as f64 / nf;
    let z2 = z * z;
    let denom = 1.0 + z2 / nf;
    let centre = (p + z2 / (2.0 * nf)) / denom;
    let half = z / denom * (p * (1.0 - p) / nf + z2 / (4.0 * nf * nf)).sqrt();
    // At 0 and n successes the exact ends are 0 and 1; rounding must not move them.
    let low = if successes == 0 { 0.0 } else { (centre - half).max(0.0) };
    let high = if successes >= n { 1.0 } else { (centre + half).min(1.0) };
    (low, high)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_and_percentiles() {
        assert_eq!(median(&mut []), None);
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), Some(2.5));
        let mut v: Vec<f64> = (0..101).rev().map(f64::from).collect();
        assert_eq!(percentile(&mut v, 0.9), Some(90.0));
        assert_eq!(percentile(&mut v, 0.0), Some(0.0));
        assert_eq!(percentile(&mut v, 1.0), Some(100.0));
        assert_eq!(percentile(&mut v, 7.0), Some(100.0), "q is clamped");
        assert_eq!(percentile_i64(&mut [5, 1, 9, 3], 0.5), Some(5));
        assert_eq!(percentile_i64(&mut [], 0.5), None);
    }

    #[test]
    fn matches_published_values() {
        // Newcombe (1998), Table I: 81/263 → 0.2553–0.3662 (Wilson, no continuity correction).
        let (lo, hi) = wilson_interval(81, 263, Z95);
        assert!((lo - 0.2553).abs() < 5e-4 && (hi - 0.3662).abs() < 5e-4, "{lo} {hi}");
        // 0/10 → 0–0.2775, 10/10 → 0.7225–1.
        let (lo, hi) = wilson_interval(0, 10, Z95);
        assert!(lo == 0.0 && (hi - 0.2775).abs() < 5e-4, "{hi}");
        let (lo, hi) = wilson_interval(10, 10, Z95);
        assert!((lo - 0.7225).abs() < 5e-4 && hi == 1.0, "{lo}");
    }
}
