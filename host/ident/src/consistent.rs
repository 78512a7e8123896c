//! The set of supports consistent with the data (the paper's future work), rather than one
//! point: every simulated candidate whose total squared residual lies within a χ² threshold
//! of the best one.
//!
//! With residual components r = (Δx, Δy, L·Δθ) per tracked pose, n of them in all, and p
//! fitted parameters, the noise variance is estimated from the best fit as
//! s² = SSE_min / (n − p), and a candidate is consistent when
//! SSE ≤ SSE_min + s² · χ²_p(0.95) (the profile-likelihood confidence region). This assumes
//! independent tracking noise; model error that is correlated along a trial makes the region
//! too small, so the report gives the estimated noise floor next to it.

use super::score::Candidate;
use crate::Error;
use mesopush_sim::SupportDistribution;
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

/// Picks the consistent candidates among `candidates` (candidate, total SSE µm²).
pub fn consistent_set(
    candidates: &[(Candidate, f64)],
    n_residuals: usize,
    n_params: usize,
) -> Result<ConsistentSet, Error> {
    let sse_min = candidates.iter().map(|c| c.1).fold(f64::INFINITY, f64::min);
    if !sse_min.is_finite() || n_residuals <= n_params {
        return Err(Error::invalid("consistent set", "no candidate simulated all trials"));
    }
    let s2 = sse_min / (n_residuals - n_params) as f64;
    let threshold = sse_min + s2 * chi2_95(n_params);
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
        n_params,
        examined: candidates.len(),
        members,
        mu_range,
        point_bounds_um: bounds,
    })
}

/// The supports file (`[[supports]]` tables of [`SupportDistribution`]), read by
/// `mesopush robustness --supports FILE`.
#[derive(Debug, Serialize, serde::Deserialize)]
pub struct SupportsFile {
    /// The supports, best first.
    pub supports: Vec<SupportDistribution>,
}

impl ConsistentSet {
    /// Writes the members' supports as a TOML list with a comment header saying how they
    /// were chosen.
    pub fn save(&self, path: &Path) -> Result<(), Error> {
        let file =
            SupportsFile { supports: self.members.iter().map(|m| m.0.support.clone()).collect() };
        let body = toml::to_string(&file)
            .map_err(|e| Error::Parse { path: path.into(), message: e.to_string() })?;
        let header = format!(
            "# Supports consistent with the data (mesopush identify): {} of {} candidates with\n\
             # total SSE <= {:.3} um^2 (min {:.3}, noise s^2 = {:.4} um^2, chi2_95(p = {})).\n\
             # Probe friction over the set: {:.3} .. {:.3}. Points relative to the COM, um.\n",
            self.members.len(),
            self.examined,
            self.threshold_um2,
            self.sse_min_um2,
            self.noise_var_um2,
            self.n_params,
            self.mu_range[0],
            self.mu_range[1],
        );
        std::fs::write(path, header + &body).map_err(|e| Error::io(path, e))
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
}
