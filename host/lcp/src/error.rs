//! The lcp crate's one error: the typed ways a complementarity solve can fail (never a silent
//! wrong answer), and problem files that cannot be read.

use std::path::PathBuf;

/// Why [`crate::LcpSolver::solve`] returned no solution, or a problem file was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The problem data is malformed (sizes, non-finite values); names what is wrong.
    #[error("bad LCP input: {0}")]
    BadInput(String),
    /// The equality rows cannot be used to make the free variables basic: the free block has
    /// rank below `n_free` (e.g. contact wrenches that do not span the plane).
    #[error("the {n_free} equality rows are singular (rank-deficient free block)")]
    SingularEqualities {
        /// Number of free variables.
        n_free: usize,
    },
    /// Lemke ended on a secondary ray (also after the retries), the problem is too large for
    /// the enumeration fallback and the Newton fallback found no verified answer.
    #[error("Lemke ended on a secondary ray after {pivots} pivots; no fallback for n = {n}")]
    SecondaryRay {
        /// Pivots spent (all attempts).
        pivots: usize,
        /// Number of complementarity variables.
        n: usize,
    },
    /// Lemke reached `max_pivots`, the problem is too large for the enumeration fallback and
    /// the Newton fallback found no verified answer.
    #[error("pivot limit reached after {pivots} pivots; no fallback for n = {n}")]
    PivotLimit {
        /// Pivots spent (all attempts).
        pivots: usize,
        /// Number of complementarity variables.
        n: usize,
    },
    /// Every method available for this size ran (Lemke, its retries, full enumeration of the
    /// complementary bases) and none produced a verified solution.
    #[error("no solution found: Lemke ({pivots} pivots) and enumeration of {bases} bases")]
    NoSolutionFound {
        /// Lemke pivots spent.
        pivots: usize,
        /// Complementary bases enumerated.
        bases: usize,
    },
    /// Lemke terminated with a complementary basis but its answer (also after polishing) fails
    /// the residual check, and no fallback produced a verified one.
    #[error("answer failed verification: residual {residual:.3e} > tolerance {tol:.1e}")]
    VerificationFailed {
        /// Largest scaled residual of the best candidate.
        residual: f64,
        /// The tolerance it had to meet.
        tol: f64,
    },
    /// A problem file could not be read.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error, as text (the enum stays `Clone`).
        message: String,
    },
    /// A problem file is not a Siconos (M)LCP file this reader accepts; names what is wrong.
    #[error("{path}: {message}")]
    Format {
        /// The file (empty when parsing text).
        path: PathBuf,
        /// What is wrong, naming the field and the value.
        message: String,
    },
}

impl Error {
    /// Lemke pivots spent before giving up, when the failure came from pivoting.
    pub fn pivots(&self) -> Option<usize> {
        match self {
            Error::SecondaryRay { pivots, .. }
            | Error::PivotLimit { pivots, .. }
            | Error::NoSolutionFound { pivots, .. } => Some(*pivots),
            _ => None,
        }
    }

    /// The best residual reached, for [`Error::VerificationFailed`].
    pub fn residual(&self) -> Option<f64> {
        match self {
            Error::VerificationFailed { residual, .. } => Some(*residual),
            _ => None,
        }
    }

    /// A short snake_case name for status fields (`--json` output, logs).
    pub fn status_name(&self) -> &'static str {
        match self {
            Error::BadInput(_) => "bad_input",
            Error::SingularEqualities { .. } => "singular_equalities",
            Error::SecondaryRay { .. } => "secondary_ray",
            Error::PivotLimit { .. } => "pivot_limit",
            Error::NoSolutionFound { .. } => "no_solution_found",
            Error::VerificationFailed { .. } => "verification_failed",
            Error::Io { .. } => "io",
            Error::Format { .. } => "format",
        }
    }
}
