//! Attribution: identify the nominal parameters on the training trials, then fit each
//! library effect together with them, score every candidate on the held-out trials, and
//! decide honestly: `none` when the nominal residual is already at the measurement floor,
//! `effect` when one candidate lowers the held-out error significantly (and wins on BIC),
//! `unexplained` otherwise.

use super::adequacy::AllTrials;
use super::candidates::{Effect, NOMINAL, base_model};
use super::data::TrialData;
use super::decide::{Ambiguity, EffectScore, Verdict, decide, training_lead};
use super::fit::{Fit, fit, fit_where};
use super::objective::{loss, residuals};
use super::options::Options;
use super::predict::valid_over_batch;
use super::residual::{Mse, Noise, Residual};
use super::starts::{StartContext, starts};
use crate::Error;
use mesopush_sim::{Model, SimSettings};
use rayon::prelude::*;

/// A whole diagnosis.
#[derive(Debug, Clone)]
pub struct Diagnosis {
    /// The verdict.
    pub verdict: Verdict,
    /// The winning effect, when the verdict is `effect`.
    pub effect: Option<Effect>,
    /// Nominal fit, then one score per candidate tried.
    pub scores: Vec<EffectScore>,
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
    pub training_lead: Option<Effect>,
    /// Training and held-out trial ids.
    pub split: (Vec<String>, Vec<String>),
    /// Held-out residuals before (nominal) and after (extended model).
    pub residuals: (Vec<Residual>, Vec<Residual>),
    /// Held-out trials.
    pub heldout: Vec<TrialData>,
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
            let l = loss(train, &Effect::Nominal.apply(base, &v), s, noise).0;
            (v, l)
        })
        .min_by(|a, b| a.1.total_cmp(&b.1));
    match best {
        Some((v, l)) if l < nominal.loss => {
            let refit = fit(Effect::Nominal, base, train, s, noise, &[v], evals / 2);
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

/// Every candidate of `opts` fitted on `train` from its signature's starts about the
/// `nominal` fit (in parallel, collected in the candidates' order).
fn fit_effects(
    base: &Model,
    nominal: &Fit,
    train: &[TrialData],
    noise: &Noise,
    last_index: usize,
    opts: &Options,
    progress: &(dyn Fn(&str) + Sync),
) -> Vec<Fit> {
    let s = &opts.settings;
    opts.candidates
        .par_iter()
        .map(|&c| {
            progress(c.name());
            let ctx =
                StartContext { base, settings: s, noise, evals_per_trial: opts.effect_evals / 3 };
            let st = starts(c, &nominal.values, train, &ctx);
            let budget = opts.effect_evals.max(st.len() + 4);
            let ok = |m: &Model| valid_over_batch(m, last_index);
            fit_where(c, base, train, s, noise, &st, budget, &ok)
        })
        .collect()
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
    let nominal = fit(Effect::Nominal, &base, train, s, &noise, &[x0], opts.nominal_evals);
    let fits = fit_effects(&base, &nominal, train, &noise, last_index, opts, progress);
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

fn score(f: &Fit, heldout: &[TrialData], s: &SimSettings, noise: &Noise, tip: bool) -> EffectScore {
    let heldout_mse = match residuals(heldout, &f.model, s) {
        Ok(r) => Mse::of(&r),
        Err(_) => Mse { xy_um2: f64::INFINITY, theta_rad2: f64::INFINITY, tip_um2: f64::INFINITY },
    };
    let names = f.candidate.params();
    EffectScore {
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
    scores: &mut [EffectScore],
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
