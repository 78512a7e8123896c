//! Robust plans by design (beyond the paper, which tuned Table II by hand): the cross-entropy
//! method over the [`Skeleton`]'s parameters, scoring each candidate by its Monte Carlo
//! success rate on one common set of sampled worlds (common random numbers, so candidates
//! are compared on the same draws and the score is deterministic for a seed).

use super::montecarlo::{draws, evaluate};
use super::sampler::Uncertainty;
use super::skeleton::{BOUNDS, Skeleton};
use crate::Error;
use crate::sim::plan::PegStart;
use crate::sim::{Fixture, Model, Plan, SimSettings, SupportDistribution};
use rand::RngExt;

/// Optimiser settings (plain data, documented defaults).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobustSettings {
    /// CEM generations. Default 12.
    pub generations: usize,
    /// Candidates per generation. Default 16.
    pub population: usize,
    /// Best candidates that set the next generation's distribution. Default 4.
    pub elite: usize,
    /// Sampled worlds each candidate is scored on. Default 64.
    pub samples: usize,
    /// Stop early once the best score reaches this rate. Default 1.0 (never early).
    pub target_rate: f64,
}

impl Default for RobustSettings {
    fn default() -> Self {
        Self { generations: 12, population: 16, elite: 4, samples: 64, target_rate: 1.0 }
    }
}

/// What the optimiser found.
#[derive(Debug, Clone, PartialEq)]
pub struct RobustResult {
    /// The best plan.
    pub plan: Plan,
    /// Its skeleton parameters.
    pub skeleton: Skeleton,
    /// Its success rate on the optimisation's worlds (optimistic: it was selected on them;
    /// re-estimate on fresh draws for an honest figure).
    pub training_rate: f64,
    /// Candidates evaluated.
    pub evaluations: usize,
    /// Generations run.
    pub generations: usize,
}

/// The world the plan must work in.
#[derive(Debug, Clone, Copy)]
pub struct World<'a> {
    /// Nominal model.
    pub model: &'a Model,
    /// Fixture.
    pub fixture: &'a Fixture,
    /// Simulator settings.
    pub settings: &'a SimSettings,
    /// Uncertainty around the nominal.
    pub uncertainty: Uncertainty,
    /// Candidate supports (empty: perturb the model's).
    pub supports: &'a [SupportDistribution],
}

fn gaussian(rng: &mut impl rand::Rng) -> f64 {
    let u1: f64 = rng.random_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Optimises the skeleton for a peg starting at `start`; `progress(generation, best_rate)`
/// may return `false` to stop after a generation.
pub fn design_robust(
    world: &World<'_>,
    start: PegStart,
    settings: &RobustSettings,
    rng: &mut impl rand::Rng,
    progress: &mut dyn FnMut(usize, f64) -> bool,
) -> Result<RobustResult, Error> {
    let worlds =
        draws(world.model, &world.uncertainty, world.supports, settings.samples, rng.random());
    let score = |s: &Skeleton| -> Result<f64, Error> {
        let plan = s.to_plan("", start);
        Ok(evaluate(&plan, &worlds, world.fixture, world.settings, &|| ())?.success_rate)
    };
    let mut mean = Skeleton::table2_like().params;
    let mut sigma: Vec<f64> = BOUNDS.iter().map(|(lo, hi)| (hi - lo) / 6.0).collect();
    let mut best = (Skeleton::table2_like(), score(&Skeleton::table2_like())?);
    let (mut evaluations, mut generations) = (1, 0);
    for g in 0..settings.generations {
        generations = g + 1;
        let mut scored = Vec::with_capacity(settings.population + 1);
        scored.push(best);
        for _ in 0..settings.population {
            let mut p = mean;
            for (v, s) in p.iter_mut().zip(&sigma) {
                *v += s * gaussian(rng);
            }
            let cand = Skeleton { params: p }.clamped();
            scored.push((cand, score(&cand)?));
            evaluations += 1;
        }
        // Stable sort: ties keep the earlier (and, for the incumbent, the older) candidate.
        scored.sort_by(|a, b| b.1.total_cmp(&a.1));
        best = scored[0];
        let elite = &scored[..settings.elite.clamp(1, scored.len())];
        for (k, (m, s)) in mean.iter_mut().zip(sigma.iter_mut()).enumerate() {
            let n = elite.len() as f64;
            let mu = elite.iter().map(|e| e.0.params[k]).sum::<f64>() / n;
            let var = elite.iter().map(|e| (e.0.params[k] - mu).powi(2)).sum::<f64>() / n;
            *m = mu;
            *s = (0.7 * *s + 0.3 * var.sqrt()).max(5.0);
        }
        if !progress(generations, best.1) || best.1 >= settings.target_rate {
            break;
        }
    }
    let name = format!("robust plan (CEM over the Table II skeleton, {evaluations} candidates)");
    Ok(RobustResult {
        plan: best.0.to_plan(&name, start),
        skeleton: best.0,
        training_rate: best.1,
        evaluations,
        generations,
    })
}
