//! A compact fitter: the noise-weighted least squares of [`super::objective`] minimised over
//! a candidate's parameter vector by trying its start grid, then a bounded Nelder–Mead simplex
//! and Levenberg–Marquardt on the residual vector (both from [`mesopush_ident::optim`]).
//! Generic over the parameter vector; deterministic (no randomness, a fixed evaluation
//! budget).

use super::candidates::{Effect, NOMINAL, Param};
use super::data::TrialData;
use super::objective::{FAILED, loss, residual_vector};
use super::residual::Noise;
use mesopush_ident::optim::{Centroid, LmSettings, NelderMeadSettings, Stop};
use mesopush_ident::optim::{axis_simplex, levenberg_marquardt, nelder_mead};
use mesopush_sim::{Model, SimSettings};

/// Diagnosis's simplex: stops when |worst − best| ≤ 1e-9 (1 + |best|), sums the centroid
/// then divides, and iterates while any evaluation is left (the settings its confusion
/// matrix and the README's figures were made with).
pub const SIMPLEX: NelderMeadSettings = NelderMeadSettings {
    stop: Stop::Spread { rel: 1e-9 },
    centroid: Centroid::SumThenDivide,
    reserve: 1,
    ..NelderMeadSettings::DEFAULT
};

/// Levenberg–Marquardt on the nominal parameters only (the effect's held at its value in
/// `v`, a full parameter vector of `candidate`), at most about `budget` evaluations: where
/// the nominal parameters go once the effect is on. The nominal fit has bent them to absorb
/// the missing effect's signature (the support's place is the most sensitive), so an effect
/// tried at the nominal optimum can look worse than none although it is there.
pub fn refit_nominal(
    candidate: Effect,
    base: &Model,
    trials: &[TrialData],
    settings: &SimSettings,
    noise: &Noise,
    v: &[f64],
    budget: usize,
) -> (Vec<f64>, f64) {
    let params = candidate.params();
    let k = NOMINAL.len();
    let full = |x: &[f64]| -> Vec<f64> { x.iter().chain(&v[k..]).copied().collect() };
    let res = |x: &[f64]| -> Option<Vec<f64>> {
        residual_vector(trials, &candidate.apply(base, &clamp(&params, &full(x))), settings, noise)
    };
    let h: Vec<f64> = params[..k].iter().map(|p| p.step * 0.05).collect();
    let m = levenberg_marquardt(&res, &v[..k], &h, budget, &LmSettings::DEFAULT);
    (clamp(&params, &full(&m.x)), m.value)
}

/// A fitted candidate.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// Which candidate.
    pub candidate: Effect,
    /// Fitted parameter vector (nominal ones first).
    pub values: Vec<f64>,
    /// The fitted model.
    pub model: Model,
    /// The base model the parameter vector applies to ([`Effect::apply`]).
    pub base: Model,
    /// Training loss (weighted SSE).
    pub loss: f64,
    /// Scalar residuals in the training loss.
    pub n: usize,
    /// Model evaluations used.
    pub evals: usize,
}

/// `v` clamped into each parameter's bounds.
pub(crate) fn clamp(params: &[Param], v: &[f64]) -> Vec<f64> {
    v.iter().zip(params).map(|(x, p)| x.clamp(p.lo, p.hi)).collect()
}

/// Fits `candidate` on `trials`, trying each of `starts` (full parameter vectors) and running
/// the simplex from the best, with at most `max_evals` evaluations in all.
pub fn fit(
    candidate: Effect,
    base: &Model,
    trials: &[TrialData],
    settings: &SimSettings,
    noise: &Noise,
    starts: &[Vec<f64>],
    max_evals: usize,
) -> Fit {
    fit_where(candidate, base, trials, settings, noise, starts, max_evals, &|_| true)
}

/// [`fit`] over the models `admissible` accepts (the others score as unsimulable).
#[allow(clippy::too_many_arguments)]
pub fn fit_where(
    candidate: Effect,
    base: &Model,
    trials: &[TrialData],
    settings: &SimSettings,
    noise: &Noise,
    starts: &[Vec<f64>],
    max_evals: usize,
    admissible: &(dyn Fn(&Model) -> bool + Sync),
) -> Fit {
    let params = candidate.params();
    let mut evals = 0;
    let mut eval = |v: &[f64]| -> f64 {
        evals += 1;
        let m = candidate.apply(base, &clamp(&params, v));
        if !admissible(&m) {
            return FAILED;
        }
        loss(trials, &m, settings, noise).0
    };
    let mut best: Option<(Vec<f64>, f64)> = None;
    for s in starts {
        let l = eval(s);
        if best.as_ref().is_none_or(|b| l < b.1) {
            best = Some((s.clone(), l));
        }
    }
    let (x0, _) = best.expect("at least one start");
    let step: Vec<f64> = params.iter().map(|p| p.step).collect();
    let budget = max_evals.saturating_sub(starts.len()).max(params.len() + 2);
    // The simplex finds the basin, Levenberg–Marquardt on the residual vector finishes it
    // (a sum of thousands of squares is nearly quadratic near its optimum; the simplex
    // crawls there). LM gets what the simplex leaves, at least two iterations' worth.
    let lm_budget = (budget / 2).max(2 * (params.len() + 5));
    let simplex = axis_simplex(&x0, &step);
    let nm = nelder_mead(&mut eval, simplex, budget.saturating_sub(lm_budget), &SIMPLEX);
    let lm_budget = budget.saturating_sub(nm.evals).max(2 * (params.len() + 5));
    let from = (nm.x, nm.value);
    let x = polish(candidate, base, trials, settings, noise, admissible, from, lm_budget);
    evals += lm_budget;
    let values = clamp(&params, &x);
    let model = candidate.apply(base, &values);
    let (loss, n) = loss(trials, &model, settings, noise);
    Fit { candidate, values, model, base: base.clone(), loss, n, evals }
}

/// Levenberg–Marquardt ([`mesopush_ident::optim::lm`]) on the noise-weighted residual vector
/// from `from` (point and loss); returns the better of the two points.
#[allow(clippy::too_many_arguments)]
fn polish(
    candidate: Effect,
    base: &Model,
    trials: &[TrialData],
    settings: &SimSettings,
    noise: &Noise,
    admissible: &(dyn Fn(&Model) -> bool + Sync),
    from: (Vec<f64>, f64),
    budget: usize,
) -> Vec<f64> {
    let params = candidate.params();
    let res = |v: &[f64]| -> Option<Vec<f64>> {
        let m = candidate.apply(base, &clamp(&params, v));
        if !admissible(&m) {
            return None;
        }
        residual_vector(trials, &m, settings, noise)
    };
    // Finite-difference steps well inside each parameter's scale, above the simulator's
    // step-size graininess.
    let h: Vec<f64> = params.iter().map(|p| p.step * 0.05).collect();
    let m = levenberg_marquardt(&res, &from.0, &h, budget, &LmSettings::DEFAULT);
    if m.value < from.1 { m.x } else { from.0 }
}
