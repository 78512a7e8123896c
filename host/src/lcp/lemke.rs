//! Lexicographic Lemke (complementary pivoting) on a dense dictionary, with free variables.
//!
//! The dictionary is `x_B = b + T x_N` with `n` basic variables (rows) and `n + 1` nonbasic
//! ones (columns). Variables are numbered `w_i = i`, `z_i = n + i`, the artificial `z0 = 2n`.
//! Before Lemke, [`Tableau::make_free_basic`] block-pivots every free `z_i` (`i < n_free`) into
//! the basis and every equality slack `w_i` out; those never move again, so Lemke runs on the
//! reduced problem. Degeneracy is resolved lexicographically relative to the basis at Lemke's
//! start (which makes the rule valid for the reduced problem, too), with priority to `z0`.
//! Everything lives in buffers sized once; a solve allocates nothing.

use super::MlcpProblem;

/// How a Lemke run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum LemkeEnd {
    /// `z0` left the basis (or was never needed): the basis is complementary and feasible.
    Solved,
    /// The entering column has no blocking row: a secondary ray.
    Ray,
    /// The pivot limit was reached.
    Limit,
}

/// The covering vector `d` of the artificial variable, in the coordinates of the basis at
/// Lemke's start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Cover {
    /// `d = (1, …, 1)`: the classic choice.
    Ones,
    /// Retry `k`: a deterministic pseudo-random positive vector with entries spread over
    /// `[0.05, 20]`; another `d` is another Lemke path (equivalent to rescaling the problem).
    Spread(u32),
}

/// The dense dictionary and all of Lemke's workspaces.
#[derive(Debug, Default)]
pub(crate) struct Tableau {
    n: usize,
    nf: usize,
    t: Vec<f64>,
    b: Vec<f64>,
    prow: Vec<f64>,
    basic: Vec<usize>,
    nonbasic: Vec<usize>,
    is_basic: Vec<bool>,
    slot: Vec<usize>,
    free_row: Vec<bool>,
    comp_rows: Vec<usize>,
    acol: Vec<f64>,
    width: usize,
    lex: Vec<usize>,
    cand: Vec<usize>,
    nz: Vec<usize>,
    pivot_tol: f64,
}

impl Tableau {
    /// Sizes every buffer for problems up to `cap` variables.
    pub(crate) fn with_capacity(cap: usize) -> Self {
        let mut tab = Tableau::default();
        tab.reserve(cap);
        tab
    }

    /// Grows the buffers (only allocates when `cap` exceeds what they hold).
    pub(crate) fn reserve(&mut self, cap: usize) {
        self.t.resize(cap * (cap + 1), 0.0);
        self.b.resize(cap, 0.0);
        self.prow.resize(cap + 1, 0.0);
        self.basic.resize(cap, 0);
        self.nonbasic.resize(cap + 1, 0);
        self.is_basic.resize(2 * cap + 1, false);
        self.slot.resize(2 * cap + 1, 0);
        self.free_row.resize(cap, false);
        self.acol.resize(cap, 0.0);
        self.comp_rows.reserve(cap.saturating_sub(self.comp_rows.capacity()));
        self.lex.reserve(cap.saturating_sub(self.lex.capacity()));
        self.cand.reserve(cap.saturating_sub(self.cand.capacity()));
        self.nz.reserve((cap + 1).saturating_sub(self.nz.capacity()));
    }

    /// Loads `w = q + M z + d z0` with every `w` basic.
    pub(crate) fn load(&mut self, p: &MlcpProblem<'_>, pivot_tol: f64) {
        let n = p.n;
        self.reserve(n);
        self.n = n;
        self.nf = p.n_free;
        self.pivot_tol = pivot_tol;
        let s = n + 1;
        self.width = s;
        for i in 0..n {
            let row = &mut self.t[i * s..(i + 1) * s];
            row[..n].copy_from_slice(&p.m[i * n..(i + 1) * n]);
            row[n] = 1.0;
            self.b[i] = p.q[i];
            self.basic[i] = i;
            self.is_basic[i] = true;
            self.slot[i] = i;
            self.free_row[i] = false;
        }
        for j in 0..=n {
            self.nonbasic[j] = n + j;
            self.is_basic[n + j] = false;
            self.slot[n + j] = j;
        }
    }

    /// Exchanges the basic variable of row `r` with the nonbasic one of column `c`.
    /// Step problems are sparse, so rows are updated only at the pivot row's nonzeros when
    /// there are few of them.
    fn pivot(&mut self, r: usize, c: usize) {
        let (s, width) = (self.n + 1, self.width);
        debug_assert!(c < width);
        let inv = 1.0 / self.t[r * s + c];
        let prow = &mut self.prow[..width];
        self.nz.clear();
        for (j, (dst, src)) in prow.iter_mut().zip(&self.t[r * s..r * s + width]).enumerate() {
            *dst = -src * inv;
            if *src != 0.0 {
                self.nz.push(j);
            }
        }
        prow[c] = inv;
        let sparse = self.nz.len() * 2 < width;
        let br = -self.b[r] * inv;
        for (i, row) in self.t[..self.n * s].chunks_exact_mut(s).enumerate() {
            let row = &mut row[..width];
            if i == r {
                row.copy_from_slice(prow);
                continue;
            }
            let f = row[c];
            if f == 0.0 {
                continue;
            }
            row[c] = 0.0;
            if sparse {
                for &j in &self.nz {
                    row[j] += f * prow[j];
                }
            } else {
                for (x, pv) in row.iter_mut().zip(prow.iter()) {
                    *x += f * pv;
                }
            }
            self.b[i] += f * br;
        }
        self.b[r] = br;
        let (vin, vout) = (self.nonbasic[c], self.basic[r]);
        self.basic[r] = vin;
        self.nonbasic[c] = vout;
        self.is_basic[vin] = true;
        self.slot[vin] = r;
        self.is_basic[vout] = false;
        self.slot[vout] = c;
    }

    /// Largest `|T[r][c]|` over rows whose basic variable passes `row_ok` and columns whose
    /// nonbasic variable passes `col_ok`.
    fn best_pivot(
        &self,
        row_ok: impl Fn(usize) -> bool,
        col_ok: impl Fn(usize) -> bool,
    ) -> Option<(usize, usize, f64)> {
        let s = self.n + 1;
        let mut best: Option<(usize, usize, f64)> = None;
        for r in (0..self.n).filter(|&r| row_ok(self.basic[r])) {
            for c in (0..self.n).filter(|&c| col_ok(self.nonbasic[c])) {
                let a = self.t[r * s + c].abs();
                if best.is_none_or(|(_, _, m)| a > m) {
                    best = Some((r, c, a));
                }
            }
        }
        best
    }

    /// Block-pivots the free variables into the basis and the equality slacks out, keeping
    /// one variable of every complementary pair basic. Returns the pivots spent, or `None`
    /// when the free block is singular.
    pub(crate) fn make_free_basic(&mut self) -> Option<usize> {
        let (n, nf) = (self.n, self.nf);
        let scale =
            self.t.chunks_exact(n + 1).take(n).flatten().fold(0.0f64, |a, v| a.max(v.abs()));
        let tiny = self.pivot_tol * scale.max(f64::MIN_POSITIVE);
        let mut pivots = 0;
        // A: every equality slack w_i (i < nf) leaves, for any z.
        for _ in 0..nf {
            let (r, c, a) = self.best_pivot(|v| v < nf, |v| v >= n && v < 2 * n)?;
            if a <= tiny {
                return None;
            }
            self.pivot(r, c);
            pivots += 1;
        }
        // B: free z still nonbasic enter where both of a pair are basic.
        loop {
            let both = |v: usize| v >= nf && v < n && self.is_basic[v + n];
            let Some((r, c, a)) = self.best_pivot(both, |v| v >= n && v < n + nf) else {
                break;
            };
            if a <= tiny {
                return None;
            }
            self.pivot(r, c);
            pivots += 1;
        }
        if (n..n + nf).any(|v| !self.is_basic[v]) {
            return None;
        }
        self.comp_rows.clear();
        for r in 0..n {
            let v = self.basic[r];
            self.free_row[r] = v >= n && v < n + nf;
            if !self.free_row[r] {
                self.comp_rows.push(r);
            }
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

    /// Runs lexicographic Lemke from the current (complementary) basis. Returns how it ended
    /// and the pivots spent.
    pub(crate) fn lemke(&mut self, max_pivots: usize, cover: Cover) -> (LemkeEnd, usize) {
        let (n, s) = (self.n, self.n + 1);
        let z0_col = self.slot[2 * n];
        self.lex.clear();
        let mut most_neg: Option<usize> = None;
        let mut k = 0;
        for r in 0..n {
            self.t[r * s + z0_col] = if self.free_row[r] { 0.0 } else { cover_entry(cover, k) };
            if self.free_row[r] {
                continue;
            }
            k += 1;
            self.lex.push(self.basic[r]);
            let ratio = self.b[r] / self.t[r * s + z0_col];
            // Ties go to the later row: that keeps the rows lexicographically positive.
            if ratio < 0.0 && most_neg.is_none_or(|m| ratio <= self.b[m] / self.t[m * s + z0_col]) {
                most_neg = Some(r);
            }
        }
        let Some(mut r) = most_neg else {
            return (LemkeEnd::Solved, 0);
        };
        let mut c = z0_col;
        let mut pivots = 0;
        loop {
            if pivots >= max_pivots {
                return (LemkeEnd::Limit, pivots);
            }
            let leaving = self.basic[r];
            self.pivot(r, c);
            pivots += 1;
            if leaving == 2 * n {
                return (LemkeEnd::Solved, pivots);
            }
            let entering = if leaving < n { leaving + n } else { leaving - n };
            c = self.slot[entering];
            match self.leaving_row(c) {
                Some(row) => r = row,
                None => return (LemkeEnd::Ray, pivots),
            }
        }
    }

    /// The lexicographic minimum-ratio row for entering column `c`, `z0` first among ties.
    fn leaving_row(&mut self, c: usize) -> Option<usize> {
        let s = self.n + 1;
        let (mut col_max, mut b_max) = (0.0f64, 0.0f64);
        for (k, &i) in self.comp_rows.iter().enumerate() {
            let a = -self.t[i * s + c];
            self.acol[k] = a;
            col_max = if a.abs() > col_max { a.abs() } else { col_max };
            b_max = if self.b[i].abs() > b_max { self.b[i].abs() } else { b_max };
        }
        let eps = self.pivot_tol * col_max;
        // Minimum ratio b/a over a > eps, compared by cross-multiplication (no division).
        let (mut best_b, mut best_a) = (f64::INFINITY, 1.0);
        for (k, &i) in self.comp_rows.iter().enumerate() {
            let (a, b) = (self.acol[k], self.b[i].max(0.0));
            if a > eps && b * best_a < best_b * a {
                (best_b, best_a) = (b, a);
            }
        }
        if best_b == f64::INFINITY {
            return None;
        }
        let theta = best_b / best_a;
        // Rows whose ratio ties with `theta` up to rounding noise in `b`.
        let tol_b = 1e-11 * b_max;
        self.cand.clear();
        for (k, &i) in self.comp_rows.iter().enumerate() {
            let a = self.acol[k];
            if a > eps && self.b[i].max(0.0) - theta * a <= tol_b {
                self.cand.push(i);
            }
        }
        if self.cand.len() > 1 {
            if let Some(&i) = self.cand.iter().find(|&&i| self.basic[i] == 2 * self.n) {
                return Some(i);
            }
            self.lex_break(c);
        }
        self.cand.first().copied()
    }

    /// The `B⁻¹` entry (row `i`, column of the `k`-th starting basic variable) over the pivot
    /// entry of row `i` in column `c`.
    fn lex_value(&self, k: usize, i: usize, c: usize) -> f64 {
        let s = self.n + 1;
        let v = self.lex[k];
        let e = if self.is_basic[v] {
            if self.slot[v] == i { 1.0 } else { 0.0 }
        } else {
            -self.t[i * s + self.slot[v]]
        };
        e / -self.t[i * s + c]
    }

    /// Narrows `cand` to the lexicographic minimum of `B⁻¹` rows over the pivot entries.
    /// Entries that are zero in exact arithmetic carry rounding noise, so "equal" means
    /// within `1e-10` of the largest such ratio over all candidates and columns.
    fn lex_break(&mut self, c: usize) {
        let mut scale = 0.0f64;
        for k in 0..self.lex.len() {
            for &i in &self.cand {
                scale = scale.max(self.lex_value(k, i, c).abs());
            }
        }
        let tie = 1e-10 * scale;
        for k in 0..self.lex.len() {
            let best = self.cand.iter().fold(f64::INFINITY, |m, &i| m.min(self.lex_value(k, i, c)));
            let mut keep = 0;
            for j in 0..self.cand.len() {
                let i = self.cand[j];
                if self.lex_value(k, i, c) <= best + tie {
                    self.cand[keep] = i;
                    keep += 1;
                }
            }
            self.cand.truncate(keep);
            if keep <= 1 {
                return;
            }
        }
    }

    /// Writes the basic values into `z` (length `n`); nonbasic entries are zero.
    pub(crate) fn extract_z(&self, z: &mut [f64]) {
        let n = self.n;
        for (j, zj) in z.iter_mut().enumerate().take(n) {
            let v = n + j;
            *zj = if self.is_basic[v] { self.b[self.slot[v]] } else { 0.0 };
        }
    }

    /// Marks, for every variable index, whether `z_i` is basic (its active set).
    pub(crate) fn active_set(&self, active: &mut [bool]) {
        for (j, a) in active.iter_mut().enumerate().take(self.n) {
            *a = self.is_basic[self.n + j];
        }
    }
}

/// Entry `k` of the covering vector.
fn cover_entry(cover: Cover, k: usize) -> f64 {
    match cover {
        Cover::Ones => 1.0,
        Cover::Spread(attempt) => {
            // splitmix64 of (attempt, k): deterministic, platform-independent.
            let mut x = (u64::from(attempt) << 32 | k as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
            x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            x ^= x >> 31;
            let u = (x >> 11) as f64 / (1u64 << 53) as f64;
            (0.05f64.ln() + u * 400f64.ln()).exp()
        }
    }
}
