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
use super::objective::residuals;
use super::options::Options;
use super::predict::valid_over_batch;
use super::residual::{Mse, Noise};
use crate::Error;
use mesopush_sim::{Model, SimSettings};

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
    from: &Fit,
    settings: &SimSettings,
    noise: &Noise,
    evals: usize,
    with_tip: bool,
) -> Result<Adequacy, Error> {
    let start = [from.values.clone()];
    let last = all.iter().map(|t| t.index).max().unwrap_or(0);
    let ok = |m: &Model| valid_over_batch(m, last);
    let f = fit_where(from.candidate, &from.base, all, settings, noise, &start, evals, &ok);
    let r = residuals(all, &f.model, settings)?;
    let error_norm = Mse::of(&r).normalised(noise, with_tip);
    Ok(Adequacy { fit: f, error_norm })
}

/// A whole batch, for the adequacy refits.
#[derive(Debug)]
pub struct AllTrials<'a> {
    /// Every trial, training and held-out.
    pub all: &'a [TrialData],
    /// Simulator settings.
    pub settings: &'a SimSettings,
    /// The measurement floor.
    pub noise: &'a Noise,
    /// Whether the imaged tip counts.
    pub with_tip: bool,
}

/// What the adequacy refits found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Judgement {
    /// The nominal model refitted on every trial, noise units (when the held-out error was
    /// above the band).
    pub nominal_norm: Option<f64>,
    /// The held-out winner refitted on every trial, noise units (when the nominal one was
    /// inside the band and there was a winner).
    pub effect_norm: Option<f64>,
    /// The verdict is `none` whatever the held-out trials said.
    pub overrules: bool,
}

impl AllTrials<'_> {
    /// The adequacy check of a diagnosis whose nominal training fits are `nominals` (the
    /// kept support family's first, then any simpler family's: a free support bent to two
    /// training pushes may refit worse on every trial than the shifted one does), held-out
    /// winner `winner` (if any) and nominal held-out error `e0` against the floor `band`.
    /// The nominal all-trial error is the best of their refits.
    pub fn judge(
        &self,
        nominals: &[&Fit],
        winner: Option<&Fit>,
        e0: f64,
        band: f64,
        opts: &Options,
    ) -> Result<Judgement, Error> {
        let mut j = Judgement { nominal_norm: None, effect_norm: None, overrules: false };
        if e0 <= band || nominals.is_empty() {
            return Ok(j);
        }
        let mut e_all = f64::INFINITY;
        for n in nominals {
            e_all = e_all.min(self.refit(n, opts.nominal_evals / 2)?);
        }
        j.nominal_norm = Some(e_all);
        if e_all > band {
            return Ok(j);
        }
        if let Some(f) = winner {
            j.effect_norm = Some(self.refit(f, opts.effect_evals / 2)?);
        }
        j.overrules = !j.effect_norm.is_some_and(|e| e <= (1.0 - opts.min_gain) * e_all);
        Ok(j)
    }

    fn refit(&self, from: &Fit, evals: usize) -> Result<f64, Error> {
        let a = refit_on_all(self.all, from, self.settings, self.noise, evals, self.with_tip)?;
        Ok(a.error_norm)
    }
}
