//! Beyond the paper: a joint fit of the probe friction, the three support points and
//! (optionally) the surface friction, started from the sweep's best candidates in three
//! stages of [`crate::optim`]: a seeded evolution strategy finds the basin,
//! Levenberg–Marquardt on the residual vector descends to its floor, and Nelder–Mead restarts
//! polish what is left. The objective is the total squared residual over all trials;
//! each evaluation simulates the trials in parallel and sums them in trial order, so the
//! result does not depend on thread count.
//!
//! Parameters are scaled to O(1) by [`Layout`]: x = [μ, r1x/L, r1y/L, r2x/L, r2y/L, r3x/L,
//! r3y/L, (μ_s), (a2, a3)], L the part's characteristic length. Candidates outside the part,
//! with the COM outside the support triangle or friction out of range score ∞ and the search
//! moves away. Surface friction scales every support's friction force alike; quasi-statically
//! the probe force scales with it and the motion barely changes (only through the small
//! viscous regularisation), so it is fitted only on request and its value is weakly
//! determined. The richer family ([`Layout::free_loads`]) gives each support its own friction
//! `μ_s·e^{a_i}` (a1 = −a2 − a3): the three friction loads no longer follow the statics of the
//! points, so the centre of friction may leave the COM — what a real part with an uneven
//! contact (a ridge, a flat face touching at its rim) has.
//!
//! The fit is generic over what it minimises ([`Objective`]): identification scores its
//! trials' replays ([`TrialObjective`]), diagnosis its noise-weighted predictions with every
//! effect off; both get the same parametrisation, starts and stages.

use super::data::IdentTrial;
use super::optim::{EsSettings, LmSettings, NelderMeadSettings};
use super::optim::{evolve, levenberg_marquardt, nelder_mead};
use super::sample::{MIN_WEIGHT, acceptable};
use super::score::{Candidate, ScoreSettings, residuals, score};
use mesopush_core::geom::ConvexPolygon;
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
    /// The richer family: each support its own friction load ([`Layout::free_loads`]).
    /// Default false.
    pub free_loads: bool,
}

impl Default for OptimizeSettings {
    fn default() -> Self {
        Self { max_evals: 600, restarts: 3, fit_surface: false, starts: 4, free_loads: false }
    }
}

impl OptimizeSettings {
    /// The parameter layout these settings fit.
    pub fn layout(&self) -> Layout {
        Layout { fit_surface: self.fit_surface, free_loads: self.free_loads }
    }
}

/// Which parameters the vector holds after μ and the three points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Layout {
    /// One surface friction shared by the supports (`x[7]`).
    pub fit_surface: bool,
    /// Per-support friction loads: two log-ratios a2, a3 (a1 = −a2 − a3) last.
    pub free_loads: bool,
}

/// The largest |a_i| of a free load: e^{±2.5} spans a 150:1 ratio between two supports.
const MAX_LOG_LOAD: f64 = 2.5;

impl Layout {
    /// Length of the parameter vector.
    pub fn len(self) -> usize {
        7 + usize::from(self.fit_surface) + 2 * usize::from(self.free_loads)
    }

    /// Always false (the vector holds at least μ and three points).
    pub fn is_empty(self) -> bool {
        false
    }

    /// Whether the friction entries of `x` are in range.
    fn in_range(self, x: &[f64]) -> bool {
        let surface = !self.fit_surface || (0.01..=2.0).contains(&x[7]);
        let k = 7 + usize::from(self.fit_surface);
        let loads = !self.free_loads || {
            let (a2, a3) = (x[k], x[k + 1]);
            [a2, a3, -a2 - a3].iter().all(|a| a.abs() <= MAX_LOG_LOAD)
        };
        surface && loads
    }

    /// The candidate `x` stands for (`mu_surface`: the mean surface friction when it is not
    /// fitted).
    pub fn decode(self, x: &[f64], l_um: f64, mu_surface: f64) -> Candidate {
        let p = |i: usize| [x[1 + 2 * i] * l_um, x[2 + 2 * i] * l_um];
        let mu_s = if self.fit_surface { x[7] } else { mu_surface };
        let mu = if self.free_loads {
            let k = 7 + usize::from(self.fit_surface);
            let (a2, a3) = (x[k], x[k + 1]);
            [-a2 - a3, a2, a3].map(|a| mu_s * a.exp())
        } else {
            [mu_s; 3]
        };
        Candidate {
            mu_probe: x[0],
            support: SupportDistribution { points_um: [p(0), p(1), p(2)], mu_surface: mu },
        }
    }

    /// The parameter vector of `c` (its loads projected onto the layout: the geometric mean
    /// of its three surface frictions is μ_s).
    pub fn encode(self, c: &Candidate, l_um: f64) -> Vec<f64> {
        let mut x = vec![c.mu_probe];
        for [px, py] in c.support.points_um {
            x.extend([px / l_um, py / l_um]);
        }
        let mu = c.support.mu_surface.map(|m| m.max(1e-9));
        let gm = (mu[0] * mu[1] * mu[2]).cbrt();
        if self.fit_surface {
            x.push(gm);
        }
        if self.free_loads {
            x.extend([(mu[1] / gm).ln(), (mu[2] / gm).ln()]);
        }
        x
    }
}

/// What the joint fit minimises: the residual vector of a candidate over some trials.
pub trait Objective: Sync {
    /// The part whose supports are fitted (body frame, COM at the origin).
    fn part(&self) -> &ConvexPolygon;
    /// The residual components of `c` (`None` when it cannot be simulated or is invalid).
    fn residuals(&self, c: &Candidate) -> Option<Vec<f64>>;
    /// Their sum of squares (∞ when `None`); override with a cheaper sum when there is one.
    fn sse(&self, c: &Candidate) -> f64 {
        self.residuals(c).map_or(f64::INFINITY, |r| r.iter().map(|v| v * v).sum())
    }
}

/// Identification's objective: the replays of its trials ([`crate::score`]).
#[derive(Debug, Clone, Copy)]
pub struct TrialObjective<'a> {
    /// The trials (one part).
    pub trials: &'a [IdentTrial],
    /// Simulator settings and fixed friction.
    pub score: &'a ScoreSettings,
}

impl Objective for TrialObjective<'_> {
    fn part(&self) -> &ConvexPolygon {
        self.trials[0].part.polygon()
    }
    fn residuals(&self, c: &Candidate) -> Option<Vec<f64>> {
        all_residuals(self.trials, c, self.score)
    }
    fn sse(&self, c: &Candidate) -> f64 {
        total_sse(self.trials, c, self.score)
    }
}

/// Whether the joint fit may evaluate `c` on `part` (μ in range, the support inside the part
/// and spanning its COM with a margin).
pub fn admissible(c: &Candidate, part: &ConvexPolygon) -> bool {
    (0.0..=2.0).contains(&c.mu_probe) && acceptable(&c.support, part, MIN_WEIGHT / 4.0)
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

/// Total squared residual of `c` over `trials` (∞ when invalid or any simulation fails).
pub fn total_sse(trials: &[IdentTrial], c: &Candidate, s: &ScoreSettings) -> f64 {
    if !admissible(c, trials[0].part.polygon()) {
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
    if !admissible(c, trials[0].part.polygon()) {
        return None;
    }
    let v: Vec<Option<Vec<f64>>> = trials.par_iter().map(|t| residuals(t, c, s)).collect();
    Some(v.into_iter().collect::<Option<Vec<_>>>()?.concat())
}

/// The joint fit's objective over one parameter layout.
struct Problem<'a> {
    objective: &'a dyn Objective,
    layout: Layout,
    l_um: f64,
    mu_s0: f64,
    tick: &'a (dyn Fn() + Sync),
}

impl Problem<'_> {
    fn decode(&self, x: &[f64]) -> Candidate {
        self.layout.decode(x, self.l_um, self.mu_s0)
    }

    fn usable(&self, x: &[f64]) -> Option<Candidate> {
        let c = self.decode(x);
        (self.layout.in_range(x) && admissible(&c, self.objective.part())).then_some(c)
    }

    fn objective(&self, x: &[f64]) -> f64 {
        (self.tick)();
        self.usable(x).map_or(f64::INFINITY, |c| self.objective.sse(&c))
    }

    fn residuals(&self, x: &[f64]) -> Option<Vec<f64>> {
        (self.tick)();
        self.objective.residuals(&self.usable(x)?)
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
        let xs = p.layout.encode(c, p.l_um);
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
    let objective = TrialObjective { trials, score: score_settings };
    optimize_objective(&objective, trials[0].part.char_length_um(), starts, settings, rng, tick)
}

/// [`optimize`] over any [`Objective`]; `l_um` is the part's characteristic length, the
/// scale of the support coordinates in the parameter vector.
pub fn optimize_objective(
    objective: &dyn Objective,
    l_um: f64,
    starts: &[Candidate],
    settings: &OptimizeSettings,
    rng: &mut impl Rng,
    tick: &(dyn Fn() + Sync),
) -> Optimized {
    let start = &starts[0];
    let mu = start.support.mu_surface;
    let equal = mu[1] == mu[0] && mu[2] == mu[0];
    let mu_s0 = if equal { mu[0] } else { (mu[0] * mu[1] * mu[2]).max(1e-27).cbrt() };
    let layout = settings.layout();
    let p = Problem { objective, layout, l_um, mu_s0, tick };
    let x0 = layout.encode(start, l_um);
    let start_sse = p.objective(&x0);
    let mut scale: Vec<f64> = x0.iter().map(|_| 0.08).collect();
    scale[0] = 0.1;
    if layout.free_loads {
        let n = scale.len();
        scale[n - 2..].iter_mut().for_each(|v| *v = 0.3);
    }
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

/// Levenberg–Marquardt alone from `start` with at most `budget` evaluations (a refit from a
/// nearby optimum, e.g. on a bootstrap resample of the trials).
pub fn refine(
    objective: &dyn Objective,
    l_um: f64,
    start: &Candidate,
    layout: Layout,
    budget: usize,
    tick: &(dyn Fn() + Sync),
) -> Optimized {
    let mu = start.support.mu_surface;
    let mu_s0 = (mu[0] * mu[1] * mu[2]).max(1e-27).cbrt();
    let p = Problem { objective, layout, l_um, mu_s0, tick };
    let x0 = layout.encode(start, l_um);
    let start_sse = p.objective(&x0);
    let mut s = Search { x: x0, best: start_sse, evals: 1, visited: Vec::new() };
    let settings = OptimizeSettings { max_evals: budget * 4, ..OptimizeSettings::default() };
    descend(&p, &settings, &mut s);
    Optimized {
        best: p.decode(&s.x),
        total_sse_um2: s.best,
        start_sse_um2: start_sse,
        evals: s.evals,
        visited: s.visited,
    }
}
