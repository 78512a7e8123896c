//! The paper's identification (section IV-A): for every trial, sweep the probe friction μ over
//! a grid and simulate each μ with the same set of random three-point supports; score every
//! simulation against the tracked poses. One support set serves all trials, so the
//! cross-trial matrix (trial i's best candidate on trial j) and the nominal choice (least
//! total error over all trials) come from the same simulations with no re-run.
//!
//! Parallel over (trial, μ, support) with rayon; every job is a pure function of its inputs
//! and results are collected in index order, so the numbers do not depend on thread count.

use super::data::IdentTrial;
use super::sample::sample_supports;
use super::score::{Candidate, Score, ScoreSettings, score};
use crate::Error;
use mesopush_sim::SupportDistribution;
use rand::Rng;
use rayon::prelude::*;

/// What the sweep tries.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepSettings {
    /// μ grid step over [0, `mu_max`]. Default 0.05 (the paper's [0, 1] in 21 values).
    pub mu_step: f64,
    /// Largest μ. Default 1.
    pub mu_max: f64,
    /// Random supports per μ. Default 120 (the paper: 100–150).
    pub n_supports: usize,
    /// Surface friction given to every sampled support. Default 0.3.
    pub mu_surface: f64,
}

impl Default for SweepSettings {
    fn default() -> Self {
        Self { mu_step: 0.05, mu_max: 1.0, n_supports: 120, mu_surface: 0.3 }
    }
}

impl SweepSettings {
    /// The μ grid, 0 to `mu_max` inclusive.
    pub fn mus(&self) -> Result<Vec<f64>, Error> {
        let ok =
            self.mu_step > 0.0 && self.mu_step.is_finite() && (0.0..=2.0).contains(&self.mu_max);
        if !ok {
            return Err(Error::invalid("mu grid", "mu_step must be > 0 and mu_max within [0, 2]"));
        }
        let n = (self.mu_max / self.mu_step + 1e-9).floor() as usize;
        Ok((0..=n).map(|i| (i as f64 * self.mu_step).min(self.mu_max)).collect())
    }
}

/// The sweep's simulations.
#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
    /// The μ grid.
    pub mus: Vec<f64>,
    /// The random supports (shared by all μ and trials).
    pub supports: Vec<SupportDistribution>,
    /// `scores[trial][candidate]`, candidate = μ index × supports + support index.
    pub scores: Vec<Vec<Score>>,
}

impl Sweep {
    /// Number of candidates per trial.
    pub fn n_candidates(&self) -> usize {
        self.mus.len() * self.supports.len()
    }

    /// Candidate `k`.
    pub fn candidate(&self, k: usize) -> Candidate {
        let n = self.supports.len();
        Candidate { mu_probe: self.mus[k / n], support: self.supports[k % n].clone() }
    }

    /// The candidate with the least cost on `trial`.
    pub fn best_on(&self, trial: usize) -> usize {
        argmin(self.scores[trial].iter().map(|s| s.cost_um2))
    }

    /// Total squared residual of candidate `k` over all trials, µm² (∞ if any failed).
    pub fn total_sse_um2(&self, k: usize) -> f64 {
        self.scores.iter().map(|row| row[k].sse_um2()).sum()
    }

    /// The candidate with the least total squared residual over all trials.
    pub fn nominal(&self) -> usize {
        argmin((0..self.n_candidates()).map(|k| self.total_sse_um2(k)))
    }

    /// The `k` candidates with the least total error whose supports differ (best first).
    pub fn ranked(&self, k: usize) -> Vec<usize> {
        let mut order: Vec<usize> = (0..self.n_candidates()).collect();
        let sse: Vec<f64> = order.iter().map(|&c| self.total_sse_um2(c)).collect();
        order.sort_by(|a, b| sse[*a].total_cmp(&sse[*b]));
        let n = self.supports.len();
        let mut out: Vec<usize> = Vec::new();
        for c in order {
            if out.len() == k.max(1) || !sse[c].is_finite() {
                break;
            }
            if out.iter().all(|o| o % n != c % n) {
                out.push(c);
            }
        }
        out
    }

    /// `cross[i][j]`: trial i's best candidate scored on trial j.
    pub fn cross(&self) -> Vec<Vec<Score>> {
        (0..self.scores.len())
            .map(|i| {
                let k = self.best_on(i);
                self.scores.iter().map(|row| row[k]).collect()
            })
            .collect()
    }
}

/// Index of the smallest value (NaN and ∞ never win over a finite value; ties: first).
pub fn argmin(values: impl Iterator<Item = f64>) -> usize {
    let mut best = (0, f64::INFINITY);
    for (i, v) in values.enumerate() {
        if v < best.1 {
            best = (i, v);
        }
    }
    best.0
}

/// Checks that every trial pushes the same part (a support set belongs to one part).
pub fn check_same_part(trials: &[IdentTrial]) -> Result<(), Error> {
    let Some(first) = trials.first() else {
        return Err(Error::invalid("identify", "no trials given"));
    };
    if let Some(t) = trials.iter().find(|t| t.part != first.part) {
        return Err(Error::invalid(
            "identify",
            format!(
                "trial {} pushes a different part than trial {}; identify each part separately",
                t.id, first.id
            ),
        ));
    }
    Ok(())
}

/// Runs the sweep; `tick` is called once per simulation (for a progress bar).
pub fn sweep(
    trials: &[IdentTrial],
    settings: &SweepSettings,
    score_settings: &ScoreSettings,
    rng: &mut impl Rng,
    tick: &(dyn Fn() + Sync),
) -> Result<Sweep, Error> {
    let (mus, supports) = grid(trials, settings, rng)?;
    let n = mus.len() * supports.len();
    let all: Vec<usize> = (0..n).collect();
    let flat = score_jobs(trials, &mus, &supports, score_settings, &all, tick);
    let scores = flat.chunks(n).map(<[Score]>::to_vec).collect();
    Ok(Sweep { mus, supports, scores })
}

/// The sweep's μ grid and its random supports (the only draws the sweep makes from `rng`).
pub fn grid(
    trials: &[IdentTrial],
    settings: &SweepSettings,
    rng: &mut impl Rng,
) -> Result<(Vec<f64>, Vec<SupportDistribution>), Error> {
    check_same_part(trials)?;
    let mus = settings.mus()?;
    let part = trials[0].part.polygon();
    let supports = sample_supports(part, settings.n_supports, settings.mu_surface, rng)?;
    Ok((mus, supports))
}

/// Scores candidates `ks` (candidate = μ index × supports + support index) on every trial:
/// element `t · ks.len() + j` is candidate `ks[j]` on trial `t`. Each score is a pure
/// function of (trial, candidate), so any split of the candidates gives the same numbers.
pub fn score_jobs(
    trials: &[IdentTrial],
    mus: &[f64],
    supports: &[SupportDistribution],
    score_settings: &ScoreSettings,
    ks: &[usize],
    tick: &(dyn Fn() + Sync),
) -> Vec<Score> {
    let n = ks.len();
    (0..trials.len() * n)
        .into_par_iter()
        .map(|job| {
            let (t, k) = (job / n, ks[job % n]);
            let c = Candidate {
                mu_probe: mus[k / supports.len()],
                support: supports[k % supports.len()].clone(),
            };
            let s = score(&trials[t], &c, score_settings);
            tick();
            s
        })
        .collect()
}
