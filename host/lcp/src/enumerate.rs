//! Fallback: enumeration of complementary bases for small problems.
//!
//! For every subset `α` of the complementarity indices, solve `w_i = 0` on the free indices and
//! `α`, `z_i = 0` elsewhere, and keep the first answer that passes verification. `2ⁿ` linear
//! solves, so only for small `n` (see [`super::LcpSettings::enumerate_max_n`]); it finds a
//! solution whenever one exists at a vertex with a nonsingular basis, which is where Lemke's
//! secondary ray (e.g. bimatrix games, CPS 4.4.23) leaves us.

use super::MlcpProblem;
use super::dense::SetSolve;
use super::verify::{self, Residuals};

/// Outcome of an enumeration.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Enumerated {
    /// Residuals of the verified answer left in `z`/`w`, if one was found.
    pub(crate) found: Option<Residuals>,
    /// Bases tried.
    pub(crate) bases: usize,
}

/// Tries every complementary basis; on success `z`, `w` hold the verified answer.
pub(crate) fn enumerate(
    p: &MlcpProblem<'_>,
    tol: f64,
    ws: &mut SetSolve,
    in_set: &mut [bool],
    z: &mut [f64],
    w: &mut [f64],
) -> Enumerated {
    let (nf, nc) = (p.n_free, p.n_comp());
    debug_assert!(nc < 31);
    let mut bases = 0;
    for mask in 0u32..(1u32 << nc) {
        bases += 1;
        in_set[..nf].fill(true);
        for (j, flag) in in_set[nf..p.n].iter_mut().enumerate() {
            *flag = mask & (1 << j) != 0;
        }
        if !ws.solve(p, in_set, z) {
            continue;
        }
        for zi in &mut z[nf..p.n] {
            *zi = zi.max(0.0);
        }
        let r = verify::check(p, z, w);
        if r.max() <= tol {
            return Enumerated { found: Some(r), bases };
        }
    }
    Enumerated { found: None, bases }
}
