//! The block pivot that makes the free variables basic before Lemke starts.
//!
//! The free–free block of the simulator's `M` is zero, so a free variable cannot pivot in on
//! its own equality row. Instead: (A) every equality slack leaves the basis for some `z`
//! (largest available pivot, full pivoting), then (B) every free variable still nonbasic
//! enters where both members of a complementary pair became basic, which restores
//! complementarity. Afterwards the free variables stay basic and the equality slacks stay
//! nonbasic at zero for good; their columns are parked at the end and no longer updated.

use super::Tableau;

impl Tableau {
    /// Largest `|T[r][c]|` over rows whose basic variable passes `row_ok` and columns whose
    /// nonbasic variable passes `col_ok` (few rows qualify: they are gathered first).
    fn best_pivot(
        &mut self,
        row_ok: impl Fn(&Self, usize) -> bool,
        col_ok: impl Fn(usize) -> bool,
    ) -> Option<(usize, usize, f64)> {
        let s = self.n + 1;
        self.cand.clear();
        for r in 0..self.n {
            if row_ok(self, self.basic[r]) {
                self.cand.push(r);
            }
        }
        let (mut best, mut best_a) = (None, -1.0);
        for c in 0..self.n {
            if !col_ok(self.nonbasic[c]) {
                continue;
            }
            for &r in &self.cand {
                let a = self.t[r * s + c].abs();
                if a > best_a {
                    (best, best_a) = (Some((r, c)), a);
                }
            }
        }
        best.map(|(r, c)| (r, c, best_a))
    }

    /// Block-pivots the free variables into the basis and the equality slacks out, keeping
    /// one variable of every complementary pair basic. Returns the pivots spent, or `None`
    /// when the free block is singular.
    pub(crate) fn make_free_basic(&mut self) -> Option<usize> {
        let (n, nf) = (self.n, self.nf);
        // Scale of the coupling blocks (free rows and free columns of M, still untouched).
        let s = n + 1;
        let mut scale = f64::MIN_POSITIVE;
        for i in 0..n {
            let row = &self.t[i * s..i * s + n];
            let part = if i < nf { row } else { &row[..nf] };
            for v in part {
                scale = if v.abs() > scale { v.abs() } else { scale };
            }
        }
        let tiny = self.pivot_tol * scale;
        let mut pivots = 0;
        // A: every equality slack w_i (i < nf) leaves, for any z.
        for _ in 0..nf {
            let (r, c, a) = self.best_pivot(|_, v| v < nf, |v| v >= n && v < 2 * n)?;
            if a <= tiny {
                return None;
            }
            self.pivot(r, c, usize::MAX);
            pivots += 1;
        }
        // B: free z still nonbasic enter where both of a pair are basic.
        loop {
            let both = |t: &Self, v: usize| v >= nf && v < n && t.is_basic[v + n];
            let Some((r, c, a)) = self.best_pivot(both, |v| v >= n && v < n + nf) else {
                break;
            };
            if a <= tiny {
                return None;
            }
            self.pivot(r, c, usize::MAX);
            pivots += 1;
        }
        if (n..n + nf).any(|v| !self.is_basic[v]) {
            return None;
        }
        for r in 0..n {
            let v = self.basic[r];
            self.free_row[r] = v >= n && v < n + nf;
            self.comp_mask[r] = if self.free_row[r] { 0.0 } else { 1.0 };
        }
        // The equality slacks stay nonbasic at zero for good: park their columns at the end
        // and stop updating them.
        for k in 0..nf {
            let target = n - k;
            if self.slot[k] != target {
                self.swap_columns(self.slot[k], target);
            }
        }
        self.width = n + 1 - nf;
        Some(pivots)
    }

    /// Swaps two nonbasic columns (values and labels).
    fn swap_columns(&mut self, a: usize, b: usize) {
        let s = self.n + 1;
        for row in self.t[..self.n * s].chunks_exact_mut(s) {
            row.swap(a, b);
        }
        self.nonbasic.swap(a, b);
        self.slot[self.nonbasic[a]] = a;
        self.slot[self.nonbasic[b]] = b;
    }
}
