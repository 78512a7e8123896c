//! Levenberg–Marquardt on a residual vector, with a forward-difference Jacobian.
//!
//! For objectives that are a sum of many squares: an evolution strategy or a simplex finds the
//! right basin but crawls inside it, while near the optimum such a sum is nearly quadratic and
//! a Gauss–Newton step uses that shape where a simplex has to discover it. Each iteration
//! spends one evaluation per parameter on the Jacobian (in parallel) and then tries every
//! damping factor of [`LmSettings::damping`] at once (in parallel), keeping the best step that
//! lowers the total. Deterministic: no random choice, results collected in index order.

use super::Minimum;
use rayon::prelude::*;

/// A residual function: `None` for a parameter vector the model cannot simulate.
pub type ResidualFn<'a> = &'a (dyn Fn(&[f64]) -> Option<Vec<f64>> + Sync);

/// The damping schedule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmSettings {
    /// Initial damping λ (Marquardt's, relative to the diagonal of JᵀJ). Default 1e-3.
    pub lambda0: f64,
    /// The dampings tried in each iteration, as multiples of the current λ. Default
    /// [1/4, 1, 4, 16].
    pub damping: [f64; 4],
    /// After an accepted step λ becomes the accepted damping divided by this. Default 3.
    pub accept_divisor: f64,
    /// The smallest λ after an accepted step. Default 1e-9.
    pub lambda_min: f64,
    /// After an iteration without improvement λ is multiplied by this. Default 64.
    pub reject_factor: f64,
    /// The run ends when λ reaches this. Default 1e8.
    pub lambda_max: f64,
    /// The run ends after an accepted step that lowers the sum of squares by less than this
    /// fraction. Default 1e-6.
    pub min_improvement: f64,
}

impl LmSettings {
    /// The documented defaults.
    pub const DEFAULT: Self = Self {
        lambda0: 1e-3,
        damping: [0.25, 1.0, 4.0, 16.0],
        accept_divisor: 3.0,
        lambda_min: 1e-9,
        reject_factor: 64.0,
        lambda_max: 1e8,
        min_improvement: 1e-6,
    };
}

impl Default for LmSettings {
    fn default() -> Self {
        Self::DEFAULT
    }
}

fn sse(r: &Option<Vec<f64>>) -> f64 {
    r.as_ref().map_or(f64::INFINITY, |r| r.iter().map(|v| v * v).sum())
}

/// Solves `a x = b` (n × n, row-major) by Gaussian elimination with partial pivoting;
/// `None` when singular.
pub fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for c in 0..n {
        let p = (c..n).max_by(|i, j| a[*i][c].abs().total_cmp(&a[*j][c].abs()))?;
        if a[p][c].abs() < 1e-300 {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        let pivot = a[c].clone();
        for r in c + 1..n {
            let f = a[r][c] / pivot[c];
            a[r][c..].iter_mut().zip(&pivot[c..]).for_each(|(x, p)| *x -= f * p);
            b[r] -= f * b[c];
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    Some(x)
}

/// Jacobian columns by forward differences (backward where the forward point fails).
fn jacobian(f: ResidualFn<'_>, x: &[f64], r0: &[f64], h: &[f64]) -> Option<Vec<Vec<f64>>> {
    let cols: Vec<Option<Vec<f64>>> = (0..x.len())
        .into_par_iter()
        .map(|i| {
            let at = |s: f64| {
                let mut y = x.to_vec();
                y[i] += s * h[i];
                f(&y).filter(|r| r.len() == r0.len())
            };
            let (r, s) = match at(1.0) {
                Some(r) => (r, 1.0),
                None => (at(-1.0)?, -1.0),
            };
            Some(r.iter().zip(r0).map(|(a, b)| (a - b) / (s * h[i])).collect())
        })
        .collect();
    cols.into_iter().collect()
}

/// The damped Gauss–Newton step for damping `lambda` (Marquardt's diagonal scaling).
fn step(jtj: &[Vec<f64>], jtr: &[f64], lambda: f64) -> Option<Vec<f64>> {
    let n = jtr.len();
    let mut a = jtj.to_vec();
    for (i, row) in a.iter_mut().enumerate() {
        row[i] += lambda * jtj[i][i].max(1e-12);
    }
    solve(a, jtr.iter().map(|g| -g).collect::<Vec<_>>()).filter(|d| d.len() == n)
}

/// Minimises the sum of squares of `f` from `x0` with finite-difference steps `h`; at most
/// about `budget` evaluations (an iteration costs `x0.len()` + the number of dampings).
pub fn levenberg_marquardt(
    f: ResidualFn<'_>,
    x0: &[f64],
    h: &[f64],
    budget: usize,
    s: &LmSettings,
) -> Minimum {
    let mut x = x0.to_vec();
    let mut r = f(&x);
    let mut fx = sse(&r);
    let mut evals = 1;
    let mut visited = vec![(x.clone(), fx)];
    let mut lambda = s.lambda0;
    let p = x.len();
    while evals + p + s.damping.len() <= budget && fx.is_finite() && lambda < s.lambda_max {
        let r0 = r.clone().unwrap_or_default();
        let Some(cols) = jacobian(f, &x, &r0, h) else { break };
        evals += p;
        let jtj: Vec<Vec<f64>> = (0..p)
            .map(|i| {
                (0..p).map(|k| cols[i].iter().zip(&cols[k]).map(|(a, b)| a * b).sum()).collect()
            })
            .collect();
        let jtr: Vec<f64> =
            cols.iter().map(|c| c.iter().zip(&r0).map(|(a, b)| a * b).sum()).collect();
        let lambdas = s.damping.map(|d| lambda * d);
        let tries: Vec<(f64, Vec<f64>, Option<Vec<f64>>)> = lambdas
            .par_iter()
            .filter_map(|&l| {
                let d = step(&jtj, &jtr, l)?;
                let y: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a + b).collect();
                let ry = f(&y);
                Some((l, y, ry))
            })
            .collect();
        evals += lambdas.len();
        visited.extend(tries.iter().map(|(_, y, ry)| (y.clone(), sse(ry))));
        let best = tries.into_iter().min_by(|a, b| sse(&a.2).total_cmp(&sse(&b.2)));
        match best {
            Some((l, y, ry)) if sse(&ry) < fx => {
                let improvement = (fx - sse(&ry)) / fx;
                (x, fx, r, lambda) = (y, sse(&ry), ry, (l / s.accept_divisor).max(s.lambda_min));
                if improvement < s.min_improvement {
                    break;
                }
            }
            _ => lambda *= s.reject_factor,
        }
    }
    Minimum { x, value: fx, evals, visited }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_a_nonlinear_least_squares_problem() {
        // Exponential decay y = a·exp(−b t) + c sampled without noise: the optimum is exact.
        let ts: Vec<f64> = (0..30).map(|i| i as f64 * 0.2).collect();
        let truth = [2.0, 0.7, 0.3];
        let f = |x: &[f64]| -> Option<Vec<f64>> {
            let m = |p: &[f64], t: f64| p[0] * (-p[1] * t).exp() + p[2];
            Some(ts.iter().map(|t| m(x, *t) - m(&truth, *t)).collect())
        };
        let m = levenberg_marquardt(&f, &[1.0, 0.2, 0.0], &[1e-6; 3], 400, &LmSettings::DEFAULT);
        let (x, fx, evals) = (m.x, m.value, m.evals);
        assert!(fx < 1e-12, "{x:?} {fx} after {evals} evaluations");
        assert!(x.iter().zip(truth).all(|(a, b)| (a - b).abs() < 1e-5), "{x:?}");
        assert!(evals <= 400);
    }

    #[test]
    fn solve_handles_pivoting_and_reports_singular() {
        let x = solve(vec![vec![0.0, 2.0], vec![3.0, 1.0]], vec![4.0, 5.0]).unwrap();
        assert!((x[0] - 1.0).abs() < 1e-12 && (x[1] - 2.0).abs() < 1e-12, "{x:?}");
        assert!(solve(vec![vec![1.0, 2.0], vec![2.0, 4.0]], vec![1.0, 2.0]).is_none());
    }
}
