//! Model adequacy: is *any* nominal model good enough for the whole batch? A few training
//! trials may not pin the nominal parameters (two pushes of a standing peg leave the support's
//! place loose by tens of µm), so a nominal fit on the training split can miss the held-out
//! trials by far more than the measurement floor with nothing missing from the model — the
//! held-out gap is then the parameters' uncertainty, not an effect. A missing effect (lost
//! motion at reversals, a lag, a scale, a pull-off) cannot be fitted away by μ and the
//! support; so the nominal model is refitted on every trial, from the training fit, and when
//! it reaches the floor band on all of them the verdict is `none`.

use super::candidates::Candidate;
use super::data::TrialData;
use super::fit::{Fit, fit};
use super::residual::{Mse, Noise};
use crate::Error;
use crate::sim::{Model, SimSettings};

/// The nominal model refitted on every trial, and its error there in noise units.
#[derive(Debug, Clone)]
pub struct Adequacy {
    /// The nominal fit on every trial.
    pub fit: Fit,
    /// Its error over every trial, in noise units (the held-out error's measure).
    pub error_norm: f64,
}

/// Refits the nominal model on `all` trials from the training fit's parameters with `evals`
/// simplex evaluations, and scores it on them.
pub fn refit_on_all(
    all: &[TrialData],
    base: &Model,
    nominal: &Fit,
    settings: &SimSettings,
    noise: &Noise,
    evals: usize,
    with_tip: bool,
) -> Result<Adequacy, Error> {
    let start = [nominal.values.clone()];
    let f = fit(Candidate::Nominal, base, all, settings, noise, &start, evals);
    let r = super::attribute::residuals(all, &f.model, settings)?;
    let error_norm = Mse::of(&r).normalised(noise, with_tip);
    Ok(Adequacy { fit: f, error_norm })
}
