//! Beyond the paper: a joint fit of the probe friction, the three support points and
//! (optionally) the surface friction, started from the sweep's best candidates: a seeded
//! evolution strategy ([`super::es`]) finds the basin, Levenberg–Marquardt on the residual
//! vector ([`super::polish`]) descends to its floor, and Nelder–Mead restarts polish what is
//! left. The objective is the total squared residual over all trials;
//! each evaluation simulates the trials in parallel and sums them in trial order, so the
//! result does not depend on thread count.
//!
//! Parameters are scaled to O(1): x = [μ, r1x/L, r1y/L, r2x/L, r2y/L, r3x/L, r3y/L, (μ_s)],
//! L the part's characteristic length. Candidates outside the part, with the COM outside the
//! support triangle or friction out of range score ∞ and the simplex moves away.
//! Surface friction scales every support's friction force alike; quasi-statically the probe
//! force scales with it and the motion barely changes (only through the small viscous
//! regularisation), so it is fitted only on request and its value is weakly determined.

use super::data::IdentTrial;
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
    /// Nelder–Mead runs (the first from the start, the others re-started around the best
    /// with a randomly oriented simplex). Default 3.
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

/// One Nelder–Mead run from `simplex` (n + 1 points), at most `budget` evaluations.
fn nelder_mead(
    f: &mut dyn FnMut(&[f64]) -> f64,
    simplex: Vec<Vec<f64>>,
    budget: usize,
) -> (Vec<f64>, f64, usize) {
    let mut evals = 0usize;
    let mut ev = |x: &[f64], evals: &mut usize| {
        *evals += 1;
        f(x)
    };
    let mut pts: Vec<(Vec<f64>, f64)> = simplex
        .into_iter()
        .map(|x| {
            let v = ev(&x, &mut evals);
            (x, v)
        })
        .collect();
    let n = pts.len() - 1;
    let lerp = |a: &[f64], b: &[f64], t: f64| -> Vec<f64> {
        a.iter().zip(b).map(|(a, b)| a + t * (b - a)).collect()
    };
    while evals + 2 <= budget {
        pts.sort_by(|a, b| a.1.total_cmp(&b.1));
        let spread = pts[n].1 - pts[0].1;
        let size = pts[1..]
            .iter()
            .flat_map(|p| p.0.iter().zip(&pts[0].0).map(|(a, b)| (a - b).abs()))
            .fold(0.0, f64::max);
        if (spread.is_finite() && spread <= 1e-9 * pts[0].1.abs().max(1e-12)) || size < 1e-6 {
            break;
        }
        let mut centroid = vec![0.0; pts[0].0.len()];
        for p in &pts[..n] {
            centroid.iter_mut().zip(&p.0).for_each(|(c, v)| *c += v / n as f64);
        }
        let worst = pts[n].0.clone();
        let refl = lerp(&centroid, &worst, -1.0);
        let fr = ev(&refl, &mut evals);
        if fr < pts[0].1 {
            let exp = lerp(&centroid, &worst, -2.0);
            let fe = ev(&exp, &mut evals);
            pts[n] = if fe < fr { (exp, fe) } else { (refl, fr) };
        } else if fr < pts[n - 1].1 {
            pts[n] = (refl, fr);
        } else {
            let con = lerp(&centroid, &worst, 0.5);
            let fc = ev(&con, &mut evals);
            if fc < pts[n].1.min(fr) {
                pts[n] = (con, fc);
            } else {
                let best = pts[0].0.clone();
                for p in pts.iter_mut().skip(1) {
                    p.0 = lerp(&best, &p.0, 0.5);
                    p.1 = ev(&p.0, &mut evals);
                }
            }
        }
    }
    pts.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (x, v) = pts.swap_remove(0);
    (x, v, evals)
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

/// Fits μ and the supports (and the surface friction if asked) to all `trials` from the
/// `starts` (best first): the evolution strategy ([`super::es`]) from each start with an equal
/// share of 60 % of the budget, Levenberg–Marquardt ([`super::polish`]) from the best found
/// with up to 25 %, then Nelder–Mead restarts with the rest.
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
    let objective = |x: &[f64]| {
        tick();
        if x.get(7).is_some_and(|m| !(0.01..=2.0).contains(m)) {
            return f64::INFINITY;
        }
        total_sse(trials, &decode(x, l_um, mu_s0), score_settings)
    };
    let x0 = encode(start, l_um, settings.fit_surface);
    let start_sse = objective(&x0);
    let mut scale: Vec<f64> = x0.iter().map(|_| 0.08).collect();
    scale[0] = 0.1;
    let es_budget = settings.max_evals * 6 / 10 / starts.len().max(1);
    let (mut x, mut best, mut evals) = (x0, start_sse, 1);
    let mut visited: Vec<(Candidate, f64)> = Vec::new();
    for (i, c) in starts.iter().enumerate() {
        let xs = encode(c, l_um, settings.fit_surface);
        let fs = if i == 0 { start_sse } else { objective(&xs) };
        let (xe, fe, used, seen) = super::es::evolve(&objective, &xs, fs, &scale, es_budget, rng);
        evals += used + usize::from(i > 0);
        visited.extend(seen.into_iter().map(|(x, v)| (decode(&x, l_um, mu_s0), v)));
        if fe < best {
            (x, best) = (xe, fe);
        }
    }
    let res = |x: &[f64]| {
        tick();
        if x.get(7).is_some_and(|m| !(0.01..=2.0).contains(m)) {
            return None;
        }
        all_residuals(trials, &decode(x, l_um, mu_s0), score_settings)
    };
    // Steps of 2e-3 (about 2 µm on the peg): above the simulator's µm-level jaggedness.
    let h = vec![2e-3; x.len()];
    let lm_budget = (settings.max_evals / 4).min(settings.max_evals.saturating_sub(evals));
    let (xl, fl, used, seen) = super::polish::levenberg_marquardt(&res, &x, &h, lm_budget);
    evals += used;
    visited.extend(seen.into_iter().map(|(x, v)| (decode(&x, l_um, mu_s0), v)));
    if fl < best {
        (x, best) = (xl, fl);
    }
    let mut f = |x: &[f64]| {
        let v = objective(x);
        visited.push((decode(x, l_um, mu_s0), v));
        v
    };
    scale.iter_mut().for_each(|s| *s *= 0.25);
    let runs = settings.restarts.max(1);
    for r in 0..runs {
        let budget = (settings.max_evals.saturating_sub(evals)) / (runs - r);
        if budget < x.len() + 3 {
            break;
        }
        let (xr, vr, used) = nelder_mead(&mut f, simplex_around(&x, &scale, rng), budget);
        evals += used;
        if vr < best {
            (x, best) = (xr, vr);
        }
        scale.iter_mut().for_each(|s| *s *= 0.5);
    }
    Optimized {
        best: decode(&x, l_um, mu_s0),
        total_sse_um2: best,
        start_sse_um2: start_sse,
        evals,
        visited,
    }
}
