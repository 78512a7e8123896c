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
/// A zero scale (e.g. `q = 0`, `z = 0`) counts as 1, so an exact zero stays zero. A
/// non-finite `z` or `w` gives an infinite `equality` residual.
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
    residuals(p, z, w, s_w)
}

/// [`check`] for a finite `M` (the solver's case, checked on entry): terms with `zⱼ = 0` are
/// skipped, which leaves every sum bit-identical (each lane adds the same nonzero terms in
/// the same order, and `x + 0 = x`) and saves most of the work when `z` is sparse.
pub(crate) fn check_finite(p: &MlcpProblem<'_>, z: &[f64], w: &mut [f64]) -> Residuals {
    let n = p.n;
    // Nonzero columns by lane (`j mod 4`, as in `dot_and_magnitude`), for n ≤ 64.
    let (mut lanes, mut len) = ([[0u8; 16]; 4], [0usize; 4]);
    let mut nnz = 0;
    for (j, &zj) in z[..n.min(64)].iter().enumerate() {
        if zj != 0.0 {
            lanes[j % 4][len[j % 4]] = j as u8;
            len[j % 4] += 1;
            nnz += 1;
        }
    }
    if n == 0 || n > 64 || 2 * nnz > n {
        return check(p, z, w);
    }
    let mut s_w = 0.0f64;
    for ((wi, row), &qi) in w.iter_mut().zip(p.m.chunks_exact(n)).zip(p.q) {
        let (mut acc, mut mag) = ([0.0f64; 4], [0.0f64; 4]);
        for l in 0..4 {
            for &j in &lanes[l][..len[l]] {
                let t = row[usize::from(j)] * z[usize::from(j)];
                acc[l] += t;
                mag[l] += t.abs();
            }
        }
        *wi = qi + ((acc[0] + acc[1]) + (acc[2] + acc[3]));
        s_w = s_w.max((mag[0] + mag[1]) + (mag[2] + mag[3])).max(qi.abs());
    }
    residuals(p, z, w, s_w)
}

/// The scaled residuals of `(z, w)` given the scale of `w`'s terms.
fn residuals(p: &MlcpProblem<'_>, z: &[f64], w: &[f64], s_w: f64) -> Residuals {
    let n = p.n;
    let s_z = z[..n].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let s_w = if s_w > 0.0 { s_w } else { 1.0 };
    let s_z = if s_z > 0.0 { s_z } else { 1.0 };
    let mut r = Residuals::default();
    if !(super::lemke::all_finite(&z[..n]) && super::lemke::all_finite(&w[..n])) {
        // `f64::max` would skip a NaN: an answer that is not finite fails outright.
        return Residuals { equality: f64::INFINITY, ..r };
    }
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

#[cfg(test)]
mod tests {
    use super::{check, check_finite};
    use crate::MlcpProblem;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn skipping_zero_terms_is_bit_identical_and_nan_answers_fail() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for n in [0, 1, 7, 34, 70] {
            let m: Vec<f64> = (0..n * n).map(|_| rng.random_range(-1e3..1e3)).collect();
            let q: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
            let p = MlcpProblem { n_free: n / 4, n, m: &m, q: &q };
            for density in [0.0, 0.2, 0.45, 1.0] {
                let z: Vec<f64> = (0..n)
                    .map(
                        |_| if rng.random_bool(density) { rng.random_range(0.0..5.0) } else { 0.0 },
                    )
                    .collect();
                let (mut w1, mut w2) = (vec![0.0; n], vec![0.0; n]);
                let (r1, r2) = (check(&p, &z, &mut w1), check_finite(&p, &z, &mut w2));
                assert_eq!(r1, r2, "n {n}, density {density}");
                let bits = |w: &[f64]| w.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&w1), bits(&w2), "n {n}, density {density}");
            }
            if n > 0 {
                let mut z = vec![0.0; n];
                z[n - 1] = f64::NAN;
                let mut w = vec![0.0; n];
                assert_eq!(check_finite(&p, &z, &mut w).max(), f64::INFINITY);
            }
        }
    }
}
