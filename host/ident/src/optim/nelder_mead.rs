//! Nelder–Mead: a derivative-free simplex that reflects its worst vertex through the centroid
//! of the others, expands a step that found a new best, contracts one that did not, and
//! shrinks toward the best when nothing helps. Deterministic; the budget counts every
//! objective evaluation, the initial simplex's included.
//!
//! Identification and diagnosis stop and round differently, and their published numbers
//! depend on it, so the differences are settings, not copies: the stopping rule ([`Stop`]), how the centroid is
//! summed ([`Centroid`], a rounding difference only) and how many evaluations must remain to
//! start an iteration (`reserve`). [`NelderMeadSettings::DEFAULT`] is identification's;
//! diagnosis uses [`Stop::Spread`], [`Centroid::SumThenDivide`] and a reserve of 1.

use super::Minimum;

/// When a run stops before its budget (the simplex sorted best first).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stop {
    /// When the values' spread (worst − best) is finite and at most `rel` × max(|best|,
    /// `floor`), or when every vertex lies within `size` of the best in every coordinate.
    SpreadOrSize {
        /// Relative tolerance on the spread. Default 1e-9.
        rel: f64,
        /// Smallest |best| the tolerance scales with. Default 1e-12.
        floor: f64,
        /// Simplex extent below which it stops, in parameter units. Default 1e-6.
        size: f64,
    },
    /// When |worst − best| ≤ `rel` × (1 + |best|); the simplex's size is not tested.
    Spread {
        /// Tolerance on the spread, relative to 1 + |best|.
        rel: f64,
    },
}

/// How the centroid of the best n vertices is computed. Both are the mean; they round
/// differently, and each caller keeps the one its numbers were made with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Centroid {
    /// Σ (xᵢ / n): each vertex divided by n, accumulated vertex by vertex from +0.
    ScaledSum,
    /// (Σ xᵢ) / n per coordinate: summed (`Iterator::sum`), then one division.
    SumThenDivide,
}

/// Nelder–Mead's coefficients and stopping rules.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NelderMeadSettings {
    /// Reflection α: the reflected point is centroid + α (centroid − worst). Default 1.
    pub reflection: f64,
    /// Expansion γ: the expanded point is γ times as far out as the reflected one. Default 2.
    pub expansion: f64,
    /// Contraction ρ: the contracted point is centroid + ρ (worst − centroid). Default 0.5.
    pub contraction: f64,
    /// Shrink σ: every vertex moves to best + σ (vertex − best). Default 0.5.
    pub shrink: f64,
    /// Early stop. Default [`Stop::SpreadOrSize`] with 1e-9, 1e-12, 1e-6.
    pub stop: Stop,
    /// Centroid summation. Default [`Centroid::ScaledSum`].
    pub centroid: Centroid,
    /// An iteration starts only while at least this many evaluations remain (a reflection
    /// and an expansion: 2). Default 2.
    pub reserve: usize,
}

impl NelderMeadSettings {
    /// The documented defaults (a `const` for struct-update syntax in constants).
    pub const DEFAULT: Self = Self {
        reflection: 1.0,
        expansion: 2.0,
        contraction: 0.5,
        shrink: 0.5,
        stop: Stop::SpreadOrSize { rel: 1e-9, floor: 1e-12, size: 1e-6 },
        centroid: Centroid::ScaledSum,
        reserve: 2,
    };
}

impl Default for NelderMeadSettings {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The axis-aligned simplex: `x0` and `x0 + step[i]·eᵢ` for every coordinate i.
pub fn axis_simplex(x0: &[f64], step: &[f64]) -> Vec<Vec<f64>> {
    let mut out = vec![x0.to_vec()];
    for i in 0..x0.len() {
        let mut x = x0.to_vec();
        x[i] += step[i];
        out.push(x);
    }
    out
}

fn lerp(a: &[f64], b: &[f64], t: f64) -> Vec<f64> {
    a.iter().zip(b).map(|(a, b)| a + t * (b - a)).collect()
}

impl Stop {
    /// Whether the sorted simplex `pts` (best first) has converged.
    fn reached(&self, pts: &[(Vec<f64>, f64)]) -> bool {
        let (best, worst) = (pts[0].1, pts[pts.len() - 1].1);
        match *self {
            Stop::SpreadOrSize { rel, floor, size } => {
                let spread = worst - best;
                let extent = pts[1..]
                    .iter()
                    .flat_map(|p| p.0.iter().zip(&pts[0].0).map(|(a, b)| (a - b).abs()))
                    .fold(0.0, f64::max);
                (spread.is_finite() && spread <= rel * best.abs().max(floor)) || extent < size
            }
            Stop::Spread { rel } => (worst - best).abs() <= rel * (1.0 + best.abs()),
        }
    }
}

impl Centroid {
    /// The centroid of `pts` (the best n vertices).
    fn of(self, pts: &[(Vec<f64>, f64)]) -> Vec<f64> {
        let n = pts.len();
        let dim = pts[0].0.len();
        match self {
            Centroid::ScaledSum => {
                let mut c = vec![0.0; dim];
                for p in pts {
                    c.iter_mut().zip(&p.0).for_each(|(c, v)| *c += v / n as f64);
                }
                c
            }
            Centroid::SumThenDivide => {
                (0..dim).map(|k| pts.iter().map(|s| s.0[k]).sum::<f64>() / n as f64).collect()
            }
        }
    }
}

/// Minimises `f` from `simplex` (n + 1 points in n dimensions, evaluated in order first) with
/// at most about `budget` evaluations (an iteration that starts may shrink, n evaluations).
pub fn nelder_mead(
    f: &mut dyn FnMut(&[f64]) -> f64,
    simplex: Vec<Vec<f64>>,
    budget: usize,
    s: &NelderMeadSettings,
) -> Minimum {
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
    let n = pts.len().saturating_sub(1);
    while n > 0 && evals + s.reserve <= budget {
        pts.sort_by(|a, b| a.1.total_cmp(&b.1));
        if s.stop.reached(&pts) {
            break;
        }
        let centroid = s.centroid.of(&pts[..n]);
        let worst = pts[n].0.clone();
        let refl = lerp(&centroid, &worst, -s.reflection);
        let fr = ev(&refl, &mut evals);
        if fr < pts[0].1 {
            let exp = lerp(&centroid, &worst, -s.reflection * s.expansion);
            let fe = ev(&exp, &mut evals);
            pts[n] = if fe < fr { (exp, fe) } else { (refl, fr) };
        } else if fr < pts[n - 1].1 {
            pts[n] = (refl, fr);
        } else {
            let con = lerp(&centroid, &worst, s.contraction);
            let fc = ev(&con, &mut evals);
            if fc < pts[n].1.min(fr) {
                pts[n] = (con, fc);
            } else {
                let best = pts[0].0.clone();
                for p in pts.iter_mut().skip(1) {
                    p.0 = lerp(&best, &p.0, s.shrink);
                    p.1 = ev(&p.0, &mut evals);
                }
            }
        }
    }
    pts.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (x, value) = pts.swap_remove(0);
    Minimum { x, value, evals, visited: Vec::new() }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quadratic(x: &[f64]) -> f64 {
        (x[0] - 3.0).powi(2) + 10.0 * (x[1] + 1.0).powi(2)
    }

    #[test]
    fn finds_a_quadratic_minimum_with_either_setting() {
        let spread = NelderMeadSettings {
            stop: Stop::Spread { rel: 1e-9 },
            centroid: Centroid::SumThenDivide,
            reserve: 1,
            ..NelderMeadSettings::DEFAULT
        };
        for s in [NelderMeadSettings::DEFAULT, spread] {
            let m = nelder_mead(&mut quadratic, axis_simplex(&[0.0, 0.0], &[1.0, 1.0]), 400, &s);
            let x = &m.x;
            assert!((x[0] - 3.0).abs() < 1e-3 && (x[1] + 1.0).abs() < 1e-3, "{x:?} {s:?}");
            assert!(m.value < 1e-6 && m.evals <= 400, "{m:?}");
        }
    }

    #[test]
    fn the_budget_counts_the_initial_simplex_and_the_reserve() {
        let s = NelderMeadSettings::DEFAULT;
        let m = nelder_mead(&mut quadratic, axis_simplex(&[0.0, 0.0], &[1.0, 1.0]), 4, &s);
        assert_eq!(m.evals, 3, "three vertices, then fewer than two evaluations left");
        let m = nelder_mead(&mut quadratic, vec![vec![5.0, 5.0]], 10, &s);
        assert_eq!((m.x, m.evals), (vec![5.0, 5.0], 1), "a 0-dimensional simplex is its point");
    }
}
