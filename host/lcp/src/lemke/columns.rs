//! The lazily updated columns of the dictionary: pivots record their pivot column (an eta)
//! and update `b`; a column applies the etas it has not seen when it is next read.
//!
//! Lemke reads one column per pivot (the entering one), so updating all `n + 1` columns at
//! every pivot, as a dense tableau does, mostly computes entries nobody reads. Here a pivot
//! costs `O(n)` and a read costs `O(n)` per pending eta. The update of one entry is the dense
//! pivot's own arithmetic (`x += T[i][c] · (−T[r][j] / T[r][c])`), so the numbers, and with
//! them every pivot choice, are bit-identical to updating the whole tableau.

use super::{Tableau, UNLOADED, eta_capacity};

impl Tableau {
    /// Brings column slot `c` up to date, copying it from `M` (row-major `n × n`) first if it
    /// still holds an untouched `z` (or `z0`, all ones).
    pub(super) fn refresh(&mut self, c: usize, m: &[f64]) {
        let n = self.n;
        debug_assert!(c < self.width, "parked columns are never read");
        let col = &mut self.cols[c * n..(c + 1) * n];
        let mut ver = self.ver[c];
        if ver == UNLOADED {
            let var = self.nonbasic[c];
            debug_assert!(var >= n, "only z columns start unloaded");
            if var == 2 * n {
                col.fill(1.0);
            } else {
                for (x, row) in col.iter_mut().zip(m.chunks_exact(n.max(1))) {
                    *x = row[var - n];
                }
            }
            ver = 0;
        }
        let etas = self.etas[ver * n..self.neta * n].chunks_exact(n.max(1));
        let rows_invs = self.eta_row[ver..self.neta].iter().zip(&self.eta_inv[ver..self.neta]);
        for (eta, (&r, &inv)) in etas.zip(rows_invs) {
            let xr = col[r];
            if xr != 0.0 {
                let g = -xr * inv;
                for (x, &e) in col.iter_mut().zip(eta) {
                    *x += e * g;
                }
                col[r] = g;
            }
        }
        self.ver[c] = self.neta;
    }

    /// Exchanges the basic variable of row `r` with the nonbasic one of column `c`: records
    /// the eta, updates `b`, and gives slot `c` the leaving variable's (up-to-date) column.
    pub(super) fn pivot(&mut self, r: usize, c: usize, m: &[f64]) {
        let n = self.n;
        if self.neta == eta_capacity(n) {
            self.flush(m);
        }
        self.refresh(c, m);
        let k = self.neta;
        let col = &mut self.cols[c * n..(c + 1) * n];
        let inv = 1.0 / col[r];
        let eta = &mut self.etas[k * n..(k + 1) * n];
        eta.copy_from_slice(col);
        (self.eta_row[k], self.eta_inv[k]) = (r, inv);
        self.neta = k + 1;
        let br = -self.b[r] * inv;
        for (bi, &e) in self.b[..n].iter_mut().zip(eta.iter()) {
            *bi += e * br;
        }
        self.b[r] = br;
        for (x, &e) in col.iter_mut().zip(eta.iter()) {
            *x = e * inv;
        }
        col[r] = inv;
        self.ver[c] = self.neta;
        let (vin, vout) = (self.nonbasic[c], self.basic[r]);
        self.basic[r] = vin;
        self.nonbasic[c] = vout;
        self.is_basic[vin] = true;
        self.slot[vin] = r;
        self.is_basic[vout] = false;
        self.slot[vout] = c;
    }

    /// Applies the whole eta file to every live column and empties it.
    fn flush(&mut self, m: &[f64]) {
        for c in 0..self.width {
            self.refresh(c, m);
        }
        self.neta = 0;
        self.ver[..self.width].fill(0);
    }

    /// Swaps two nonbasic column slots (values, labels and versions).
    pub(super) fn swap_columns(&mut self, a: usize, b: usize) {
        let n = self.n;
        let (lo, hi) = (a.min(b), a.max(b));
        let (head, tail) = self.cols.split_at_mut(hi * n);
        head[lo * n..(lo + 1) * n].swap_with_slice(&mut tail[..n]);
        self.ver.swap(a, b);
        self.nonbasic.swap(a, b);
        self.slot[self.nonbasic[a]] = a;
        self.slot[self.nonbasic[b]] = b;
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Tableau, eta_capacity};
    use crate::MlcpProblem;
    use rand::{RngExt, SeedableRng};

    /// The dense reference: one full tableau pivot (`t` row-major `n × (n + 1)`).
    fn dense_pivot(t: &mut [f64], b: &mut [f64], n: usize, r: usize, c: usize) {
        let s = n + 1;
        let inv = 1.0 / t[r * s + c];
        let mut prow: Vec<f64> = t[r * s..(r + 1) * s].iter().map(|v| -v * inv).collect();
        prow[c] = inv;
        let br = -b[r] * inv;
        for i in (0..n).filter(|&i| i != r) {
            let f = t[i * s + c];
            t[i * s + c] = 0.0;
            for j in 0..s {
                t[i * s + j] += f * prow[j];
            }
            b[i] += f * br;
        }
        t[r * s..(r + 1) * s].copy_from_slice(&prow);
        b[r] = br;
    }

    #[test]
    fn lazy_columns_match_dense_pivots_bit_for_bit_across_flushes() {
        let n = 5;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let m: Vec<f64> = (0..n * n).map(|_| rng.random_range(-2.0..2.0)).collect();
        let q: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
        let mut tab = Tableau::with_capacity(n);
        assert!(tab.load(&MlcpProblem { n_free: 0, n, m: &m, q: &q }, 1e-11));
        let s = n + 1;
        let mut t = vec![1.0; n * s];
        for i in 0..n {
            t[i * s..i * s + n].copy_from_slice(&m[i * n..(i + 1) * n]);
        }
        let mut b = q.clone();
        let pivots = 3 * eta_capacity(n);
        for k in 0..pivots {
            // A well-conditioned pivot: the largest entry of a pseudo-random column.
            let c = (k * 3 + 1) % s;
            let r = (0..n).max_by(|&x, &y| t[x * s + c].abs().total_cmp(&t[y * s + c].abs()));
            let r = r.unwrap();
            dense_pivot(&mut t, &mut b, n, r, c);
            tab.pivot(r, c, &m);
            // Read only some columns now, so that others lag behind by several etas.
            if k % 4 == 0 {
                tab.refresh((k + 2) % s, &m);
            }
        }
        assert!(tab.neta < pivots, "the eta file was flushed");
        assert_eq!(tab.b[..n], b[..]);
        for c in 0..s {
            tab.refresh(c, &m);
            for i in 0..n {
                assert_eq!(tab.cols[c * n + i], t[i * s + c], "T[{i}][{c}]");
            }
        }
    }
}
