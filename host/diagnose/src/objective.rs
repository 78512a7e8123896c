//! What the fits minimise and the verdict compares: the residual of a model over a set of
//! trials, as a noise-weighted sum of squares ([`loss`]), as the vector of its weighted
//! scalars ([`residual_vector`], for Levenberg–Marquardt) and as per-trial residuals
//! ([`residuals`], for held-out errors and the report).

use super::data::TrialData;
use super::memo::{cached, model_key};
use super::predict::{Prediction, predict};
use super::residual::{Noise, Residual};
use crate::Error;
use mesopush_sim::{Model, SimSettings};
use rayon::prelude::*;
use std::sync::Arc;

/// `predict`, through the memo ([`super::memo`]): a fit evaluates many a model more than
/// once; `key` is the [`model_key`] of `model` and `settings`.
fn predicted(
    t: &TrialData,
    model: &Model,
    settings: &SimSettings,
    key: &str,
) -> Result<Arc<Prediction>, Error> {
    cached(t, key, || predict(t, model, settings))
}

/// Loss of a parameter set that cannot be simulated (kept finite so the simplex moves away).
pub const FAILED: f64 = 1e12;

/// The residual of `model` on each of `trials`, replayed in parallel and returned in
/// order (so every sum over them adds the same numbers in the same order as one by one).
fn each_residual(
    trials: &[TrialData],
    model: &Model,
    settings: &SimSettings,
) -> Vec<Result<Residual, Error>> {
    let key = model_key("predict", model, settings);
    trials
        .par_iter()
        .map(|t| predicted(t, model, settings, &key).map(|p| Residual::new(t, &p)))
        .collect()
}

/// A residual profiled over its trial's start poses and the starts' corrections (prior σ).
type Profiled = (Residual, Vec<[f64; 3]>);

/// [`each_residual`], profiled over the start poses where a trial carries its start-pose
/// sensitivity ([`crate::start_pose`]): each residual with the starts' corrections, in
/// prior σ, whose squares join the loss.
fn each_profiled(
    trials: &[TrialData],
    model: &Model,
    settings: &SimSettings,
    noise: &Noise,
) -> Vec<Result<Profiled, Error>> {
    each_residual(trials, model, settings)
        .into_iter()
        .zip(trials)
        .map(|(r, t)| {
            let mut r = r?;
            let deltas =
                t.start_sensitivity.as_ref().map_or(Vec::new(), |s| s.profile(&mut r, noise));
            Ok((r, deltas))
        })
        .collect()
}

/// The weighted sum of squared residuals of `model` over `trials` (each channel divided by
/// its noise variance) and the number of scalar residuals in it; a trial carrying its
/// start-pose sensitivity (a training trial) is profiled over its start poses, their
/// corrections' squares (in prior σ) added ([`crate::start_pose`]).
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
    for r in each_profiled(trials, model, settings, noise) {
        match r {
            Ok((r, deltas)) => {
                let (s, k) = r.weighted_sse(noise);
                sum += s + deltas.iter().flatten().map(|d| d * d).sum::<f64>();
                n += k;
            }
            Err(_) => return (FAILED, 1),
        }
    }
    (sum, n.max(1))
}

/// Every weighted residual scalar of `model` over `trials` (see
/// [`Residual::weighted_into`]; profiled as in [`loss`], the start corrections appended);
/// `None` when it cannot be simulated.
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
    for r in each_profiled(trials, model, settings, noise) {
        let (r, deltas) = r.ok()?;
        r.weighted_into(noise, &mut out);
        out.extend(deltas.iter().flatten());
    }
    Some(out)
}

/// The residuals of `model` on each of `trials`; a trial it cannot simulate is an error
/// naming it (the first such, in order).
pub fn residuals(
    trials: &[TrialData],
    model: &Model,
    s: &SimSettings,
) -> Result<Vec<Residual>, Error> {
    each_residual(trials, model, s)
        .into_iter()
        .zip(trials)
        .map(|(r, t)| {
            r.map_err(|e| {
                Error::invalid("diagnose", format!("trial {} cannot be simulated: {e}", t.id))
            })
        })
        .collect()
}
