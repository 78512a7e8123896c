//! A support drift's starts: a drift is a trend of the support over the trials' places in
//! the batch. The support shift fitted to each training trial alone, regressed on its index,
//! gives the drift's first guess (the trend the residual shows by trial); the grid starts are
//! measured about the training trials' mean index (the nominal fit saw the average support),
//! so they shift the support back by the drift times that mean index.

use super::context::StartContext;
use crate::candidates::Effect;
use crate::data::TrialData;
use crate::fit::refit_nominal;
use crate::objective::loss;

/// The drift read off the residual's trend by trial: each training trial's own nominal fit
/// (from the batch's), its support shift regressed on the trial's index. `None` with fewer
/// than two distinct indices.
pub fn drift_trend_start(
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
    let c = Effect::Nominal;
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

/// Support-drift starts: drifts along each axis, the nominal shift moved back so that the
/// training trials' mean index keeps the support the nominal fit found.
pub fn drift_starts(nominal: &[f64], train: &[TrialData]) -> Vec<Vec<f64>> {
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
