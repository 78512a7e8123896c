//! Model adequacy: is *any* nominal model good enough for the whole batch? A few training
//! trials may not pin the nominal parameters (two pushes of a standing peg leave the support's
//! place loose by tens of µm), so a nominal fit on the training split can miss the held-out
//! trials by far more than the measurement floor with nothing missing from the model — the
//! held-out gap is then the parameters' uncertainty, not an effect. A missing effect (lost
//! motion at reversals, a lag, a scale, a pull-off) cannot be fitted away by μ and the
//! support; so the nominal model is refitted on every trial, from the training fit, and when
//! it reaches the floor band on all of them the verdict is `none` — unless the effect the
//! held-out trials named, refitted on every trial too, still lowers that all-trial error by
//! the same margin a held-out win needs (a small support drift: the nominal model alone fits
//! six trials inside the band, the drift fits them several times better).

use super::data::TrialData;
use super::fit::{Fit, fit_where};
use super::predict::valid_over_batch;
use super::residual::{Mse, Noise};
use crate::Error;
use crate::sim::{Model, SimSettings};

/// A candidate refitted on every trial, and its error there in noise units.
#[derive(Debug, Clone)]
pub struct Adequacy {
    /// The fit on every trial.
    pub fit: Fit,
    /// Its error over every trial, in noise units (the held-out error's measure).
    pub error_norm: f64,
}

/// Refits `from`'s candidate on `all` trials, starting at its parameters, with `evals`
/// simplex evaluations over the models physical for the whole batch, and scores it there.
pub fn refit_on_all(
    all: &[TrialData],
    base: &Model,
    from: &Fit,
    settings: &SimSettings,
    noise: &Noise,
    evals: usize,
    with_tip: bool,
) -> Result<Adequacy, Error> {
    let start = [from.values.clone()];
    let last = all.iter().map(|t| t.index).max().unwrap_or(0);
    let ok = |m: &Model| valid_over_batch(m, last);
    let f = fit_where(from.candidate, base, all, settings, noise, &start, evals, &ok);
    let r = super::attribute::residuals(all, &f.model, settings)?;
    let error_norm = Mse::of(&r).normalised(noise, with_tip);
    Ok(Adequacy { fit: f, error_norm })
}
