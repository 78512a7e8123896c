//! Beyond the paper: a joint fit of the probe friction, the three support points and
//! (optionally) the surface friction, started from the sweep's best candidates in three
//! stages of [`crate::optim`]: a seeded evolution strategy finds the basin,
//! Levenberg–Marquardt on the residual vector descends to its floor, and Nelder–Mead restarts
//! polish what is left. The objective is the total squared residual over all trials;
//! each evaluation simulates the trials in parallel and sums them in trial order, so the
//! result does not depend on thread count.
//!
//! Parameters are scaled to O(1): x = [μ, r1x/L, r1y/L, r2x/L, r2y/L, r3x/L, r3y/L, (μ_s)],
//! L the part's characteristic length. Candidates outside the part, with the COM outside the
//! support triangle or friction out of range score ∞ and the search moves away.
//! Surface friction scales every support's friction force alike; quasi-statically the probe
//! force scales with it and the motion barely changes (only through the small viscous
//! regularisation), so it is fitted only on request and its value is weakly determined.

use super::data::IdentTrial;
use super::optim::{EsSettings, LmSettings, NelderMeadSettings};
use super::optim::{evolve, levenberg_marquardt, nelder_mead};
use super::sample::{MIN_WEIGHT, acceptable};
use super::score::{Candidate, ScoreSettings, residuals, score};
use mesopush_sim::SupportDistribution;
use rand::{Rng, RngExt};
use rayon::prelude::*;
use serde::Serialize;

/// Optimiser budget and options.
#[derive(Debug, Clone, PartialEq)]
pub struct OptimizeSettings {
    /// Objective evaluations in all (each simulates every trial). Default 600.
    pub max_evals: usize,
    /// Nelder–Mead runs after Levenberg–Marquardt, each started around the best so far with
    /// a randomly oriented simplex. Default 3.
    pub restarts: usize,
    /// Also fit one surface friction shared by the three supports. Default false.
    pub fit_surface: bool,
    /// Starts: the sweep's best candidates with distinct supports. Default 4.
    pub starts: usize,
}

impl Default for OptimizeSettings {
    fn default() -> Self {
        Self { max_evals: 600, restarts: 3, fit_surface: false, starts: 4 }
    }
}

/// The optimiser's outcome.
#[derive(Debug, Clone, Serialize)]
pub struct Optimized {
    /// The best candidate found.
    pub best: Candidate,
    /// Its total squared residual over all trials, µm².
    pub total_sse_um2: f64,
    /// The start's total squared residual, µm².
    pub start_sse_um2: f64,
    /// Objective evaluations used.
    pub evals: usize,
    /// Every evaluated candidate with its total squared residual (for the consistent set).
    #[serde(skip)]
    pub visited: Vec<(Candidate, f64)>,
}

/// Maps a parameter vector to a candidate (see the module header for the layout).
pub fn decode(x: &[f64], l_um: f64, mu_surface: f64) -> Candidate {
    let p = |i: usize| [x[1 + 2 * i] * l_um, x[2 + 2 * i] * l_um];
    let mu_s = x.get(7).copied().unwrap_or(mu_surface);
    Candidate {
        mu_probe: x[0],
        support: SupportDistribution { points_um: [p(0), p(1), p(2)], mu_surface: [mu_s; 3] },
    }
}

/// The parameter vector of a candidate.
pub fn encode(c: &Candidate, l_um: f64, fit_surface: bool) -> Vec<f64> {
    let mut x = vec![c.mu_probe];
    for [px, py] in c.support.points_um {
        x.extend([px / l_um, py / l_um]);
    }
    if fit_surface {
        x.push(c.support.mu_surface[0]);
    }
    x
}

/// Total squared residual of `c` over `trials` (∞ when invalid or any simulation fails).
pub fn total_sse(trials: &[IdentTrial], c: &Candidate, s: &ScoreSettings) -> f64 {
    let part = trials[0].part.polygon();
    let mu_ok = (0.0..=2.0).contains(&c.mu_probe);
    if !mu_ok || !acceptable(&c.support, part, MIN_WEIGHT / 4.0) {
        return f64::INFINITY;
    }
    let v: Vec<f64> = trials.par_iter().map(|t| score(t, c, s).sse_um2()).collect();
    v.iter().sum()
}

/// A simplex around `x0`: steps of `scale` along randomly signed, randomly permuted axes.
fn simplex_around(x0: &[f64], scale: &[f64], rng: &mut impl Rng) -> Vec<Vec<f64>> {
    let mut out = vec![x0.to_vec()];
    for i in 0..x0.len() {
        let mut x = x0.to_vec();
        let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
        x[i] += sign * scale[i];
        // A small random tilt so restarts do not retrace the same simplex.
        let j = rng.random_range(0..x0.len());
        if j != i {
            x[j] += 0.3 * scale[j] * (rng.random::<f64>() - 0.5);
        }
        out.push(x);
    }
    out
}

/// All residual components of `c` over `trials`, in trial order (`None` when invalid or any
/// simulation fails); the sum of their squares is [`total_sse`].
pub fn all_residuals(trials: &[IdentTrial], c: &Candidate, s: &ScoreSettings) -> Option<Vec<f64>> {
    let part = trials[0].part.polygon();
    if !(0.0..=2.0).contains(&c.mu_probe) || !acceptable(&c.support, part, MIN_WEIGHT / 4.0) {
        return None;
    }
    let v: Vec<Option<Vec<f64>>> = trials.par_iter().map(|t| residuals(t, c, s)).collect();
    Some(v.into_iter().collect::<Option<Vec<_>>>()?.concat())
}

/// The joint fit's objective over one set of trials.
struct Problem<'a> {
    trials: &'a [IdentTrial],
    score: &'a ScoreSettings,
    l_um: f64,
    mu_s0: f64,
    tick: &'a (dyn Fn() + Sync),
}

impl Problem<'_> {
    fn decode(&self, x: &[f64]) -> Candidate {
        decode(x, self.l_um, self.mu_s0)
    }

    /// Whether a fitted surface friction (x[7]) is in range.
    fn surface_ok(x: &[f64]) -> bool {
        x.get(7).is_none_or(|m| (0.01..=2.0).contains(m))
    }

    fn objective(&self, x: &[f64]) -> f64 {
        (self.tick)();
        if !Self::surface_ok(x) {
            return f64::INFINITY;
        }
        total_sse(self.trials, &self.decode(x), self.score)
    }

    fn residuals(&self, x: &[f64]) -> Option<Vec<f64>> {
        (self.tick)();
        if !Self::surface_ok(x) {
            return None;
        }
        all_residuals(self.trials, &self.decode(x), self.score)
    }
}

/// The best point so far and what the stages spent.
struct Search {
    x: Vec<f64>,
    best: f64,
    evals: usize,
    visited: Vec<(Candidate, f64)>,
}

impl Search {
    fn offer(&mut self, x: Vec<f64>, value: f64) {
        if value < self.best {
            (self.x, self.best) = (x, value);
        }
    }
}

/// Stage 1: the evolution strategy from each start with an equal share of 60 % of the budget.
fn evolve_starts(
    p: &Problem<'_>,
    starts: &[Candidate],
    settings: &OptimizeSettings,
    scale: &[f64],
    rng: &mut impl Rng,
    s: &mut Search,
) {
    let es_budget = settings.max_evals * 6 / 10 / starts.len().max(1);
    let objective = |x: &[f64]| p.objective(x);
    for (i, c) in starts.iter().enumerate() {
        let xs = encode(c, p.l_um, settings.fit_surface);
        let fs = if i == 0 { s.best } else { objective(&xs) };
        let m = evolve(&objective, &xs, fs, scale, es_budget, &EsSettings::DEFAULT, rng);
        s.evals += m.evals + usize::from(i > 0);
        s.visited.extend(m.visited.into_iter().map(|(x, v)| (p.decode(&x), v)));
        s.offer(m.x, m.value);
    }
}

/// Stage 2: Levenberg–Marquardt from the best found, with up to 25 % of the budget. Steps of
/// 2e-3 (about 2 µm on the peg): above the simulator's µm-level jaggedness.
fn descend(p: &Problem<'_>, settings: &OptimizeSettings, s: &mut Search) {
    let h = vec![2e-3; s.x.len()];
    let lm_budget = (settings.max_evals / 4).min(settings.max_evals.saturating_sub(s.evals));
    let res = |x: &[f64]| p.residuals(x);
    let m = levenberg_marquardt(&res, &s.x, &h, lm_budget, &LmSettings::DEFAULT);
    s.evals += m.evals;
    s.visited.extend(m.visited.into_iter().map(|(x, v)| (p.decode(&x), v)));
    s.offer(m.x, m.value);
}

/// Stage 3: Nelder–Mead restarts with the rest, each around the best with a randomly
/// oriented simplex half the size of the one before.
fn polish(
    p: &Problem<'_>,
    settings: &OptimizeSettings,
    mut scale: Vec<f64>,
    rng: &mut impl Rng,
    s: &mut Search,
) {
    scale.iter_mut().for_each(|v| *v *= 0.25);
    let runs = settings.restarts.max(1);
    for r in 0..runs {
        let budget = (settings.max_evals.saturating_sub(s.evals)) / (runs - r);
        if budget < s.x.len() + 3 {
            break;
        }
        let simplex = simplex_around(&s.x, &scale, rng);
        let visited = &mut s.visited;
        let mut f = |x: &[f64]| {
            let v = p.objective(x);
            visited.push((p.decode(x), v));
            v
        };
        let m = nelder_mead(&mut f, simplex, budget, &NelderMeadSettings::DEFAULT);
        s.evals += m.evals;
        s.offer(m.x, m.value);
        scale.iter_mut().for_each(|v| *v *= 0.5);
    }
}

/// Fits μ and the supports (and the surface friction if asked) to all `trials` from the
/// `starts` (best first): the evolution strategy from each start with an equal share of 60 %
/// of the budget, Levenberg–Marquardt from the best found with up to 25 %, then Nelder–Mead
/// restarts with the rest.
pub fn optimize(
    trials: &[IdentTrial],
    starts: &[Candidate],
    settings: &OptimizeSettings,
    score_settings: &ScoreSettings,
    rng: &mut impl Rng,
    tick: &(dyn Fn() + Sync),
) -> Optimized {
    let l_um = trials[0].part.char_length_um();
    let start = &starts[0];
    let mu_s0 = start.support.mu_surface[0];
    let p = Problem { trials, score: score_settings, l_um, mu_s0, tick };
    let x0 = encode(start, l_um, settings.fit_surface);
    let start_sse = p.objective(&x0);
    let mut scale: Vec<f64> = x0.iter().map(|_| 0.08).collect();
    scale[0] = 0.1;
    let mut s = Search { x: x0, best: start_sse, evals: 1, visited: Vec::new() };
    evolve_starts(&p, starts, settings, &scale, rng, &mut s);
    descend(&p, settings, &mut s);
    polish(&p, settings, scale, rng, &mut s);
    Optimized {
        best: p.decode(&s.x),
        total_sse_um2: s.best,
        start_sse_um2: start_sse,
        evals: s.evals,
        visited: s.visited,
    }
}
