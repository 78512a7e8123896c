//! Mixed linear complementarity problems (MLCP) and our own solver for them.
//!
//! The quasi-static simulator (paper §II-A, Eq. 7–8) poses, at every time step, a mixed LCP:
//! find `z = [u | λ]` (`u` free, `λ ≥ 0`) with `w = M z + q` such that the first `n_free`
//! rows are equalities (`w_u = 0`) and the others are complementary (`w_λ ≥ 0 ⊥ λ ≥ 0`).
//! This module solves it without outside numerics:
//!
//! 1. a block pivot makes the free variables basic (they never leave again),
//! 2. lexicographic Lemke (complementary pivoting) on the rest, with a pivot limit,
//! 3. if Lemke ends on a secondary ray, at its pivot limit or with an answer that fails
//!    verification: a retry on an equilibrated (rescaled, equivalent) problem, retries with
//!    other covering vectors, then enumeration of complementary bases for small problems
//!    or, for larger ones, a Fischer–Burmeister Newton search whose active set is re-solved
//!    exactly,
//! 4. every candidate answer is verified against the original `M`, `q` and, when
//!    the tableau's accumulated rounding spoils it, polished by a direct solve on its active
//!    set. Only a verified answer is reported as solved; everything else is a typed
//!    [`Error`].
//!
//! Conventions: matrices are dense, row-major `n × n`; a pure LCP is `n_free = 0`. Units are
//! the caller's: the solver is scale-aware (residuals are relative, see [`Residuals`]).
//! [`siconos`] reads the dense Siconos `.dat` formats of the peer test suite; [`generate`]
//! builds seeded peg-pushing step problems for tests and benchmarks.
//!
//! Use one [`LcpSolver`] per thread and reuse it: its buffers are sized once, and a solve
//! allocates nothing unless `n` grows. For a sequence of similar problems (simulator steps),
//! [`LcpSolver::solve_warm`] with the previous [`LcpSolution::active`] is a verified shortcut.
//!
//! May depend on: nothing of mesopush (a leaf: numerics only).
//!
//! ```
//! use mesopush_lcp::{LcpSettings, LcpSolver, MlcpProblem};
//!
//! // One free variable u and one complementarity pair (zero free–free block, as in the
//! // simulator): 0 = λ − 1 (force balance), w = −u + λ ≥ 0 ⊥ λ ≥ 0. So λ = 1 and u = 1.
//! let m = [0.0, 1.0, -1.0, 1.0];
//! let q = [-1.0, 0.0];
//! let mut solver = LcpSolver::new(2, LcpSettings::default());
//! let sol = solver.solve(&MlcpProblem { n_free: 1, n: 2, m: &m, q: &q }).unwrap();
//! assert!((sol.z[0] - 1.0).abs() < 1e-12 && (sol.z[1] - 1.0).abs() < 1e-12);
//! assert!(sol.residuals.max() <= solver.settings().tol);
//! ```

mod dense;
mod enumerate;
mod error;
pub mod generate;
mod lemke;
mod newton;
mod problem;
mod scale;
pub mod siconos;
mod solver;
mod verify;

pub use error::Error;
pub use problem::{LcpSettings, MlcpProblem};
pub use solver::{LcpSolution, LcpSolver, SolveMethod};
pub use verify::{Residuals, check as check_solution};
