//! Attribution: identify the nominal parameters on the training trials, then fit each
//! library effect together with them, score every candidate on the held-out trials, and
//! decide honestly: `none` when the nominal residual is already at the measurement floor,
//! `effect` when one candidate lowers the held-out error significantly (and wins on BIC),
//! `unexplained` otherwise.

use super::adequacy::AllTrials;
use super::candidates::{Candidate, NOMINAL};
use super::data::TrialData;
use super::decide::{Ambiguity, decide, training_lead};
use super::fit::{Fit, fit, fit_where, loss};
use super::predict::{predict, valid_over_batch};
use super::residual::{Mse, Noise, Residual};
use super::starts::{StartContext, starts};
use crate::Error;
use mesopush_sim::{Model, SimSettings};
use rayon::prelude::*;
use serde::Serialize;

/// Knobs of a diagnosis (defaults for a real batch; tests shrink the budgets).
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Simplex evaluations for the nominal fit.
    pub nominal_evals: usize,
    /// Evaluations (start grid included) for each effect fit.
    pub effect_evals: usize,
    /// Candidates to try.
    pub candidates: Vec<Candidate>,
    /// Simulator settings.
    pub settings: SimSettings,
    /// Smallest relative drop of the held-out error that counts (0.3 = 30 %).
    pub min_gain: f64,
    /// The nominal residual counts as at the floor below this many times the floor.
    pub floor_factor: f64,
    /// Smallest BIC improvement on the training trials that counts.
    pub min_delta_bic: f64,
    /// Ambiguity: when the winner's held-out error stays above the floor band and another
    /// effect's is within this factor of it (1.15 = 15 % worse), two explanations fit the
    /// held-out trials about as well and neither explains them; the verdict is then
    /// `unexplained` (naming both in the diagnosis's `ambiguity`), never a guess between them.
    pub ambiguity_ratio: f64,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            nominal_evals: 120,
            effect_evals: 80,
            candidates: Candidate::EFFECTS.to_vec(),
            settings: SimSettings::default(),
            min_gain: 0.3,
            floor_factor: 5.0,
            min_delta_bic: 10.0,
            ambiguity_ratio: 1.15,
        }
    }
}

/// What a diagnosis concluded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// A library effect explains the residual.
    Effect,
    /// The residual is above the floor and no candidate explains it.
    Unexplained,
    /// The residual is at the measurement floor: no missing effect.
    None,
}

/// One candidate's fit and held-out score.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Score {
    /// The candidate.
    pub candidate: Candidate,
    /// Fitted parameters: name, value, 1σ (NaN when not estimated).
    pub params: Vec<(String, f64, f64)>,
    /// BIC on the training trials.
    pub bic: f64,
    /// Held-out errors.
    pub heldout: Mse,
    /// Held-out error in noise units.
    pub heldout_norm: f64,
}

/// A whole diagnosis.
#[derive(Debug, Clone)]
pub struct Diagnosis {
    /// The verdict.
    pub verdict: Verdict,
    /// The winning effect, when the verdict is `effect`.
    pub effect: Option<Candidate>,
    /// Nominal fit, then one score per candidate tried.
    pub scores: Vec<Score>,
    /// The nominal fit.
    pub nominal: Fit,
    /// The winning extended fit (the nominal one when no effect was found).
    pub best: Fit,
    /// Measurement floor.
    pub noise: Noise,
    /// The nominal model refitted on every trial: its error there in noise units, when the
    /// held-out error was above the floor band ([`super::adequacy`]).
    pub nominal_all_norm: Option<f64>,
    /// The named effect refitted on every trial: its error there in noise units, when the
    /// nominal refit on every trial reached the floor band (the effect is kept only when it
    /// lowers that error by `min_gain`).
    pub effect_all_norm: Option<f64>,
    /// The floor band, noise units: a held-out error below it is at the floor.
    pub floor_band: f64,
    /// When the verdict is `unexplained` with two effects in the running: which, and why
    /// neither was named.
    pub ambiguity: Option<Ambiguity>,
    /// When the verdict is `unexplained`: the effect that fits the training trials best
    /// (beating the nominal BIC by `min_delta_bic`), a lead for whoever looks further.
    pub training_lead: Option<Candidate>,
    /// Training and held-out trial ids.
    pub split: (Vec<String>, Vec<String>),
    /// Held-out residuals before (nominal) and after (extended model).
    pub residuals: (Vec<Residual>, Vec<Residual>),
    /// Held-out trials.
    pub heldout: Vec<TrialData>,
}

/// The starting model for a batch's part: the default model for the paper's peg, else a
/// symmetric support inside the part.
pub fn base_model(part: &mesopush_sim::Part) -> Model {
    let default = Model::default();
    if *part == default.part {
        return default;
    }
    let (lo, hi) = part.polygon().bounds();
    let support = mesopush_sim::SupportDistribution::symmetric(
        0.25 * (hi.x - lo.x) / 2.0,
        0.5 * (hi.y - lo.y) / 2.0,
        0.3,
    );
    Model { part: part.clone(), support, ..default }
}

/// Held-out residuals of `model`; a trial it cannot simulate is an error naming it.
pub fn residuals(
    trials: &[TrialData],
    model: &Model,
    s: &SimSettings,
) -> Result<Vec<Residual>, Error> {
    trials
        .iter()
        .map(|t| {
            let p = predict(t, model, s).map_err(|e| {
                Error::invalid("diagnose", format!("trial {} cannot be simulated: {e}", t.id))
            })?;
            Ok(Residual::new(t, &p))
        })
        .collect()
}

/// The nominal fit, improved where a candidate's fit found better *nominal* parameters: each
/// candidate's nominal part is tried with its effect off, and the simplex restarted from the
/// best. Without this an effect could win only because its longer search found a better
/// μ or support — credit the optimiser earned, not the effect.
fn rescue_nominal(
    nominal: Fit,
    fits: &[Fit],
    base: &Model,
    train: &[TrialData],
    s: &SimSettings,
    noise: &Noise,
    evals: usize,
) -> Fit {
    let k = NOMINAL.len();
    let best = fits
        .iter()
        .map(|f| {
            let v = f.values[..k].to_vec();
            let l = loss(train, &Candidate::Nominal.apply(base, &v), s, noise).0;
            (v, l)
        })
        .min_by(|a, b| a.1.total_cmp(&b.1));
    match best {
        Some((v, l)) if l < nominal.loss => {
            let refit = fit(Candidate::Nominal, base, train, s, noise, &[v], evals / 2);
            if refit.loss < nominal.loss { refit } else { nominal }
        }
        _ => nominal,
    }
}

fn ids(trials: &[TrialData]) -> Vec<String> {
    trials.iter().map(|t| t.id.clone()).collect()
}

fn bic(f: &Fit) -> f64 {
    let n = f.n as f64;
    n * (f.loss / n).max(1e-300).ln() + f.values.len() as f64 * n.ln()
}

/// Runs the whole diagnosis on `train` and `heldout` trials.
pub fn diagnose(
    train: &[TrialData],
    heldout: &[TrialData],
    opts: &Options,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Diagnosis, Error> {
    if train.is_empty() || heldout.is_empty() {
        return Err(Error::invalid(
            "diagnose",
            "needs at least one training and one held-out trial",
        ));
    }
    let base = base_model(&train[0].part);
    let all: Vec<TrialData> = train.iter().chain(heldout).cloned().collect();
    let noise = Noise::estimate(&all);
    let with_tip = all.iter().any(TrialData::has_tips);
    let last_index = all.iter().map(|t| t.index).max().unwrap_or(0);
    let s = &opts.settings;
    progress("nominal");
    let x0 = vec![base.mu_probe, base.support.mu_surface[0], 0.0, 0.0];
    let nominal = fit(Candidate::Nominal, &base, train, s, &noise, &[x0], opts.nominal_evals);
    let fits: Vec<Fit> = opts
        .candidates
        .par_iter()
        .map(|&c| {
            progress(c.name());
            let ctx = StartContext {
                base: &base,
                settings: s,
                noise: &noise,
                evals_per_trial: opts.effect_evals / 3,
            };
            let st = starts(c, &nominal.values, train, &ctx);
            let budget = opts.effect_evals.max(st.len() + 4);
            let ok = |m: &Model| valid_over_batch(m, last_index);
            fit_where(c, &base, train, s, &noise, &st, budget, &ok)
        })
        .collect();
    let nominal = rescue_nominal(nominal, &fits, &base, train, s, &noise, opts.nominal_evals);
    let before = residuals(heldout, &nominal.model, s)?;
    let e0 = Mse::of(&before).normalised(&noise, with_tip);
    let mut scores = vec![score(&nominal, heldout, s, &noise, with_tip)];
    for f in &fits {
        scores.push(score(f, heldout, s, &noise, with_tip));
    }
    let band = opts.floor_factor * (2.0 + if with_tip { 1.0 } else { 0.0 });
    let (verdict, best, ambiguity) = decide(&scores, &fits, e0, band / opts.floor_factor, opts);
    let batch = AllTrials { all: &all, base: &base, settings: s, noise: &noise, with_tip };
    let adequacy = batch.judge(&nominal, best, e0, band, opts)?;
    let (verdict, best, ambiguity) =
        if adequacy.overrules { (Verdict::None, None, None) } else { (verdict, best, ambiguity) };
    let lead = training_lead(&scores, opts).filter(|_| verdict == Verdict::Unexplained);
    let best = best.cloned().unwrap_or_else(|| nominal.clone());
    let after = residuals(heldout, &best.model, s)?;
    attach_uncertainty(&best, &base, &mut scores, train, s, &noise);
    Ok(Diagnosis {
        verdict,
        effect: (verdict == Verdict::Effect).then_some(best.candidate),
        scores,
        nominal,
        best,
        noise,
        nominal_all_norm: adequacy.nominal_norm,
        effect_all_norm: adequacy.effect_norm,
        floor_band: band,
        ambiguity,
        training_lead: lead,
        split: (ids(train), ids(heldout)),
        residuals: (before, after),
        heldout: heldout.to_vec(),
    })
}

fn score(f: &Fit, heldout: &[TrialData], s: &SimSettings, noise: &Noise, tip: bool) -> Score {
    let heldout_mse = match residuals(heldout, &f.model, s) {
        Ok(r) => Mse::of(&r),
        Err(_) => Mse { xy_um2: f64::INFINITY, theta_rad2: f64::INFINITY, tip_um2: f64::INFINITY },
    };
    let names = f.candidate.params();
    Score {
        candidate: f.candidate,
        params: names
            .iter()
            .zip(&f.values)
            .map(|(p, v)| (p.name.to_string(), *v, f64::NAN))
            .collect(),
        bic: bic(f),
        heldout: heldout_mse,
        heldout_norm: heldout_mse.normalised(noise, tip),
    }
}

/// 1σ of each effect parameter of the winner from the loss's curvature along it (the loss
/// is a χ², scaled by the reduced χ² so a misfit widens the interval).
fn attach_uncertainty(
    best: &Fit,
    base: &Model,
    scores: &mut [Score],
    train: &[TrialData],
    s: &SimSettings,
    noise: &Noise,
) {
    let params = best.candidate.params();
    let red = (best.loss / best.n as f64).max(1.0);
    let Some(sc) = scores.iter_mut().find(|sc| sc.candidate == best.candidate) else { return };
    for i in NOMINAL.len()..params.len() {
        let h = params[i].step * 0.5;
        let at = |d: f64| {
            let mut v = best.values.clone();
            v[i] += d;
            loss(train, &best.candidate.apply(base, &v), s, noise).0
        };
        let (lm, lp) = (at(-h), at(h));
        let curv = (lp - 2.0 * best.loss + lm) / (h * h);
        sc.params[i].2 = if curv > 0.0 { (2.0 * red / curv).sqrt() } else { f64::INFINITY };
    }
}
