//! A (1 + λ) evolution strategy for the joint fit: each generation draws λ Gaussian
//! perturbations of the current best (sequentially, from the seeded generator), evaluates
//! them in parallel, and keeps the best if it improves; the step grows on success and shrinks
//! on failure (a success rule in the spirit of Rechenberg's 1/5 rule). Robust to the jagged
//! objective that contact-mode switches make, where a simplex method stalls; Nelder–Mead then
//! polishes the result ([`mod@super::optimize`]).

use rand::{Rng, RngExt};
use rayon::prelude::*;

/// What [`evolve`] returns: the best point, its value, evaluations used, and every
/// evaluated point with its value.
pub type Evolved = (Vec<f64>, f64, usize, Vec<(Vec<f64>, f64)>);

/// Perturbations per generation.
pub const LAMBDA: usize = 8;

/// Minimises `f` from `x0` (value `f0`) with per-coordinate step `scale`; at most `budget`
/// evaluations. `f` must be a pure function of its argument (it runs in parallel).
pub fn evolve(
    f: &(dyn Fn(&[f64]) -> f64 + Sync),
    x0: &[f64],
    f0: f64,
    scale: &[f64],
    budget: usize,
    rng: &mut impl Rng,
) -> Evolved {
    let (mut x, mut fx) = (x0.to_vec(), f0);
    let mut sigma = 1.0;
    let mut evals = 0;
    let mut visited = Vec::new();
    while evals + LAMBDA <= budget {
        let batch: Vec<Vec<f64>> = (0..LAMBDA)
            .map(|_| x.iter().zip(scale).map(|(v, s)| v + sigma * s * normal(rng)).collect())
            .collect();
        let values: Vec<f64> = batch.par_iter().map(|y| f(y)).collect();
        evals += LAMBDA;
        let best = (0..LAMBDA).min_by(|a, b| values[*a].total_cmp(&values[*b])).unwrap_or(0);
        if values[best] < fx {
            (x, fx) = (batch[best].clone(), values[best]);
            sigma = (sigma * 1.5).min(2.0);
        } else {
            sigma *= 0.7;
            if sigma < 0.01 {
                sigma = 0.5;
            }
        }
        visited.extend(batch.into_iter().zip(values));
    }
    (x, fx, evals, visited)
}

/// A standard normal draw (Box–Muller).
fn normal(rng: &mut impl Rng) -> f64 {
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
            evolve(&f, &[0.0; 4], f(&[0.0; 4]), &[0.5; 4], 2000, &mut rng)
        };
        let (x, fx, _, _) = run();
        assert!(fx < 1e-3, "{x:?} {fx}");
        assert_eq!(run().0, x);
    }
}
