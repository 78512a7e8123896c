//! Lexicographic Lemke (complementary pivoting) on a dense dictionary, with free variables.
//! The dictionary's columns are updated lazily (see `columns`): a pivot touches `b` and
//! records its pivot column, and only the columns Lemke reads are brought up to date.
//!
//! The dictionary is `x_B = b + T x_N` with `n` basic variables (rows) and `n + 1` nonbasic
//! ones (columns). Variables are numbered `w_i = i`, `z_i = n + i`, the artificial `z0 = 2n`.
//! Before Lemke, [`Tableau::make_free_basic`] block-pivots every free `z_i` (`i < n_free`) into
//! the basis and every equality slack `w_i` out; those never move again, so Lemke runs on the
//! reduced problem. Degeneracy is resolved lexicographically relative to the basis at Lemke's
//! start (which makes the rule valid for the reduced problem, too), with priority to `z0`.
//! Everything lives in buffers sized once; a solve allocates nothing.

use super::MlcpProblem;

mod columns;
mod free_block;

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

/// The dictionary, stored by columns and brought up to date lazily, and all of Lemke's
/// workspaces.
///
/// Column slot `j` holds `T[·][j]` (`n` entries, contiguous) as of `ver[j]` pivots of the
/// current eta file; a pivot only updates `b` and records its pivot column (the eta), and a
/// column is brought up to date ([`Tableau::refresh`]) when a ratio test needs it. Columns of
/// `z` not yet touched are copied from `M` on first use. Each update applies exactly the
/// arithmetic of a full tableau pivot, so the results are bit-identical to one.
#[derive(Debug, Default)]
pub(crate) struct Tableau {
    n: usize,
    nf: usize,
    /// Column-major `T`, `n + 1` slots of `n` entries.
    cols: Vec<f64>,
    /// Eta-file pivots applied to each slot, or [`UNLOADED`].
    ver: Vec<usize>,
    /// Pivot columns (before their pivot), `n` entries each, oldest first.
    etas: Vec<f64>,
    eta_row: Vec<usize>,
    eta_inv: Vec<f64>,
    /// Pivots in the eta file; at capacity it is flushed into every column.
    neta: usize,
    /// The equality rows of `T` during the free block pivot (row-major, `n + 1` wide).
    eq_rows: Vec<f64>,
    b: Vec<f64>,
    basic: Vec<usize>,
    nonbasic: Vec<usize>,
    is_basic: Vec<bool>,
    slot: Vec<usize>,
    free_row: Vec<bool>,
    comp_mask: Vec<f64>,
    acol: Vec<f64>,
    width: usize,
    col_max: f64,
    b_max: f64,
    lex: Vec<usize>,
    cand: Vec<usize>,
    pivot_tol: f64,
}

/// `ver` of a slot whose column has not been copied from `M` yet.
const UNLOADED: usize = usize::MAX;

impl Tableau {
    /// Sizes every buffer for problems up to `cap` variables.
    pub(crate) fn with_capacity(cap: usize) -> Self {
        let mut tab = Tableau::default();
        tab.reserve(cap);
        tab
    }

    /// Grows the buffers (only allocates when `cap` exceeds what they hold).
    pub(crate) fn reserve(&mut self, cap: usize) {
        self.cols.resize(cap * (cap + 1), 0.0);
        self.ver.resize(cap + 1, UNLOADED);
        self.etas.resize(cap * eta_capacity(cap), 0.0);
        self.eta_row.resize(eta_capacity(cap), 0);
        self.eta_inv.resize(eta_capacity(cap), 0.0);
        self.eq_rows.resize(cap * (cap + 1), 0.0);
        self.b.resize(cap, 0.0);
        self.basic.resize(cap, 0);
        self.nonbasic.resize(cap + 1, 0);
        self.is_basic.resize(2 * cap + 1, false);
        self.slot.resize(2 * cap + 1, 0);
        self.free_row.resize(cap, false);
        self.acol.resize(cap, 0.0);
        self.comp_mask.resize(cap, 1.0);
        self.lex.reserve(cap.saturating_sub(self.lex.capacity()));
        self.cand.reserve(cap.saturating_sub(self.cand.capacity()));
    }

    /// Starts `w = q + M z + d z0` with every `w` basic (the columns of `M` are copied when
    /// first needed). Returns `false` if `M` or `q` holds a non-finite value.
    pub(crate) fn load(&mut self, p: &MlcpProblem<'_>, pivot_tol: f64) -> bool {
        let n = p.n;
        self.reserve(n);
        self.n = n;
        self.nf = p.n_free;
        self.pivot_tol = pivot_tol;
        self.width = n + 1;
        self.neta = 0;
        self.b[..n].copy_from_slice(p.q);
        for i in 0..n {
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
        self.ver[..=n].fill(UNLOADED);
        all_finite(p.m) && all_finite(p.q)
    }

    /// Runs lexicographic Lemke from the current (complementary) basis on the problem whose
    /// `M` (row-major `n × n`) was loaded. Returns how it ended and the pivots spent.
    pub(crate) fn lemke(
        &mut self,
        m: &[f64],
        max_pivots: usize,
        cover: Cover,
    ) -> (LemkeEnd, usize) {
        let n = self.n;
        let z0_col = self.slot[2 * n];
        self.lex.clear();
        let mut most_neg: Option<usize> = None;
        let mut k = 0;
        let d = &mut self.cols[z0_col * n..(z0_col + 1) * n];
        for r in 0..n {
            if self.free_row[r] {
                d[r] = 0.0;
                continue;
            }
            d[r] = match cover {
                Cover::Ones => 1.0,
                Cover::Spread(attempt) => spread_entry(attempt, k),
            };
            k += 1;
            self.lex.push(self.basic[r]);
            let ratio = self.b[r] / d[r];
            // Ties go to the later row: that keeps the rows lexicographically positive.
            if ratio < 0.0 && most_neg.is_none_or(|m| ratio <= self.b[m] / d[m]) {
                most_neg = Some(r);
            }
        }
        self.ver[z0_col] = self.neta;
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
            // The next entering variable is the complement of the one leaving now.
            let next = match leaving {
                v if v == 2 * n => usize::MAX,
                v if v < n => self.slot[v + n],
                v => self.slot[v - n],
            };
            self.pivot(r, c, m);
            pivots += 1;
            if leaving == 2 * n {
                return (LemkeEnd::Solved, pivots);
            }
            c = next;
            match self.leaving_row(c, m) {
                Some(row) => r = row,
                None => return (LemkeEnd::Ray, pivots),
            }
        }
    }

    /// Brings column `c` up to date and copies `−T[·][c]` (zero on free rows) into `acol`,
    /// with the largest `|acol|` and the largest `|b|` over the complementarity rows, for the
    /// next ratio test.
    fn gather_column(&mut self, c: usize, m: &[f64]) {
        let n = self.n;
        self.refresh(c, m);
        let (mut col_max, mut b_max) = (0.0f64, 0.0f64);
        let col = &self.cols[c * n..(c + 1) * n];
        let rows = self.acol[..n].iter_mut().zip(col).zip(&self.comp_mask[..n]).zip(&self.b[..n]);
        for (((dst, &t), &mask), &b) in rows {
            let a = -t * mask;
            *dst = a;
            let (a, b) = (a.abs(), b.abs() * mask);
            col_max = if a > col_max { a } else { col_max };
            b_max = if b > b_max { b } else { b_max };
        }
        (self.col_max, self.b_max) = (col_max, b_max);
    }

    /// The lexicographic minimum-ratio row for entering column `c`, `z0` first among ties.
    /// One pass keeps every row that ties with the best ratio so far (up to rounding noise in
    /// `b`); a short filter then keeps those that tie with the final one.
    fn leaving_row(&mut self, c: usize, m: &[f64]) -> Option<usize> {
        self.gather_column(c, m);
        let n = self.n;
        let eps = self.pivot_tol * self.col_max;
        let tol_b = 1e-11 * self.b_max;
        let (mut best_b, mut best_a, mut theta) = (f64::INFINITY, 1.0, f64::INFINITY);
        self.cand.clear();
        for (i, (&a, &b)) in self.acol[..n].iter().zip(&self.b[..n]).enumerate() {
            if a <= eps {
                continue;
            }
            let b = b.max(0.0);
            if b * best_a < best_b * a {
                (best_b, best_a) = (b, a);
                theta = b / a;
            }
            if b - theta * a <= tol_b {
                self.cand.push(i);
            }
        }
        if theta == f64::INFINITY {
            return None;
        }
        let (acol, b) = (&self.acol, &self.b);
        self.cand.retain(|&i| b[i].max(0.0) - theta * acol[i] <= tol_b);
        if self.cand.len() > 1 {
            if let Some(&i) = self.cand.iter().find(|&&i| self.basic[i] == 2 * n) {
                return Some(i);
            }
            self.lex_break(c, m);
        }
        self.cand.first().copied()
    }

    /// The `B⁻¹` entry (row `i`, column of the `k`-th starting basic variable) over the pivot
    /// entry of row `i` in column `c` (both columns up to date).
    fn lex_value(&self, k: usize, i: usize, c: usize) -> f64 {
        let n = self.n;
        let v = self.lex[k];
        let e = if self.is_basic[v] {
            if self.slot[v] == i { 1.0 } else { 0.0 }
        } else {
            -self.cols[self.slot[v] * n + i]
        };
        e / -self.cols[c * n + i]
    }

    /// Narrows `cand` to the lexicographic minimum of `B⁻¹` rows over the pivot entries.
    /// Entries that are zero in exact arithmetic carry rounding noise, so "equal" means
    /// within `1e-10` of the largest such ratio over all candidates and columns.
    fn lex_break(&mut self, c: usize, m: &[f64]) {
        let mut scale = 0.0f64;
        for k in 0..self.lex.len() {
            let v = self.lex[k];
            if !self.is_basic[v] {
                self.refresh(self.slot[v], m);
            }
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

/// Eta-file capacity for problems of `n` variables: past it, the file is flushed.
fn eta_capacity(n: usize) -> usize {
    n + 8
}

/// `v * 0` is NaN exactly when `v` is not finite; four independent lanes let the compiler
/// vectorise the check (a single running sum could not be reordered).
pub(crate) fn all_finite(values: &[f64]) -> bool {
    let mut lanes = [0.0f64; 4];
    let chunks = values.chunks_exact(4);
    let tail = chunks.remainder();
    for ch in chunks {
        for (l, v) in lanes.iter_mut().zip(ch) {
            *l += v * 0.0;
        }
    }
    for (l, v) in lanes.iter_mut().zip(tail) {
        *l += v * 0.0;
    }
    lanes == [0.0; 4]
}

/// Entry `k` of retry `attempt`'s covering vector. Kept out of line so the compiler does not
/// evaluate it speculatively for the all-ones vector.
#[inline(never)]
fn spread_entry(attempt: u32, k: usize) -> f64 {
    // splitmix64 of (attempt, k): deterministic, platform-independent.
    let mut x = (u64::from(attempt) << 32 | k as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^= x >> 31;
    let u = (x >> 11) as f64 / (1u64 << 53) as f64;
    (0.05f64.ln() + u * 400f64.ln()).exp()
}
