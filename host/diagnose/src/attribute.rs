//! Attribution: identify the nominal parameters on the training trials, then fit each
//! library effect together with them, score every candidate on the held-out trials, and
//! decide honestly: `none` when the nominal residual is already at the measurement floor,
//! `effect` when one candidate lowers the held-out error significantly (and wins on BIC),
//! `unexplained` otherwise.

use super::adequacy::AllTrials;
use super::candidates::{Effect, NOMINAL, base_model, mean_mu_surface, nominal_values};
use super::data::TrialData;
use super::decide::{Ambiguity, EffectScore, Verdict, decide, tip_winner, training_lead};
use super::effect_refit::refit_named;
use super::fit::{Fit, fit, fit_where};
use super::free_support::{refit_with_free_support, training_lead_index};
use super::free_tip::{FreeTip, fit_free_tip};
use super::nominal::{Held, SupportFit, nominal_base};
use super::objective::{loss, residual_vector, residuals};
use super::options::Options;
use super::polish::NearFloor;
use super::predict::valid_over_batch;
use super::replay::{ReplayOptions, settings_for};
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
    /// The nominal support fit: which family was kept, and each family's held-out error.
    pub support_fit: SupportFit,
    /// Whether the imaged probe tip alone named the effect ([`crate::decide`]: an effect
    /// between the command and the image, while the part's poses stay above the floor; or
    /// [`crate::free_tip`]: the free tip's kinematic fits).
    pub named_by_tip: bool,
    /// The stage and camera effects fitted on the free imaged tip alone, when the trials
    /// image it ([`crate::free_tip`]).
    pub free_tip: Option<FreeTip>,
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
            let l = loss(train, &Effect::Nominal.apply(&f.base, &v), s, noise).0;
            (v, l, &f.base)
        })
        .min_by(|a, b| a.1.total_cmp(&b.1));
    match best {
        Some((v, l, base)) if l < nominal.loss => {
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
#[allow(clippy::too_many_arguments)]
fn fit_effects(
    nominal: &Fit,
    prior_mu: [f64; 2],
    train: &[TrialData],
    noise: &Noise,
    last_index: usize,
    (s, opts): (&SimSettings, &Options),
    progress: &(dyn Fn(&str) + Sync),
) -> Vec<Fit> {
    opts.candidates
        .par_iter()
        .map(|&c| {
            progress(c.name());
            let ctx = StartContext {
                base: &nominal.base,
                settings: s,
                noise,
                evals_per_trial: opts.effect_evals / 3,
                prior_mu,
            };
            let st = starts(c, &nominal.values, train, &ctx);
            let budget = opts.effect_evals.max(st.len() + 4);
            let ok = |m: &Model| valid_over_batch(m, last_index);
            fit_where(c, &nominal.base, train, s, noise, &st, budget, &ok)
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
    let prior = prior_model(&train[0], opts)?;
    let prior_mu = [prior.mu_probe, mean_mu_surface(&prior.support)];
    let all: Vec<TrialData> = train.iter().chain(heldout).cloned().collect();
    let noise = Noise::estimate(&all);
    let with_tip = all.iter().any(TrialData::has_tips);
    let last_index = all.iter().map(|t| t.index).max().unwrap_or(0);
    // The settings' lengths are the paper's peg's: another part gets them scaled to its size,
    // and the trials' own registration tolerance.
    let replay = ReplayOptions { base: opts.settings.clone(), registration_tol: None };
    let coarse = settings_for(&replay, &train[0]);
    let band = opts.floor_factor * (2.0 + if with_tip { 1.0 } else { 0.0 });
    // The stage and camera effects on the free imaged tip alone: no replay of the part.
    let free_tip = if with_tip {
        fit_free_tip(&opts.candidates, &prior, &nominal_values(&prior), train, heldout, &noise)
    } else {
        None
    };
    let free = free_tip.as_ref();
    progress("nominal support");
    let held = Held { trials: heldout, settings: &coarse, noise: &noise, with_tip };
    let (nominal, shifted, support_fit, fit_train) = nominal_base(&prior, train, &held, band, opts);
    let at_floor = support_fit.kept_heldout_norm() <= band;
    let near = NearFloor { prior: &prior, train, held: &held, band, opts };
    let (nominal, support_fit, fit_train, settings) =
        near.refit(nominal, support_fit, fit_train, progress);
    let s = &settings;
    // The effects are fitted (and the nominal rescued, the uncertainties taken) on the
    // training trials with their start-pose sensitivity at the nominal fit.
    let train = &fit_train[..];
    // Each effect is fitted about the nominal fit; an effect on the supports' friction is
    // also fitted about the shifted prior when a free support was kept: the free points may
    // have bent to absorb the very effect (a friction patch), which the effect can then not
    // undo by a shift ([`Effect::acts_on_supports`]).
    // A nominal model already at the floor on the held-out trials leaves nothing for an
    // effect to explain (the verdict is `none` whatever they would fit): none is fitted.
    // When the free tip names a stage or camera effect, the supports' effects are fitted
    // about the nominal fit only (their scores are reported, but
    // the free tip's refit decides, below): the second pass cost a fifth of the replays of
    // seed-1 scale-01.
    let tip_names = free.and_then(|f| f.winner(opts.floor_factor, opts.min_gain)).is_some();
    let mut fits = if at_floor {
        Vec::new()
    } else {
        fit_effects(&nominal, prior_mu, train, &noise, last_index, (s, opts), progress)
    };
    if !at_floor && !tip_names && support_fit.family != "shifted" {
        let on_supports: Vec<Effect> =
            opts.candidates.iter().copied().filter(|c| c.acts_on_supports()).collect();
        let opts_s = Options { candidates: on_supports, ..opts.clone() };
        let other =
            fit_effects(&shifted, prior_mu, train, &noise, last_index, (s, &opts_s), progress);
        for g in other {
            if let Some(f) = fits.iter_mut().find(|f| f.candidate == g.candidate)
                && g.loss < f.loss
            {
                *f = g;
            }
        }
    }
    let lead = training_lead_index(&fits, &bic, bic(&nominal), opts.min_delta_bic);
    if let Some(i) = lead.filter(|_| opts.refit_lead_support) {
        progress("training lead, support points free");
        let ok = |m: &Model| valid_over_batch(m, last_index);
        fits[i] = refit_with_free_support(&fits[i], train, s, &noise, &ok, opts.effect_evals);
    }
    let nominal = rescue_nominal(nominal, &fits, train, s, &noise, opts.nominal_evals);
    let before = residuals(heldout, &nominal.model, s)?;
    let e0 = Mse::of(&before).normalised(&noise, with_tip);
    let mut scores = vec![score(&nominal, heldout, s, &noise, with_tip)];
    for f in &fits {
        scores.push(score(f, heldout, s, &noise, with_tip));
    }
    let joint_tip = tip_winner(&scores, &fits, opts).map(|f| f.candidate);
    // Named by the free tip: its fit is the nominal fit run again with the effect held where
    // the free tip puts it (first: the free tip's evidence needs no part model at all).
    let free_named = if e0 > band { refit_named(free, &near, progress) } else { None };
    // A refit that cannot replay every trial (a pusher starting inside the rescaled part:
    // fresh seed-16 scale-00) is not an explanation: the verdict is then left to the rules.
    let replays =
        |w: &Fit| all.iter().all(|t| residuals(std::slice::from_ref(t), &w.model, s).is_ok());
    let free_named = free_named.filter(replays).and_then(|w| {
        let i = fits.iter().position(|f| f.candidate == w.candidate)?;
        scores[i + 1] = score(&w, heldout, s, &noise, with_tip);
        fits[i] = w;
        Some(fits[i].candidate)
    });
    let (verdict, best, ambiguity) = match free_named {
        Some(c) => (Verdict::Effect, fits.iter().find(|f| f.candidate == c), None),
        None => decide(&scores, &fits, e0, band / opts.floor_factor, opts),
    };
    let batch = AllTrials { all: &all, settings: s, noise: &noise, with_tip };
    let nominals: Vec<&Fit> =
        if support_fit.family == "shifted" { vec![&nominal] } else { vec![&nominal, &shifted] };
    let adequacy = batch.judge(&nominals, best, e0, band, opts)?;
    let (verdict, best, ambiguity) =
        if adequacy.overrules { (Verdict::None, None, None) } else { (verdict, best, ambiguity) };
    let lead = training_lead(&scores, opts).filter(|_| verdict == Verdict::Unexplained);
    let named_by_tip = verdict == Verdict::Effect
        && (free_named.is_some()
            || joint_tip.is_some_and(|c| Some(c) == best.map(|b| b.candidate)));
    let best = best.cloned().unwrap_or_else(|| nominal.clone());
    let after = residuals(heldout, &best.model, s)?;
    let every: Vec<&Fit> = std::iter::once(&nominal).chain(&fits).collect();
    attach_uncertainty(&every, &mut scores, train, s, &noise);
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
        support_fit,
        named_by_tip,
        free_tip,
        split: (ids(train), ids(heldout)),
        residuals: (before, after),
        heldout: heldout.to_vec(),
    })
}

/// The model the nominal fit starts from: `--model`'s (its part must be the trials'), else
/// the part's default.
fn prior_model(first: &TrialData, opts: &Options) -> Result<Model, Error> {
    let Some(m) = &opts.start_model else { return Ok(base_model(&first.part)) };
    if m.part != first.part {
        return Err(Error::invalid(
            "--model",
            format!(
                "the model's part ({} vertices, size {:.0} µm) is not the part of trial {} \
                 ({} vertices, size {:.0} µm); identify the model on trials of this part",
                m.part.polygon().vertices().len(),
                m.part.char_length_um(),
                first.id,
                first.part.polygon().vertices().len(),
                first.part.char_length_um()
            ),
        ));
    }
    m.validate().map_err(|e| Error::invalid("--model", format!("the model is not valid: {e}")))?;
    Ok(Model { effects: Default::default(), ..m.clone() })
}

fn score(f: &Fit, heldout: &[TrialData], s: &SimSettings, noise: &Noise, tip: bool) -> EffectScore {
    let inf = Mse { xy_um2: f64::INFINITY, theta_rad2: f64::INFINITY, tip_um2: f64::INFINITY };
    let (heldout_mse, per_trial) = match residuals(heldout, &f.model, s) {
        Ok(r) => (Mse::of(&r), r.iter().map(|t| Mse::of(std::slice::from_ref(t))).collect()),
        Err(_) => (inf, vec![inf; heldout.len()]),
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
        heldout_per_trial_norm: per_trial.iter().map(|m: &Mse| m.normalised(noise, tip)).collect(),
        heldout_tip_norm: if tip {
            heldout_mse.tip_um2 / (2.0 * noise.tip_um.powi(2))
        } else {
            f64::NAN
        },
    }
}

/// 1σ of every parameter of every fit: the marginal standard deviations of the
/// Gauss–Newton covariance (JᵀJ)⁻¹ at the fit (J the forward-difference Jacobian of the
/// noise-weighted residual vector, so the loss is a χ²), scaled by the reduced χ² so a misfit
/// widens them. Correlated parameters widen each other; a direction the trials do not
/// determine makes JᵀJ singular and its σ infinite (reported as undetermined).
fn attach_uncertainty(
    fits: &[&Fit],
    scores: &mut [EffectScore],
    train: &[TrialData],
    s: &SimSettings,
    noise: &Noise,
) {
    let sigmas: Vec<Vec<f64>> = fits.par_iter().map(|f| sigmas(f, train, s, noise)).collect();
    for (f, sig) in fits.iter().zip(sigmas) {
        if let Some(sc) = scores.iter_mut().find(|sc| sc.candidate == f.candidate) {
            for (p, e) in sc.params.iter_mut().zip(sig) {
                p.2 = e;
            }
        }
    }
}

fn sigmas(f: &Fit, train: &[TrialData], s: &SimSettings, noise: &Noise) -> Vec<f64> {
    let params = f.candidate.params();
    let n = params.len();
    let res = |v: &[f64]| residual_vector(train, &f.candidate.apply(&f.base, v), s, noise);
    let Some(r0) = res(&f.values) else { return vec![f64::INFINITY; n] };
    let cols: Vec<Option<Vec<f64>>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let h = params[i].step * 0.05;
            let mut v = f.values.clone();
            v[i] += h;
            let r = res(&v)?;
            (r.len() == r0.len()).then(|| r.iter().zip(&r0).map(|(a, b)| (a - b) / h).collect())
        })
        .collect();
    let Some(j) = cols.into_iter().collect::<Option<Vec<Vec<f64>>>>() else {
        return vec![f64::INFINITY; n];
    };
    // A parameter the fit left at a bound (a patch edge at the plate's edge) has no effect
    // nearby: it is undetermined and left out of the others' covariance.
    let live: Vec<usize> = (0..n).filter(|&i| j[i].iter().any(|v| *v != 0.0)).collect();
    let m = live.len();
    let jtj: Vec<Vec<f64>> = live
        .iter()
        .map(|&a| live.iter().map(|&b| j[a].iter().zip(&j[b]).map(|(x, y)| x * y).sum()).collect())
        .collect();
    let red = (f.loss / f.n as f64).max(1.0);
    let mut out = vec![f64::INFINITY; n];
    for (k, &i) in live.iter().enumerate() {
        let e: Vec<f64> = (0..m).map(|q| if q == k { 1.0 } else { 0.0 }).collect();
        if let Some(x) = mesopush_ident::optim::lm::solve(jtj.clone(), e)
            && x[k] > 0.0
            && x[k].is_finite()
        {
            out[i] = (x[k] * red).sqrt();
        }
    }
    out
}
