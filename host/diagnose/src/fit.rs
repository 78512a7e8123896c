//! A compact fitter: weighted least squares of the measured-minus-predicted residual over a
//! set of trials, minimised over a candidate's parameter vector by trying its start grid
//! and then a bounded Nelder–Mead simplex. Generic over the parameter vector; deterministic
//! (no randomness, a fixed evaluation budget).

use super::candidates::{Candidate, Param};
use super::data::TrialData;
use super::predict::predict;
use super::residual::{Noise, Residual};
use mesopush_sim::{Model, SimSettings};

/// Loss of a parameter set that cannot be simulated (kept finite so the simplex moves away).
const FAILED: f64 = 1e12;

/// The weighted sum of squared residuals of `model` over `trials` (each channel divided by
/// its noise variance) and the number of scalar residuals in it.
pub fn loss(
    trials: &[TrialData],
    model: &Model,
    settings: &SimSettings,
    noise: &Noise,
) -> (f64, usize) {
    if model.validate().is_err() {
        return (FAILED, 1);
    }
    let mut sum = 0.0;
    let mut n = 0;
    for t in trials {
        match predict(t, model, settings) {
            Ok(pred) => {
                let r = Residual::new(t, &pred);
                let (s, k) = r.weighted_sse(noise);
                sum += s;
                n += k;
            }
            Err(_) => return (FAILED, 1),
        }
    }
    (sum, n.max(1))
}

/// Every weighted residual scalar of `model` over `trials` (see
/// [`Residual::weighted_into`]); `None` when it cannot be simulated.
pub fn residual_vector(
    trials: &[TrialData],
    model: &Model,
    settings: &SimSettings,
    noise: &Noise,
) -> Option<Vec<f64>> {
    if model.validate().is_err() {
        return None;
    }
    let mut out = Vec::new();
    for t in trials {
        let pred = predict(t, model, settings).ok()?;
        Residual::new(t, &pred).weighted_into(noise, &mut out);
    }
    Some(out)
}

/// Levenberg–Marquardt on the nominal parameters only (the effect's held at its value in
/// `v`, a full parameter vector of `candidate`), at most about `budget` evaluations: where
/// the nominal parameters go once the effect is on. The nominal fit has bent them to absorb
/// the missing effect's signature (the support's place is the most sensitive), so an effect
/// tried at the nominal optimum can look worse than none although it is there.
pub fn refit_nominal(
    candidate: Candidate,
    base: &Model,
    trials: &[TrialData],
    settings: &SimSettings,
    noise: &Noise,
    v: &[f64],
    budget: usize,
) -> (Vec<f64>, f64) {
    let params = candidate.params();
    let k = super::candidates::NOMINAL.len();
    let full = |x: &[f64]| -> Vec<f64> { x.iter().chain(&v[k..]).copied().collect() };
    let res = |x: &[f64]| -> Option<Vec<f64>> {
        residual_vector(trials, &candidate.apply(base, &clamp(&params, &full(x))), settings, noise)
    };
    let h: Vec<f64> = params[..k].iter().map(|p| p.step * 0.05).collect();
    let (x, fx, _, _) = mesopush_ident::polish::levenberg_marquardt(&res, &v[..k], &h, budget);
    (clamp(&params, &full(&x)), fx)
}

/// A fitted candidate.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// Which candidate.
    pub candidate: Candidate,
    /// Fitted parameter vector (nominal ones first).
    pub values: Vec<f64>,
    /// The fitted model.
    pub model: Model,
    /// Training loss (weighted SSE).
    pub loss: f64,
    /// Scalar residuals in the training loss.
    pub n: usize,
    /// Model evaluations used.
    pub evals: usize,
}

fn clamp(params: &[Param], v: &[f64]) -> Vec<f64> {
    v.iter().zip(params).map(|(x, p)| x.clamp(p.lo, p.hi)).collect()
}

/// Bounded Nelder–Mead on `f` from `x0` with initial steps `step`, at most `max_evals`
/// evaluations. Returns the best point and value.
pub fn nelder_mead(
    f: &mut dyn FnMut(&[f64]) -> f64,
    x0: &[f64],
    step: &[f64],
    max_evals: usize,
) -> (Vec<f64>, f64, usize) {
    let d = x0.len();
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(d + 1);
    simplex.push((x0.to_vec(), f(x0)));
    for i in 0..d {
        let mut x = x0.to_vec();
        x[i] += step[i];
        let fx = f(&x);
        simplex.push((x, fx));
    }
    let mut evals = d + 1;
    while evals < max_evals {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, worst) = (simplex[0].1, simplex[d].1);
        if (worst - best).abs() <= 1e-9 * (1.0 + best.abs()) {
            break;
        }
        let centroid: Vec<f64> =
            (0..d).map(|k| simplex[..d].iter().map(|s| s.0[k]).sum::<f64>() / d as f64).collect();
        let at = |t: f64, w: &[f64]| -> Vec<f64> {
            centroid.iter().zip(w).map(|(c, x)| c + t * (x - c)).collect()
        };
        let xr = at(-1.0, &simplex[d].0);
        let fr = f(&xr);
        evals += 1;
        if fr < simplex[0].1 {
            let xe = at(-2.0, &simplex[d].0);
            let fe = f(&xe);
            evals += 1;
            simplex[d] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[d - 1].1 {
            simplex[d] = (xr, fr);
        } else {
            let xc = at(0.5, &simplex[d].0);
            let fc = f(&xc);
            evals += 1;
            if fc < simplex[d].1.min(fr) {
                simplex[d] = (xc, fc);
            } else {
                let b = simplex[0].0.clone();
                for s in simplex.iter_mut().skip(1) {
                    s.0 = b.iter().zip(&s.0).map(|(bb, x)| bb + 0.5 * (x - bb)).collect();
                    s.1 = f(&s.0);
                }
                evals += d;
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (x, fx) = simplex.swap_remove(0);
    (x, fx, evals)
}

/// Fits `candidate` on `trials`, trying each of `starts` (full parameter vectors) and running
/// the simplex from the best, with at most `max_evals` evaluations in all.
pub fn fit(
    candidate: Candidate,
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
    candidate: Candidate,
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
    let (xn, fxn, used) = nelder_mead(&mut eval, &x0, &step, budget.saturating_sub(lm_budget));
    let lm_budget = budget.saturating_sub(used).max(2 * (params.len() + 5));
    let x = polish(candidate, base, trials, settings, noise, admissible, (xn, fxn), lm_budget);
    evals += lm_budget;
    let values = clamp(&params, &x);
    let model = candidate.apply(base, &values);
    let (loss, n) = loss(trials, &model, settings, noise);
    Fit { candidate, values, model, loss, n, evals }
}

/// Levenberg–Marquardt ([`mesopush_ident::polish`]) on the noise-weighted residual vector from
/// `from` (point and loss); returns the better of the two points.
#[allow(clippy::too_many_arguments)]
fn polish(
    candidate: Candidate,
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
    let (x, fx, _, _) = mesopush_ident::polish::levenberg_marquardt(&res, &from.0, &h, budget);
    if fx < from.1 { x } else { from.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nelder_mead_finds_a_quadratic_minimum() {
        let mut f = |x: &[f64]| (x[0] - 3.0).powi(2) + 10.0 * (x[1] + 1.0).powi(2);
        let (x, fx, evals) = nelder_mead(&mut f, &[0.0, 0.0], &[1.0, 1.0], 400);
        assert!((x[0] - 3.0).abs() < 1e-3 && (x[1] + 1.0).abs() < 1e-3, "{x:?}");
        assert!(fx < 1e-6 && evals <= 400);
    }
}
