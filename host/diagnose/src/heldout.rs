//! Held-out prediction across start conditions: the trials come in groups (one start
//! condition each, repeated runs); for each group, the nominal model is identified on the
//! other groups ([`crate::nominal::nominal_base`]: fitted on every other training run, its
//! family chosen on the runs between) and the group is replayed open-loop ([`crate::replay`]). Each run's final-pose error
//! is reported next to the group's repeat spread — how far the runs of one start end from each
//! other, which no model of the mean can beat.
//!
//! The repeat spread of a group: the population standard deviation of its runs' final
//! measured poses, `spread_um = √(σx² + σy²)` and `spread_deg = σθ`. The target the issue
//! set: the median final error within 2 × the spread or 2 mm / 2°, whichever is larger.

use super::data::TrialData;
use super::nominal::{Held, SupportFit, nominal_base};
use super::options::Options;
use super::replay::{ReplayOptions, TrialReplay, replay_trial, settings_for};
use super::residual::Noise;
use crate::Error;
use mesopush_sim::Model;
use serde::Serialize;

/// One group held out.
#[derive(Debug, Clone, Serialize)]
pub struct HeldOutGroup {
    /// The held-out group's name.
    pub group: String,
    /// Training runs (the other groups).
    pub n_train: usize,
    /// The fitted model's support family and held-out errors of the families tried.
    pub support_fit: SupportFit,
    /// The fitted model.
    pub model: Model,
    /// Each held-out run's replay.
    pub runs: Vec<TrialReplay>,
    /// Median final position error over the runs, µm.
    pub median_final_error_um: f64,
    /// Median |final angle error| over the runs, degrees.
    pub median_final_error_deg: f64,
    /// Repeat spread of the group's final positions, µm.
    pub spread_um: f64,
    /// Repeat spread of the group's final angles, degrees.
    pub spread_deg: f64,
    /// max(2 × spread, 2 mm) and max(2 × spread, 2°).
    pub target: [f64; 2],
    /// Both medians within their targets.
    pub within_target: bool,
}

fn median(v: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = v.collect();
    mesopush_core::stats::median(&mut v).unwrap_or(f64::NAN)
}

/// Population standard deviations of the final measured x, y (µm) and θ (rad) of `runs`.
fn final_spread(runs: &[TrialData]) -> (f64, f64) {
    let last: Vec<[f64; 3]> = runs
        .iter()
        .filter_map(|t| t.frames.last())
        .map(|m| [m.pose.x_um, m.pose.y_um, m.pose.theta_rad])
        .collect();
    let n = last.len().max(1) as f64;
    let var = |k: usize| {
        let mean = last.iter().map(|p| p[k]).sum::<f64>() / n;
        last.iter().map(|p| (p[k] - mean).powi(2)).sum::<f64>() / n
    };
    ((var(0) + var(1)).sqrt(), var(2).sqrt().to_degrees())
}

/// Holds out each of `groups` (name, its runs) in turn; `prior` is where every fit starts.
pub fn heldout_by_group(
    groups: &[(String, Vec<TrialData>)],
    prior: &Model,
    opts: &Options,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Vec<HeldOutGroup>, Error> {
    if groups.len() < 2 {
        return Err(Error::invalid("groups", "held-out prediction needs at least two groups"));
    }
    groups
        .iter()
        .enumerate()
        .map(|(g, held)| hold_out(groups, g, held, prior, opts, progress))
        .collect()
}

fn hold_out(
    groups: &[(String, Vec<TrialData>)],
    g: usize,
    (name, held): &(String, Vec<TrialData>),
    prior: &Model,
    opts: &Options,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<HeldOutGroup, Error> {
    progress(name);
    let train: Vec<TrialData> = groups
        .iter()
        .enumerate()
        .filter(|(k, _)| *k != g)
        .flat_map(|(_, (_, runs))| runs.iter().cloned())
        .collect();
    let first = train.first().ok_or_else(|| Error::invalid("groups", "a group has no runs"))?;
    let replay = ReplayOptions { base: opts.settings.clone(), registration_tol: None };
    let s = settings_for(&replay, first);
    // The family is chosen on alternate training runs (never on the held-out group).
    let fit_on: Vec<TrialData> = train.iter().step_by(2).cloned().collect();
    let choose_on: Vec<TrialData> = train.iter().skip(1).step_by(2).cloned().collect();
    let noise = Noise::estimate(&train);
    let with_tip = train.iter().any(TrialData::has_tips);
    let band = opts.floor_factor * (2.0 + if with_tip { 1.0 } else { 0.0 });
    let h = Held { trials: &choose_on, settings: &s, noise: &noise, with_tip };
    let (fit, _, support_fit, _) = nominal_base(prior, &fit_on, &h, band, opts);
    let runs: Vec<TrialReplay> =
        held.iter().map(|t| replay_trial(&fit.model, t, &s)).collect::<Result<_, _>>()?;
    let (spread_um, spread_deg) = final_spread(held);
    let med_um = median(runs.iter().map(|r| r.final_error_um));
    let med_deg = median(runs.iter().map(|r| r.final_error_deg.abs()));
    let target = [(2.0 * spread_um).max(2000.0), (2.0 * spread_deg).max(2.0)];
    Ok(HeldOutGroup {
        group: name.clone(),
        n_train: train.len(),
        support_fit,
        model: fit.model,
        runs,
        median_final_error_um: med_um,
        median_final_error_deg: med_deg,
        spread_um,
        spread_deg,
        target,
        within_target: med_um <= target[0] && med_deg <= target[1],
    })
}
