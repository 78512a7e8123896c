//! Honest uncertainty: the fit repeated on bootstrap resamples of the trials (n trials drawn
//! with replacement, Levenberg–Marquardt from the full fit), so a parameter the trials do not
//! pin down shows as spread between refits instead of as one confident number. A trial is the
//! resampled unit because its residuals are correlated along it (one wrong support bends a
//! whole stroke); resampling poses would pretend there are thousands of independent ones.
//!
//! Fewer than three trials give no bootstrap (every resample is nearly the same trial); the
//! consistent set's spread ([`crate::consistent`]) is then all there is.

use super::data::IdentTrial;
use super::joint::{Layout, TrialObjective, refine};
use super::score::{Candidate, ScoreSettings};
use rand::{Rng, RngExt};
use serde::Serialize;

/// Bootstrap knobs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BootstrapSettings {
    /// Resamples (0: no bootstrap). Default 8.
    pub resamples: usize,
    /// Objective evaluations per refit. Default 100.
    pub evals: usize,
}

impl Default for BootstrapSettings {
    fn default() -> Self {
        Self { resamples: 8, evals: 100 }
    }
}

/// One parameter's spread over the refits.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Spread {
    /// Name with unit.
    pub name: String,
    /// Mean over the refits.
    pub mean: f64,
    /// Sample standard deviation over the refits.
    pub sd: f64,
}

/// The refits and the spread of each parameter.
#[derive(Debug, Clone, Serialize)]
pub struct Bootstrap {
    /// Each refit's candidate and its total squared residual on its resample, µm².
    pub fits: Vec<(Candidate, f64)>,
    /// Per parameter: μ_probe, the mean surface μ, each support coordinate (µm).
    pub spread: Vec<Spread>,
    /// Evaluations used.
    pub evals: usize,
}

/// The named parameters of `c`: μ_probe, mean surface μ, r1x, r1y, …, r3y (µm).
pub fn named(c: &Candidate) -> Vec<(String, f64)> {
    let mu = c.support.mu_surface;
    let mut out = vec![
        ("mu_probe".to_string(), c.mu_probe),
        ("mu_surface_mean".to_string(), (mu[0] + mu[1] + mu[2]) / 3.0),
    ];
    for (i, p) in c.support.points_um.iter().enumerate() {
        out.push((format!("support{}_x_um", i + 1), p[0]));
        out.push((format!("support{}_y_um", i + 1), p[1]));
    }
    out
}

/// Refits `best` on `settings.resamples` bootstrap resamples of `trials`; `None` with fewer
/// than three trials or no resamples.
pub fn bootstrap(
    trials: &[IdentTrial],
    best: &Candidate,
    layout: Layout,
    settings: &BootstrapSettings,
    score: &ScoreSettings,
    rng: &mut impl Rng,
    tick: &(dyn Fn() + Sync),
) -> Option<Bootstrap> {
    let n = trials.len();
    if n < 3 || settings.resamples == 0 {
        return None;
    }
    let l_um = trials[0].part.char_length_um();
    let mut fits = Vec::with_capacity(settings.resamples);
    let mut evals = 0;
    for _ in 0..settings.resamples {
        let sample: Vec<IdentTrial> =
            (0..n).map(|_| trials[rng.random_range(0..n)].clone()).collect();
        let objective = TrialObjective { trials: &sample, score };
        let o = refine(&objective, l_um, best, layout, settings.evals, tick);
        evals += o.evals;
        fits.push((o.best, o.total_sse_um2));
    }
    let named_fits: Vec<Vec<(String, f64)>> = fits.iter().map(|(c, _)| named(c)).collect();
    let spread = (0..named_fits[0].len())
        .map(|k| {
            let v: Vec<f64> = named_fits.iter().map(|f| f[k].1).collect();
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
            Spread { name: named_fits[0][k].0.clone(), mean, sd: var.sqrt() }
        })
        .collect();
    Some(Bootstrap { fits, spread, evals })
}
