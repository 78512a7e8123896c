//! A small dense LU solve (partial pivoting) on caller-owned buffers, for polishing answers on
//! their active set and for the enumeration fallback. No allocation.

use super::MlcpProblem;

/// Solves `A x = rhs` in place (`a` is `k × k` row-major and is destroyed, `rhs` becomes `x`).
/// Returns `false` when a pivot is below `rel_tol` times the largest entry of `A` (singular).
///
/// The simulator's step problems are mostly this small (its Newton iterations solve 3 to 7
/// unknowns, millions of times per diagnosis): each size up to 8 gets a copy compiled for
/// it, loops unrolled and index checks gone. Every copy is the same source, so it does the
/// same floating-point operations in the same order: the answers are bit-identical.
pub(crate) fn lu_solve(a: &mut [f64], k: usize, rhs: &mut [f64], rel_tol: f64) -> bool {
    match k {
        1 => lu_solve_sized(a, 1, rhs, rel_tol),
        2 => lu_solve_sized(a, 2, rhs, rel_tol),
        3 => lu_solve_sized(a, 3, rhs, rel_tol),
        4 => lu_solve_sized(a, 4, rhs, rel_tol),
        5 => lu_solve_sized(a, 5, rhs, rel_tol),
        6 => lu_solve_sized(a, 6, rhs, rel_tol),
        7 => lu_solve_sized(a, 7, rhs, rel_tol),
        8 => lu_solve_sized(a, 8, rhs, rel_tol),
        _ => lu_solve_sized(a, k, rhs, rel_tol),
    }
}

/// [`lu_solve`]'s body, inlined into each of its size cases so `k` is a constant there.
#[inline(always)]
fn lu_solve_sized(a: &mut [f64], k: usize, rhs: &mut [f64], rel_tol: f64) -> bool {
    debug_assert!(a.len() >= k * k && rhs.len() >= k);
    let scale = a[..k * k].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if k == 0 {
        return true;
    }
    let tiny = rel_tol * scale;
    if scale == 0.0 {
        return false;
    }
    for col in 0..k {
        let (mut p, mut best) = (col, a[col * k + col].abs());
        for r in col + 1..k {
            let v = a[r * k + col].abs();
            if v > best {
                (p, best) = (r, v);
            }
        }
        if best <= tiny {
            return false;
        }
        if p != col {
            for j in 0..k {
                a.swap(p * k + j, col * k + j);
            }
            rhs.swap(p, col);
        }
        let (top, bottom) = a.split_at_mut((col + 1) * k);
        let prow = &top[col * k..];
        let inv = 1.0 / prow[col];
        for (r, row) in bottom[..(k - col - 1) * k].chunks_exact_mut(k).enumerate() {
            let f = row[col] * inv;
            if f == 0.0 {
                continue;
            }
            for j in col..k {
                row[j] -= f * prow[j];
            }
            rhs[col + 1 + r] -= f * rhs[col];
        }
    }
    for col in (0..k).rev() {
        let mut s = rhs[col];
        for j in col + 1..k {
            s -= a[col * k + j] * rhs[j];
        }
        rhs[col] = s / a[col * k + col];
    }
    true
}

/// Workspace for solving `M[F,F] z_F = −q_F` on an index set `F` (free variables plus an
/// active set), the step that turns a complementary basis into an answer.
#[derive(Debug, Default)]
pub(crate) struct SetSolve {
    a: Vec<f64>,
    rhs: Vec<f64>,
    idx: Vec<usize>,
}

impl SetSolve {
    /// Grows the buffers for problems up to `cap` variables.
    pub(crate) fn reserve(&mut self, cap: usize) {
        self.a.resize(cap * cap, 0.0);
        self.rhs.resize(cap, 0.0);
        self.idx.reserve(cap.saturating_sub(self.idx.capacity()));
    }

    /// Writes into `z` the solution with `z_i = 0` off the set (`in_set[i]` false) and
    /// `w_i = 0` on it. Returns `false` when that system is singular.
    pub(crate) fn solve(&mut self, p: &MlcpProblem<'_>, in_set: &[bool], z: &mut [f64]) -> bool {
        let n = p.n;
        self.idx.clear();
        self.idx.extend((0..n).filter(|&i| in_set[i]));
        let k = self.idx.len();
        for (r, &i) in self.idx.iter().enumerate() {
            for (c, &j) in self.idx.iter().enumerate() {
                self.a[r * k + c] = p.m[i * n + j];
            }
            self.rhs[r] = -p.q[i];
        }
        if !lu_solve(&mut self.a, k, &mut self.rhs, 1e-13) {
            return false;
        }
        z[..n].fill(0.0);
        for (r, &i) in self.idx.iter().enumerate() {
            z[i] = self.rhs[r];
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::lu_solve;

    #[test]
    fn solves_a_permuted_system_and_flags_singular() {
        // Needs a row swap: the (0,0) entry is zero.
        let mut a = [0.0, 2.0, 1.0, 3.0, 1.0, 0.0, 1.0, 1.0, 1.0];
        let mut x = [5.0, 4.0, 6.0];
        assert!(lu_solve(&mut a, 3, &mut x, 1e-12));
        // A x = rhs with x = (1, 1, 4)? check by substitution.
        let a0 = [0.0, 2.0, 1.0, 3.0, 1.0, 0.0, 1.0, 1.0, 1.0];
        for (i, want) in [5.0, 4.0, 6.0].iter().enumerate() {
            let got: f64 = (0..3).map(|j| a0[i * 3 + j] * x[j]).sum();
            assert!((got - want).abs() < 1e-12, "row {i}: {got} vs {want}");
        }
        let mut s = [1.0, 2.0, 2.0, 4.0];
        let mut r = [1.0, 1.0];
        assert!(!lu_solve(&mut s, 2, &mut r, 1e-12));
    }
}
