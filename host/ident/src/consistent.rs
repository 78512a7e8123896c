//! The set of supports consistent with the data (the paper's future work), rather than one
//! point: every simulated candidate whose total squared residual lies within a χ² threshold
//! of the best one.
//!
//! With residual components r = (Δx, Δy, L·Δθ) per tracked pose, n of them in all, and p
//! fitted parameters, the noise variance is estimated from the best fit as
//! s² = SSE_min / (n − p), and a candidate is consistent when
//! SSE ≤ SSE_min + s² · χ²_p(0.95) · n / n_eff (the profile-likelihood confidence region).
//! Independent tracking noise would give n_eff = n; model error is correlated along a trial
//! (one wrong support bends a whole stroke), and counting its n residuals as independent made
//! the region collapse onto one point (15 supports agreeing to 1e-6 µm on a real push while
//! the rotated world moved μ tenfold). So n_eff = n (1 − ρ)/(1 + ρ) from the best fit's
//! lag-one autocorrelation ρ of the residuals along each trial ([`effective_count`]), the
//! variance inflation of an AR(1) series. The bootstrap refits ([`crate::bootstrap`]) join the
//! set, so what the trials cannot pin down shows as spread.

use super::score::Candidate;
use crate::Error;
use mesopush_sim::support_set::{SupportSample, SupportSet};
use serde::Serialize;
use std::path::Path;

/// Upper 95 % quantile of the χ² distribution with `p` degrees of freedom (Wilson–Hilferty;
/// within 1 % for p ≥ 3).
pub fn chi2_95(p: usize) -> f64 {
    let p = p as f64;
    let z = 1.644_853_6;
    let a = 2.0 / (9.0 * p);
    p * (1.0 - a + z * a.sqrt()).powi(3)
}

/// The consistent set and how it was chosen.
#[derive(Debug, Clone, Serialize)]
pub struct ConsistentSet {
    /// Best total squared residual, µm².
    pub sse_min_um2: f64,
    /// Estimated noise variance per residual component, µm² (s²).
    pub noise_var_um2: f64,
    /// Threshold on the total squared residual, µm².
    pub threshold_um2: f64,
    /// Residual components n and fitted parameters p.
    pub n_residuals: usize,
    /// Effective number of independent residuals n_eff (≤ n; see the module header).
    pub n_effective: f64,
    /// Fitted parameters.
    pub n_params: usize,
    /// Candidates examined.
    pub examined: usize,
    /// The consistent candidates, best first.
    pub members: Vec<(Candidate, f64)>,
    /// Range of μ over the members.
    pub mu_range: [f64; 2],
    /// Bounding box of each support point over the members, µm: [[xmin, ymin], [xmax, ymax]].
    pub point_bounds_um: [[[f64; 2]; 2]; 3],
}

/// The effective number of independent scalars among residual series `series` (one per
/// trial and component): Σ n_k (1 − ρ)/(1 + ρ), ρ the pooled lag-one autocorrelation
/// (clamped to [0, 0.999]: negative correlation is not counted as extra information).
pub fn effective_count(series: &[Vec<f64>]) -> f64 {
    let (mut num, mut den, mut n) = (0.0, 0.0, 0usize);
    for r in series {
        n += r.len();
        den += r.iter().map(|v| v * v).sum::<f64>();
        num += r.windows(2).map(|w| w[0] * w[1]).sum::<f64>();
    }
    let rho = if den > 0.0 { (num / den).clamp(0.0, 0.999) } else { 0.0 };
    n as f64 * (1.0 - rho) / (1.0 + rho)
}

/// Picks the consistent candidates among `candidates` (candidate, total SSE µm²), with
/// `n_effective` independent scalars among the `n_residuals` ([`effective_count`]).
pub fn consistent_set(
    candidates: &[(Candidate, f64)],
    n_residuals: usize,
    n_effective: f64,
    n_params: usize,
) -> Result<ConsistentSet, Error> {
    let sse_min = candidates.iter().map(|c| c.1).fold(f64::INFINITY, f64::min);
    if !sse_min.is_finite() || n_residuals <= n_params {
        return Err(Error::invalid("consistent set", "no candidate simulated all trials"));
    }
    let s2 = sse_min / (n_residuals - n_params) as f64;
    let inflation = n_residuals as f64 / n_effective.clamp(1.0, n_residuals as f64);
    let threshold = sse_min + s2 * chi2_95(n_params) * inflation;
    let mut members: Vec<(Candidate, f64)> =
        candidates.iter().filter(|c| c.1 <= threshold).cloned().collect();
    members.sort_by(|a, b| a.1.total_cmp(&b.1));
    members.dedup_by(|a, b| a.0 == b.0);
    let mut mu_range = [f64::INFINITY, f64::NEG_INFINITY];
    let mut bounds = [[[f64::INFINITY; 2], [f64::NEG_INFINITY; 2]]; 3];
    for (c, _) in &members {
        mu_range = [mu_range[0].min(c.mu_probe), mu_range[1].max(c.mu_probe)];
        for (b, p) in bounds.iter_mut().zip(c.support.points_um) {
            for a in 0..2 {
                b[0][a] = b[0][a].min(p[a]);
                b[1][a] = b[1][a].max(p[a]);
            }
        }
    }
    Ok(ConsistentSet {
        sse_min_um2: sse_min,
        noise_var_um2: s2,
        threshold_um2: threshold,
        n_residuals,
        n_effective,
        n_params,
        examined: candidates.len(),
        members,
        mu_range,
        point_bounds_um: bounds,
    })
}

impl ConsistentSet {
    /// The members as a support set (each with its probe friction), best first.
    pub fn support_set(&self) -> SupportSet {
        let support =
            self.members.iter().map(|(c, _)| SupportSample::new(Some(c.mu_probe), &c.support));
        SupportSet { support: support.collect() }
    }

    /// Writes the members as a support set (`[[support]]` tables with `mu_probe`, read by
    /// `mesopush robustness --supports FILE`) with a comment header saying how they were
    /// chosen.
    pub fn save(&self, path: &Path) -> Result<(), Error> {
        let header = format!(
            "Supports consistent with the data (mesopush identify): {} of {} candidates with\n\
             total SSE <= {:.3} um^2 (min {:.3}, noise s^2 = {:.4} um^2, chi2_95(p = {}),\n\
             n = {} residuals counted as n_eff = {:.0} independent ones).\n\
             Probe friction over the set: {:.3} .. {:.3}. Points relative to the COM, um;\n\
             each probe friction was fitted with its support: sample them as pairs.",
            self.members.len(),
            self.examined,
            self.threshold_um2,
            self.sse_min_um2,
            self.noise_var_um2,
            self.n_params,
            self.n_residuals,
            self.n_effective,
            self.mu_range[0],
            self.mu_range[1],
        );
        Ok(self.support_set().save(path, &header)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_quantiles_match_tables() {
        for (p, q) in [(3, 7.815), (7, 14.067), (8, 15.507)] {
            assert!((chi2_95(p) - q).abs() / q < 0.01, "p = {p}: {}", chi2_95(p));
        }
    }

    #[test]
    fn correlated_residuals_count_as_fewer() {
        let white: Vec<f64> = (0..400).map(|k| if k % 2 == 0 { 1.0 } else { -1.0 }).collect();
        assert_eq!(effective_count(&[white]), 400.0);
        // A slow drift: neighbours almost equal, ρ ≈ 1, a handful of independent values.
        let drift: Vec<f64> = (0..400).map(|k| (k as f64 / 100.0).sin() + 1.5).collect();
        let n = effective_count(&[drift]);
        assert!(n < 5.0, "{n}");
    }
}
