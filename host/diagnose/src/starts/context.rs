//! What every start search needs besides the trials: the base model, the simulator, the
//! measurement floor and a budget for the small fits some searches make.

use crate::residual::Noise;
use mesopush_sim::{Model, SimSettings};

/// What the signature-based starts need to fit the nominal model to one trial.
#[derive(Debug, Clone, Copy)]
pub struct StartContext<'a> {
    /// The base model the candidates apply their parameters to.
    pub base: &'a Model,
    /// Simulator settings.
    pub settings: &'a SimSettings,
    /// The measurement floor.
    pub noise: &'a Noise,
    /// Evaluations for each per-trial nominal fit.
    pub evals_per_trial: usize,
    /// The nominal parameters before the batch's nominal fit (μ_probe, mean surface μ): an
    /// effect the nominal fit absorbed into friction (an adhesive drag) is also searched
    /// from there.
    pub prior_mu: [f64; 2],
}
