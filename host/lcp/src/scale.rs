//! Equilibration: an equivalent, better-scaled problem for when the caller's units make the
//! tableau's relative tolerances misjudge entries.
//!
//! For positive diagonal `R` (rows) and `C` (columns), `w̃ = R w`, `z = C z̃` turns
//! `w = M z + q` into `w̃ = (R M C) z̃ + R q` with the same complementarity pattern
//! (`z̃ᵢ w̃ᵢ = 0 ⇔ zᵢ wᵢ = 0`, signs kept, equality rows stay equalities). `R`, `C` come from
//! a few Ruiz passes (each divides rows and columns by the square root of their largest
//! entry) and are rounded to powers of two, so scaling itself adds no rounding error.

use super::MlcpProblem;

/// Scaled copy of a problem and its scales; buffers reused across solves.
#[derive(Debug, Default)]
pub(crate) struct Equilibration {
    m: Vec<f64>,
    q: Vec<f64>,
    row: Vec<f64>,
    /// Column scales: `z = col ∘ z̃`.
    pub(crate) col: Vec<f64>,
    rmax: Vec<f64>,
    cmax: Vec<f64>,
}

impl Equilibration {
    /// Computes the scales for `p` and the scaled copy.
    pub(crate) fn compute(&mut self, p: &MlcpProblem<'_>) {
        let n = p.n;
        for v in [&mut self.row, &mut self.col] {
            v.clear();
            v.resize(n, 1.0);
        }
        self.rmax.resize(n, 0.0);
        self.cmax.resize(n, 0.0);
        for _ in 0..4 {
            self.rmax[..n].fill(0.0);
            self.cmax[..n].fill(0.0);
            for i in 0..n {
                for j in 0..n {
                    let a = (self.row[i] * p.m[i * n + j] * self.col[j]).abs();
                    self.rmax[i] = self.rmax[i].max(a);
                    self.cmax[j] = self.cmax[j].max(a);
                }
            }
            for i in 0..n {
                if self.rmax[i] > 0.0 {
                    self.row[i] /= self.rmax[i].sqrt();
                }
                if self.cmax[i] > 0.0 {
                    self.col[i] /= self.cmax[i].sqrt();
                }
            }
        }
        for s in self.row.iter_mut().chain(self.col.iter_mut()) {
            *s = s.log2().round().exp2();
        }
        self.m.resize(n * n, 0.0);
        self.q.resize(n, 0.0);
        for i in 0..n {
            for j in 0..n {
                self.m[i * n + j] = self.row[i] * p.m[i * n + j] * self.col[j];
            }
            self.q[i] = self.row[i] * p.q[i];
        }
    }

    /// The scaled problem (valid after [`Self::compute`] on `p`).
    pub(crate) fn problem(&self, p: &MlcpProblem<'_>) -> MlcpProblem<'_> {
        MlcpProblem { n_free: p.n_free, n: p.n, m: &self.m[..p.n * p.n], q: &self.q[..p.n] }
    }
}

#[cfg(test)]
mod tests {
    use super::Equilibration;
    use crate::MlcpProblem;

    #[test]
    fn scales_are_powers_of_two_and_balance_a_badly_scaled_matrix() {
        let m = [1e6, 2e6, 3.0, 1e-6];
        let q = [1.0, 1.0];
        let mut e = Equilibration::default();
        let p = MlcpProblem { n_free: 0, n: 2, m: &m, q: &q };
        e.compute(&p);
        for s in e.row.iter().chain(&e.col) {
            assert_eq!(s.log2().fract(), 0.0, "{s}");
        }
        let sp = e.problem(&p);
        let big = sp.m.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!((0.5..=4.0).contains(&big), "largest scaled entry {big}");
        // Row 1 keeps its exact value relation: row × M × col.
        assert_eq!(sp.m[2], e.row[1] * 3.0 * e.col[0]);
    }
}
