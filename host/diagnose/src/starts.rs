//! Where each candidate's search starts. A simplex only finds what its start can see, so the
//! starts come from the physics of each effect's signature:
//! - a friction patch shows only where the peg's supports straddle the patch's edge (a
//!   uniform change of the surface friction scales every support force alike and moves
//!   nothing): its edge is scanned where the supports travelled (`diagnose::patch`);
//! - a support drift is a trend of the support over the trials' places in the batch: the
//!   support shift fitted to each training trial alone, regressed on its index, gives the
//!   drift's first guess (the trend the residual shows by trial); the grid starts are
//!   measured about the training trials' mean index (the nominal fit saw the average
//!   support), so they shift the support back by the drift times that mean index;
//! - every other effect starts from the nominal optimum with each combination of its grid.

use super::candidates::Candidate;
use super::data::TrialData;
use super::fit::{loss, refit_nominal};
use super::residual::Noise;
use mesopush_sim::{Model, SimSettings};

/// What the signature-based starts need to fit the nominal model to one trial.
#[derive(Debug, Clone, Copy)]
pub struct StartContext<'a> {
    /// The base model the candidates apply their parameters to.
    pub base: &'a Model,
    /// Simulator settings.
    pub settings: &'a SimSettings,
    /// The measurement floor.
    pub noise: &'a Noise,
    /// Evaluations for each per-trial nominal fit.
    pub evals_per_trial: usize,
}

/// Start vectors (full parameter vectors) of `c` from the nominal optimum `nominal`.
pub fn starts(
    c: Candidate,
    nominal: &[f64],
    train: &[TrialData],
    ctx: &StartContext<'_>,
) -> Vec<Vec<f64>> {
    let mut out = signature_starts(c, nominal, train, ctx);
    // The effect off (its parameters at zero; a patch as wide as the plate with the nominal
    // friction): the extended model nests the nominal one, so its fit is never worse.
    out.push(off(c, nominal));
    out
}

/// The full parameter vector of `c` with its effect off at the nominal optimum.
fn off(c: Candidate, nominal: &[f64]) -> Vec<f64> {
    let mut v: Vec<f64> = nominal.to_vec();
    if c == Candidate::FrictionPatch {
        let p = c.effect_params();
        v.extend([nominal[1], p[1].lo, p[2].lo, p[3].hi, p[4].hi]);
    } else {
        v.extend(c.effect_params().iter().map(|_| 0.0));
    }
    v
}

fn signature_starts(
    c: Candidate,
    nominal: &[f64],
    train: &[TrialData],
    ctx: &StartContext<'_>,
) -> Vec<Vec<f64>> {
    match c {
        Candidate::FrictionPatch => super::patch::patch_starts(nominal, train, ctx),
        Candidate::SpeedFriction => profile_starts(c, grid_starts(c, nominal), train, ctx),
        Candidate::SupportDrift => {
            let mut s = drift_starts(nominal, train);
            s.extend(drift_trend_start(nominal, train, ctx));
            profile_starts(c, s, train, ctx)
        }
        Candidate::Adhesion => {
            // The nominal fit absorbs an adhesive drag with surface friction (it ends at its
            // bound); start the adhesion grid from the prior surface friction too.
            let mut prior = nominal.to_vec();
            prior[1] = ctx.base.support.mu_surface[0];
            let mut s = grid_starts(c, nominal);
            s.extend(grid_starts(c, &prior));
            s
        }
        _ => grid_starts(c, nominal),
    }
}

/// The drift read off the residual's trend by trial: each training trial's own nominal fit
/// (from the batch's), its support shift regressed on the trial's index. `None` with fewer
/// than two distinct indices.
fn drift_trend_start(
    nominal: &[f64],
    train: &[TrialData],
    ctx: &StartContext<'_>,
) -> Option<Vec<f64>> {
    let per: Vec<(f64, [f64; 2])> = train
        .iter()
        .map(|t| {
            let v = trial_support(nominal, std::slice::from_ref(t), ctx);
            (t.index as f64, [v[2], v[3]])
        })
        .collect();
    let n = per.len() as f64;
    let k_mean = per.iter().map(|p| p.0).sum::<f64>() / n;
    let skk: f64 = per.iter().map(|p| (p.0 - k_mean).powi(2)).sum();
    if per.len() < 2 || skk <= 0.0 {
        return None;
    }
    let mut v = nominal.to_vec();
    for a in 0..2 {
        let mean = per.iter().map(|p| p.1[a]).sum::<f64>() / n;
        let slope = per.iter().map(|p| (p.0 - k_mean) * (p.1[a] - mean)).sum::<f64>() / skk;
        v[2 + a] = mean - slope * k_mean;
        v.push(slope);
    }
    Some(v)
}

/// Support offsets (µm) one trial's own support search tries before refining: a drift of
/// 10–25 µm per trial puts a trial's support up to ~100 µm from the batch's average, far
/// outside the few-µm basin a local search sees (the support's place is the most sensitive
/// parameter of the model).
const SUPPORT_SCAN_UM: [[f64; 2]; 11] = [
    [0.0, 0.0],
    [40.0, 0.0],
    [-40.0, 0.0],
    [80.0, 0.0],
    [-80.0, 0.0],
    [120.0, 0.0],
    [-120.0, 0.0],
    [0.0, 40.0],
    [0.0, -40.0],
    [0.0, 80.0],
    [0.0, -80.0],
];

/// The nominal parameters fitted to `trials` alone: the support offsets of
/// [`SUPPORT_SCAN_UM`] about `nominal`'s, then Levenberg–Marquardt from the best.
fn trial_support(nominal: &[f64], trials: &[TrialData], ctx: &StartContext<'_>) -> Vec<f64> {
    let c = Candidate::Nominal;
    let best = SUPPORT_SCAN_UM
        .iter()
        .map(|[dx, dy]| {
            let mut v = nominal[..4].to_vec();
            v[2] += dx;
            v[3] += dy;
            let l = loss(trials, &c.apply(ctx.base, &v), ctx.settings, ctx.noise).0;
            (v, l)
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|p| p.0)
        .unwrap_or_else(|| nominal[..4].to_vec());
    refit_nominal(c, ctx.base, trials, ctx.settings, ctx.noise, &best, ctx.evals_per_trial).0
}

/// Profile starts: `out` and, for each of its starts, the nominal parameters refitted with
/// the effect held there — the nominal optimum has absorbed what
/// it could of the effect, and the effect at that optimum can look worse than none.
fn profile_starts(
    c: Candidate,
    mut out: Vec<Vec<f64>>,
    train: &[TrialData],
    ctx: &StartContext<'_>,
) -> Vec<Vec<f64>> {
    let profiled: Vec<Vec<f64>> = out
        .iter()
        .map(|v| {
            refit_nominal(c, ctx.base, train, ctx.settings, ctx.noise, v, ctx.evals_per_trial).0
        })
        .collect();
    out.extend(profiled);
    out
}

fn grid_starts(c: Candidate, nominal: &[f64]) -> Vec<Vec<f64>> {
    let mut out = vec![nominal.to_vec()];
    for p in c.effect_params() {
        let grid = if p.grid.is_empty() { &[0.0][..] } else { p.grid };
        out = out
            .iter()
            .flat_map(|v| grid.iter().map(move |g| [v.as_slice(), &[*g]].concat()))
            .collect();
    }
    out
}

/// Support-drift starts: drifts along each axis, the nominal shift moved back so that the
/// training trials' mean index keeps the support the nominal fit found.
fn drift_starts(nominal: &[f64], train: &[TrialData]) -> Vec<Vec<f64>> {
    let k_mean = train.iter().map(|t| t.index as f64).sum::<f64>() / train.len().max(1) as f64;
    // A star along each body axis, near and far (a drift usually has one direction).
    let mut drifts = vec![[0.0, 0.0]];
    for m in [8.0, 20.0] {
        drifts.extend([[m, 0.0], [-m, 0.0], [0.0, m], [0.0, -m]]);
    }
    drifts
        .into_iter()
        .map(|[gx, gy]| {
            let mut v = nominal.to_vec();
            v[2] -= k_mean * gx;
            v[3] -= k_mean * gy;
            v.extend([gx, gy]);
            v
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_starts_are_every_combination() {
        let nominal = [0.8, 0.3, 0.0, 0.0];
        let s = grid_starts(Candidate::Backlash, &nominal);
        assert_eq!(s.len(), 9);
        assert!(s.iter().all(|v| v.len() == 6 && v[..4] == nominal));
    }
}
