//! Helpers shared by the LCP integration tests: an independent answer check (not the
//! solver's own) and seeded random matrices.

#![allow(dead_code, unreachable_pub)]

use rand::{Rng, RngExt};

/// Independent check of `z` for the mixed LCP `(n_free, M, q)` (written apart from the
/// solver's): the largest of the equality residual, the sign violations and `|zᵢ wᵢ|`, with
/// `w` relative to the largest row magnitude `maxᵢ(|qᵢ| + Σⱼ |Mᵢⱼ zⱼ|)` and `z` to `‖z‖∞`.
pub fn residual(n_free: usize, m: &[f64], q: &[f64], z: &[f64]) -> f64 {
    let n = q.len();
    assert_eq!(z.len(), n);
    let zmax = z.iter().fold(1e-300f64, |a, v| a.max(v.abs()));
    let mut w = q.to_vec();
    let mut scale = 1e-300f64;
    for i in 0..n {
        let mut row = q[i].abs();
        for j in 0..n {
            w[i] += m[i * n + j] * z[j];
            row += (m[i * n + j] * z[j]).abs();
        }
        scale = scale.max(row);
    }
    let mut worst = 0.0f64;
    for i in 0..n {
        if i < n_free {
            worst = worst.max(w[i].abs() / scale);
        } else {
            let comp = (z[i] * w[i]).abs() / (zmax * scale);
            worst = worst.max(-z[i] / zmax).max(-w[i] / scale).max(comp);
        }
    }
    worst
}

/// A random `n × n` matrix with entries uniform in `[-1, 1)`, row-major.
pub fn random_matrix(rng: &mut impl Rng, n: usize) -> Vec<f64> {
    (0..n * n).map(|_| rng.random_range(-1.0..1.0)).collect()
}

/// `AᵀA + S` with `S` skew-symmetric: positive semidefinite, not symmetric; singular when
/// `rank < n`.
pub fn psd_matrix(rng: &mut impl Rng, n: usize, rank: usize) -> Vec<f64> {
    let a = (0..rank * n).map(|_| rng.random_range(-1.0..1.0)).collect::<Vec<f64>>();
    let s = random_matrix(rng, n);
    let mut m = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            let ata: f64 = (0..rank).map(|k| a[k * n + i] * a[k * n + j]).sum();
            m[i * n + j] = ata + 0.5 * (s[i * n + j] - s[j * n + i]);
        }
    }
    m
}

/// A P-matrix that is neither symmetric nor positive definite in general: a positive definite
/// matrix times a positive diagonal, `(AᵀA + εI + S) D`.
pub fn p_matrix(rng: &mut impl Rng, n: usize) -> Vec<f64> {
    let mut m = psd_matrix(rng, n, n);
    for i in 0..n {
        m[i * n + i] += 0.1;
    }
    let d: Vec<f64> = (0..n).map(|_| rng.random_range(0.2..5.0)).collect();
    for i in 0..n {
        for j in 0..n {
            m[i * n + j] *= d[j];
        }
    }
    m
}

/// A planted solution: `z*` and `w*` with complementary supports, some indices degenerate
/// (`zᵢ = wᵢ = 0`) when `degenerate`; returns `(z*, q = w* − M z*)`.
pub fn plant(rng: &mut impl Rng, m: &[f64], n: usize, degenerate: bool) -> (Vec<f64>, Vec<f64>) {
    let mut z = vec![0.0; n];
    let mut w = vec![0.0; n];
    for i in 0..n {
        let roll: f64 = rng.random_range(0.0..1.0);
        if degenerate && roll < 0.25 {
            continue;
        }
        if roll < 0.6 {
            z[i] = rng.random_range(0.1..2.0);
        } else {
            w[i] = rng.random_range(0.1..2.0);
        }
    }
    let q = (0..n).map(|i| w[i] - (0..n).map(|j| m[i * n + j] * z[j]).sum::<f64>()).collect();
    (z, q)
}
