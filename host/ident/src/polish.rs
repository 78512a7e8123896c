//! The last stage of the joint fit: Levenberg–Marquardt on the residual vector (Δx, Δy, L·Δθ
//! of every scored pose of every trial), with a forward-difference Jacobian.
//!
//! The evolution strategy and the simplex find the right basin but crawl inside it: the
//! objective is a sum of thousands of squares, nearly quadratic near the truth, and a
//! Gauss–Newton step uses that shape where a simplex has to discover it. Each iteration
//! spends one evaluation per parameter on the Jacobian (in parallel) and then tries four
//! damping factors at once (in parallel), keeping the best step that lowers the total.
//! Deterministic: no random choice, results collected in index order.

use rayon::prelude::*;

/// A residual function: `None` for a parameter vector the model cannot simulate.
pub type Residuals<'a> = &'a (dyn Fn(&[f64]) -> Option<Vec<f64>> + Sync);

/// What [`levenberg_marquardt`] returns: best point, its sum of squares, evaluations used and
/// every evaluated point with its sum of squares.
pub type Polished = (Vec<f64>, f64, usize, Vec<(Vec<f64>, f64)>);

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
fn jacobian(f: Residuals<'_>, x: &[f64], r0: &[f64], h: &[f64]) -> Option<Vec<Vec<f64>>> {
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
/// about `budget` evaluations (an iteration costs `x0.len() + 4`).
pub fn levenberg_marquardt(f: Residuals<'_>, x0: &[f64], h: &[f64], budget: usize) -> Polished {
    let mut x = x0.to_vec();
    let mut r = f(&x);
    let mut fx = sse(&r);
    let mut evals = 1;
    let mut visited = vec![(x.clone(), fx)];
    let mut lambda = 1e-3;
    let p = x.len();
    while evals + p + 4 <= budget && fx.is_finite() && lambda < 1e8 {
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
        let lambdas = [lambda / 4.0, lambda, lambda * 4.0, lambda * 16.0];
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
                (x, fx, r, lambda) = (y, sse(&ry), ry, (l / 3.0).max(1e-9));
                if improvement < 1e-6 {
                    break;
                }
            }
            _ => lambda *= 64.0,
        }
    }
    (x, fx, evals, visited)
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
        let (x, fx, evals, _) = levenberg_marquardt(&f, &[1.0, 0.2, 0.0], &[1e-6; 3], 400);
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
