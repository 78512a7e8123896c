//! A (1 + λ) evolution strategy: each generation draws λ Gaussian perturbations of the current
//! best (sequentially, from the seeded generator), evaluates them in parallel, and keeps the
//! best if it improves; the step grows on success and shrinks on failure (a success rule in
//! the spirit of Rechenberg's 1/5 rule). Robust to the jagged objective that contact-mode
//! switches make, where a simplex method stalls. Deterministic for a seed: the draws are
//! sequential and the parallel values are collected in index order.

use super::Minimum;
use rand::{Rng, RngExt};
use rayon::prelude::*;

/// The strategy's population and step-size rule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EsSettings {
    /// Perturbations per generation (λ). Default 8.
    pub lambda: usize,
    /// Initial step multiplier σ (a perturbation is σ · scale · N(0, 1) per coordinate).
    /// Default 1.
    pub sigma0: f64,
    /// σ is multiplied by this after a generation that improves. Default 1.5.
    pub grow: f64,
    /// The largest σ. Default 2.
    pub sigma_max: f64,
    /// σ is multiplied by this after a generation that does not improve. Default 0.7.
    pub shrink: f64,
    /// When σ falls below this it restarts at `sigma_restart`. Default 0.01.
    pub sigma_min: f64,
    /// Where σ restarts (a wider search around the best). Default 0.5.
    pub sigma_restart: f64,
}

impl EsSettings {
    /// The documented defaults.
    pub const DEFAULT: Self = Self {
        lambda: 8,
        sigma0: 1.0,
        grow: 1.5,
        sigma_max: 2.0,
        shrink: 0.7,
        sigma_min: 0.01,
        sigma_restart: 0.5,
    };
}

impl Default for EsSettings {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Minimises `f` from `x0` (value `f0`, not re-evaluated) with per-coordinate step `scale`;
/// whole generations only, at most `budget` evaluations. `f` must be a pure function of its
/// argument (it runs in parallel).
pub fn evolve(
    f: &(dyn Fn(&[f64]) -> f64 + Sync),
    x0: &[f64],
    f0: f64,
    scale: &[f64],
    budget: usize,
    s: &EsSettings,
    rng: &mut impl Rng,
) -> Minimum {
    let (mut x, mut fx) = (x0.to_vec(), f0);
    let mut sigma = s.sigma0;
    let mut evals = 0;
    let mut visited = Vec::new();
    let lambda = s.lambda.max(1);
    while evals + lambda <= budget {
        let batch: Vec<Vec<f64>> = (0..lambda)
            .map(|_| x.iter().zip(scale).map(|(v, s)| v + sigma * s * normal(rng)).collect())
            .collect();
        let values: Vec<f64> = batch.par_iter().map(|y| f(y)).collect();
        evals += lambda;
        let best = (0..lambda).min_by(|a, b| values[*a].total_cmp(&values[*b])).unwrap_or(0);
        if values[best] < fx {
            (x, fx) = (batch[best].clone(), values[best]);
            sigma = (sigma * s.grow).min(s.sigma_max);
        } else {
            sigma *= s.shrink;
            if sigma < s.sigma_min {
                sigma = s.sigma_restart;
            }
        }
        visited.extend(batch.into_iter().zip(values));
    }
    Minimum { x, value: fx, evals, visited }
}

/// A standard normal draw (Box–Muller).
pub fn normal(rng: &mut impl Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(f64::MIN_POSITIVE);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn finds_the_minimum_of_a_shifted_quadratic_deterministically() {
        let f = |x: &[f64]| x.iter().enumerate().map(|(i, v)| (v - i as f64).powi(2)).sum::<f64>();
        let run = || {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
            evolve(&f, &[0.0; 4], f(&[0.0; 4]), &[0.5; 4], 2000, &EsSettings::DEFAULT, &mut rng)
        };
        let m = run();
        assert!(m.value < 1e-3, "{:?} {}", m.x, m.value);
        assert_eq!(run().x, m.x);
    }
}
