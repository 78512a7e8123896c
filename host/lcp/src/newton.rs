//! Fallback for problems too large to enumerate: semismooth Newton on the Fischer–Burmeister
//! reformulation, whose answer only counts once an active-set solve reproduces and verifies
//! it.
//!
//! `Φ(z) = [w_free ; φ(zᵢ, wᵢ)]`, `φ(a, b) = √(a² + b²) − a − b` (zero exactly when
//! `a, b ≥ 0` and `ab = 0`), `w = M z + q`. Each iteration solves `J d = −Φ` with an element
//! of the generalised Jacobian (LU), then backtracks on `½‖Φ‖²`; when the Newton direction is
//! unusable it takes the steepest-descent step `−JᵀΦ`. From the final iterate the active
//! set `{i : zᵢ > wᵢ}` is read and handed back for the exact solve. A run stops early when
//! ten iterations fail to halve the merit (no answer near: typically a jammed step).

use super::MlcpProblem;
use super::dense::lu_solve;

/// Workspace; buffers sized on first use and reused.
#[derive(Debug, Default)]
pub(crate) struct FbNewton {
    jac: Vec<f64>,
    lu: Vec<f64>,
    phi: Vec<f64>,
    step: Vec<f64>,
    w: Vec<f64>,
    trial: Vec<f64>,
}

impl FbNewton {
    /// Runs up to `iterations` Newton steps from `z` (updated in place). Returns `true` and
    /// fills `active` when `‖Φ‖∞` fell below `tol` times the problem scale.
    pub(crate) fn run(
        &mut self,
        p: &MlcpProblem<'_>,
        z: &mut [f64],
        active: &mut [bool],
        iterations: usize,
        tol: f64,
    ) -> bool {
        let n = p.n;
        for v in [&mut self.phi, &mut self.step, &mut self.w, &mut self.trial] {
            v.resize(n, 0.0);
        }
        self.jac.resize(n * n, 0.0);
        self.lu.resize(n * n, 0.0);
        let scale = p.q.iter().chain(p.m).fold(1e-300f64, |a, v| a.max(v.abs()));
        let mut merit = self.residual(p, z);
        let mut checkpoint = merit;
        for k in 0..iterations {
            // Give up on stagnation: less than a halving of the merit in 10 iterations.
            if k > 0 && k % 10 == 0 {
                if merit > 0.5 * checkpoint {
                    return false;
                }
                checkpoint = merit;
            }
            if self.phi.iter().fold(0.0f64, |a, v| a.max(v.abs())) <= tol * scale {
                for i in 0..n {
                    active[i] = i < p.n_free || z[i] > self.w[i];
                }
                return true;
            }
            self.jacobian(p, z);
            let newton = self.newton_direction(n);
            let Some(next) = self.line_search(p, z, merit, newton) else {
                return false;
            };
            merit = next;
        }
        false
    }

    /// `Φ(z)` into `phi` (and `w`); returns `½‖Φ‖²`.
    fn residual(&mut self, p: &MlcpProblem<'_>, z: &[f64]) -> f64 {
        let n = p.n;
        let mut merit = 0.0;
        for i in 0..n {
            let row = &p.m[i * n..(i + 1) * n];
            let wi = p.q[i] + row.iter().zip(z).map(|(a, b)| a * b).sum::<f64>();
            self.w[i] = wi;
            let f = if i < p.n_free { wi } else { z[i].hypot(wi) - z[i] - wi };
            self.phi[i] = f;
            merit += 0.5 * f * f;
        }
        merit
    }

    /// An element of the generalised Jacobian of `Φ` at `z` (uses `w` from `residual`).
    fn jacobian(&mut self, p: &MlcpProblem<'_>, z: &[f64]) {
        let n = p.n;
        for i in 0..n {
            let row = &p.m[i * n..(i + 1) * n];
            let jrow = &mut self.jac[i * n..(i + 1) * n];
            if i < p.n_free {
                jrow.copy_from_slice(row);
                continue;
            }
            let r = z[i].hypot(self.w[i]);
            let (da, db) = if r > 0.0 {
                (z[i] / r - 1.0, self.w[i] / r - 1.0)
            } else {
                (std::f64::consts::FRAC_1_SQRT_2 - 1.0, std::f64::consts::FRAC_1_SQRT_2 - 1.0)
            };
            for (jv, mv) in jrow.iter_mut().zip(row) {
                *jv = db * mv;
            }
            jrow[i] += da;
        }
    }

    /// Solves `J d = −Φ` into `step`; on a singular `J` falls back to `d = −JᵀΦ`. Returns
    /// whether `step` is a Newton direction.
    fn newton_direction(&mut self, n: usize) -> bool {
        self.lu[..n * n].copy_from_slice(&self.jac[..n * n]);
        for (s, f) in self.step.iter_mut().zip(&self.phi) {
            *s = -f;
        }
        if lu_solve(&mut self.lu, n, &mut self.step, 1e-13)
            && self.step.iter().all(|v| v.is_finite())
        {
            return true;
        }
        self.gradient_direction(n);
        false
    }

    fn gradient_direction(&mut self, n: usize) {
        self.step[..n].fill(0.0);
        for i in 0..n {
            for j in 0..n {
                self.step[j] -= self.jac[i * n + j] * self.phi[i];
            }
        }
    }

    /// Armijo backtracking on `½‖Φ‖²` along `step` (then along `−JᵀΦ` if the Newton step
    /// finds no decrease). Returns the new merit, or `None` when no step decreases it.
    fn line_search(
        &mut self,
        p: &MlcpProblem<'_>,
        z: &mut [f64],
        merit: f64,
        newton: bool,
    ) -> Option<f64> {
        let n = p.n;
        for pass in 0..2 {
            if pass == 1 {
                if !newton {
                    break;
                }
                self.residual(p, z);
                self.gradient_direction(n);
            }
            let mut t = 1.0;
            for _ in 0..40 {
                for ((x, zi), d) in self.trial.iter_mut().zip(&z[..n]).zip(&self.step) {
                    *x = zi + t * d;
                }
                let trial = std::mem::take(&mut self.trial);
                let m = self.residual(p, &trial);
                self.trial = trial;
                if m <= (1.0 - 1e-4 * t) * merit {
                    z[..n].copy_from_slice(&self.trial[..n]);
                    return Some(m);
                }
                t *= 0.5;
            }
        }
        self.residual(p, z);
        None
    }
}
