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
    /// Largest `|T[r][c]|` over the rows in `cand` and the columns whose nonbasic variable
    /// passes `col_ok`; `row_major` reads the equality rows kept in `eq_rows`, otherwise the
    /// (refreshed) columns are read.
    fn best_pivot(
        &mut self,
        m: &[f64],
        row_major: bool,
        col_ok: impl Fn(usize) -> bool,
    ) -> Option<(usize, usize, f64)> {
        let (n, s) = (self.n, self.n + 1);
        let (mut best, mut best_a) = (None, -1.0);
        for c in 0..n {
            if !col_ok(self.nonbasic[c]) {
                continue;
            }
            if !row_major {
                self.refresh(c, m);
            }
            for &r in &self.cand {
                let t = if row_major { self.eq_rows[r * s + c] } else { self.cols[c * n + r] };
                if t.abs() > best_a {
                    (best, best_a) = (Some((r, c)), t.abs());
                }
            }
        }
        best.map(|(r, c)| (r, c, best_a))
    }

    /// Phase A's view of a pivot on `(r, c)`: the dense pivot's update of the other equality
    /// rows still basic (`cand`), which phase A reads row by row.
    fn pivot_eq_rows(&mut self, r: usize, c: usize) {
        let s = self.n + 1;
        let (width, inv) = (self.width, 1.0 / self.eq_rows[r * s + c]);
        for k in 0..self.cand.len() {
            let i = self.cand[k];
            if i == r {
                continue;
            }
            let f = self.eq_rows[i * s + c];
            if f == 0.0 {
                continue;
            }
            let (lo, hi) = (i.min(r), i.max(r));
            let (head, tail) = self.eq_rows.split_at_mut(hi * s);
            let (lo_row, hi_row) = (&mut head[lo * s..lo * s + width], &mut tail[..width]);
            let (row, prow) = if i < r { (lo_row, hi_row) } else { (hi_row, lo_row) };
            for (x, p) in row.iter_mut().zip(prow.iter()) {
                *x += f * (-p * inv);
            }
            row[c] = f * inv;
        }
    }

    /// Block-pivots the free variables into the basis and the equality slacks out, keeping
    /// one variable of every complementary pair basic, on the loaded problem with matrix `m`.
    /// Returns the pivots spent, or `None` when the free block is singular.
    pub(crate) fn make_free_basic(&mut self, m: &[f64]) -> Option<usize> {
        let (n, nf) = (self.n, self.nf);
        // Scale of the coupling blocks (free rows and free columns of M).
        let mut scale = f64::MIN_POSITIVE;
        for (i, row) in m.chunks_exact(n.max(1)).enumerate() {
            let part = if i < nf { row } else { &row[..nf] };
            for v in part {
                scale = if v.abs() > scale { v.abs() } else { scale };
            }
        }
        let tiny = self.pivot_tol * scale;
        let mut pivots = 0;
        // A: every equality slack w_i (i < nf) leaves, for any z. Its rows are still those of
        // M (plus the z0 column of ones), updated here as phase A pivots.
        let s = n + 1;
        for (i, row) in m.chunks_exact(n.max(1)).take(nf).enumerate() {
            self.eq_rows[i * s..i * s + n].copy_from_slice(row);
            self.eq_rows[i * s + n] = 1.0;
        }
        for _ in 0..nf {
            self.cand.clear();
            self.cand.extend((0..nf).filter(|&r| self.basic[r] < nf));
            let (r, c, a) = self.best_pivot(m, true, |v| v >= n && v < 2 * n)?;
            if a <= tiny {
                return None;
            }
            self.pivot_eq_rows(r, c);
            self.pivot(r, c, m);
            pivots += 1;
        }
        pivots += self.enter_free(m, tiny)?;
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

    /// Phase B: free `z` still nonbasic enter where both of a pair are basic. Returns the
    /// pivots spent, or `None` on a pivot below `tiny`.
    fn enter_free(&mut self, m: &[f64], tiny: f64) -> Option<usize> {
        let (n, nf) = (self.n, self.nf);
        let mut pivots = 0;
        loop {
            self.cand.clear();
            for r in 0..n {
                let v = self.basic[r];
                if v >= nf && v < n && self.is_basic[v + n] {
                    self.cand.push(r);
                }
            }
            let Some((r, c, a)) = self.best_pivot(m, false, |v| v >= n && v < n + nf) else {
                return Some(pivots);
            };
            if a <= tiny {
                return None;
            }
            self.pivot(r, c, m);
            pivots += 1;
        }
    }
}
