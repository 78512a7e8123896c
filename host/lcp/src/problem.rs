//! The problem and settings types: plain data the caller fills, validated at the boundary.

use super::Error;

/// A mixed LCP: find `z` (length `n`) with `w = M z + q` such that
/// `w[i] = 0` for `i < n_free` (equalities, `z[i]` free) and
/// `0 ≤ z[i] ⊥ w[i] ≥ 0` for `i ≥ n_free`. A pure LCP has `n_free = 0`.
#[derive(Debug, Clone, Copy)]
pub struct MlcpProblem<'a> {
    /// Number of free variables (and equality rows); they come first.
    pub n_free: usize,
    /// Total number of variables.
    pub n: usize,
    /// `M`, `n × n`, row-major (`m[i * n + j]` is row `i`, column `j`).
    pub m: &'a [f64],
    /// `q`, length `n`.
    pub q: &'a [f64],
}

impl MlcpProblem<'_> {
    /// Number of complementarity variables, `n − n_free`.
    pub fn n_comp(&self) -> usize {
        self.n - self.n_free
    }

    /// Checks sizes and finiteness; the message names the first problem found.
    pub fn validate(&self) -> Result<(), Error> {
        self.validate_sizes()?;
        if let Some(k) = self.m.iter().position(|v| !v.is_finite()) {
            return Err(Error::BadInput(format!(
                "M[{}][{}] = {} is not finite",
                k / self.n,
                k % self.n,
                self.m[k]
            )));
        }
        if let Some(i) = self.q.iter().position(|v| !v.is_finite()) {
            return Err(Error::BadInput(format!("q[{i}] = {} is not finite", self.q[i])));
        }
        Ok(())
    }

    /// Checks the sizes only (`O(1)`); the solver checks finiteness while loading.
    pub fn validate_sizes(&self) -> Result<(), Error> {
        if self.n_free > self.n {
            return Err(Error::BadInput(format!(
                "n_free = {} exceeds n = {}",
                self.n_free, self.n
            )));
        }
        if self.m.len() != self.n * self.n {
            return Err(Error::BadInput(format!(
                "M has {} entries, expected n × n = {}",
                self.m.len(),
                self.n * self.n
            )));
        }
        if self.q.len() != self.n {
            return Err(Error::BadInput(format!(
                "q has {} entries, expected n = {}",
                self.q.len(),
                self.n
            )));
        }
        Ok(())
    }
}

/// Solver settings. Plain data; [`Default`] gives the documented defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LcpSettings {
    /// Most Lemke pivots per attempt (the free-variable block pivot is not counted).
    /// Default 10 000 (Murty's example needs `2ⁿ − 1`: raise it for n > 13).
    pub max_pivots: usize,
    /// Acceptance tolerance on every scaled residual (see [`crate::Residuals`]).
    /// Default `1e-9`.
    pub tol: f64,
    /// Relative pivot tolerance: a tableau entry counts as nonzero when larger than this times
    /// the largest entry of its column. Default `1e-11`.
    pub pivot_tol: f64,
    /// Largest number of complementarity variables for which the enumeration fallback runs
    /// (`2ⁿ` bases); `0` disables it. Default 16.
    pub enumerate_max_n: usize,
    /// Iterations of the Fischer–Burmeister Newton fallback, per start (two starts), for
    /// problems too large to enumerate; `0` disables it. Default 100.
    pub newton_iterations: usize,
    /// Extra Lemke attempts, each with another (deterministic) covering vector, when Lemke
    /// ends on a secondary ray, at the pivot limit or with an answer that fails verification.
    /// Default 8.
    pub retries: u32,
}

impl Default for LcpSettings {
    fn default() -> Self {
        LcpSettings {
            max_pivots: 10_000,
            tol: 1e-9,
            pivot_tol: 1e-11,
            enumerate_max_n: 16,
            retries: 8,
            newton_iterations: 100,
        }
    }
}

impl LcpSettings {
    /// Checks that the settings make sense (positive finite tolerances).
    pub fn validate(&self) -> Result<(), Error> {
        let ok = |v: f64| v.is_finite() && v > 0.0;
        if !ok(self.tol) {
            return Err(Error::BadInput(format!("tol = {} must be > 0", self.tol)));
        }
        if !ok(self.pivot_tol) {
            return Err(Error::BadInput(format!("pivot_tol = {} must be > 0", self.pivot_tol)));
        }
        if self.enumerate_max_n > 30 {
            return Err(Error::BadInput(format!(
                "enumerate_max_n = {} is too large (at most 30)",
                self.enumerate_max_n
            )));
        }
        Ok(())
    }
}
