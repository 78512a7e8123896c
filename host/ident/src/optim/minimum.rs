//! What every minimiser of [`super`] returns, so callers read one shape whatever ran.

/// The outcome of a minimisation.
#[derive(Debug, Clone, PartialEq)]
pub struct Minimum {
    /// The best point found.
    pub x: Vec<f64>,
    /// Its objective value.
    pub value: f64,
    /// Objective evaluations used.
    pub evals: usize,
    /// Evaluated points with their values, in evaluation order (the evolution strategy and
    /// Levenberg–Marquardt record theirs; Nelder–Mead leaves this empty — a caller that wants
    /// its points records them in the objective).
    pub visited: Vec<(Vec<f64>, f64)>,
}
