//! Verification of a candidate answer against the original data: every reported solution
//! passed through here.

use super::MlcpProblem;

/// Scaled residuals of an answer `z`, `w = M z + q`, all dimensionless.
///
/// With `s_w = max(‖q‖∞, maxᵢ Σⱼ |Mᵢⱼ zⱼ|)` (the size of the terms that make up `w`) and
/// `s_z = ‖z‖∞`:
/// - `equality = max_{i < n_free} |wᵢ| / s_w`,
/// - `feasibility = max(max_{i ≥ n_free} (−wᵢ)/s_w, max_{i ≥ n_free} (−zᵢ)/s_z, 0)`,
/// - `complementarity = max_{i ≥ n_free} |zᵢ wᵢ| / (s_z s_w)`.
///
/// A zero scale (e.g. `q = 0`, `z = 0`) counts as 1, so an exact zero stays zero.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Residuals {
    /// Equality rows.
    pub equality: f64,
    /// Sign constraints on `z` and `w` (complementarity part).
    pub feasibility: f64,
    /// `zᵢ wᵢ` products.
    pub complementarity: f64,
}

impl Residuals {
    /// The largest of the three.
    pub fn max(&self) -> f64 {
        self.equality.max(self.feasibility).max(self.complementarity)
    }
}

/// Computes `w = M z + q` into `w` and the scaled residuals of `(z, w)`.
pub fn check(p: &MlcpProblem<'_>, z: &[f64], w: &mut [f64]) -> Residuals {
    let n = p.n;
    let mut s_w = 0.0f64;
    for (i, wi) in w.iter_mut().enumerate().take(n) {
        let (acc, mag) = dot_and_magnitude(&p.m[i * n..(i + 1) * n], &z[..n]);
        *wi = p.q[i] + acc;
        s_w = s_w.max(mag).max(p.q[i].abs());
    }
    let s_z = z[..n].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let s_w = if s_w > 0.0 { s_w } else { 1.0 };
    let s_z = if s_z > 0.0 { s_z } else { 1.0 };
    let mut r = Residuals::default();
    for i in 0..n {
        if i < p.n_free {
            r.equality = r.equality.max(w[i].abs() / s_w);
        } else {
            r.feasibility = r.feasibility.max(-w[i] / s_w).max(-z[i] / s_z);
            r.complementarity = r.complementarity.max((z[i] * w[i]).abs() / (s_z * s_w));
        }
    }
    r
}

/// `(Σ aⱼ bⱼ, Σ |aⱼ bⱼ|)` in four independent lanes, so the compiler can vectorise it.
fn dot_and_magnitude(a: &[f64], b: &[f64]) -> (f64, f64) {
    let (mut acc, mut mag) = ([0.0f64; 4], [0.0f64; 4]);
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ta, tb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..4 {
            let t = x[l] * y[l];
            acc[l] += t;
            mag[l] += t.abs();
        }
    }
    for (l, (x, y)) in ta.iter().zip(tb).enumerate() {
        acc[l] += x * y;
        mag[l] += (x * y).abs();
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3]), (mag[0] + mag[1]) + (mag[2] + mag[3]))
}
