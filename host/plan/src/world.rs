//! The uncertain world a robust plan must work in: the nominal model, fixture and simulator
//! settings, and the uncertainty its Monte Carlo draws come from. The robust design, its
//! press start and its candidates' scoring all take one.

use crate::sampler::Uncertainty;
use mesopush_sim::support_set::SupportSample;
use mesopush_sim::{Fixture, Model, SimSettings};

/// The world a robust plan must work in: the nominal one and the uncertainty around it.
#[derive(Debug, Clone, Copy)]
pub struct UncertainWorld<'a> {
    /// Nominal model.
    pub model: &'a Model,
    /// Fixture.
    pub fixture: &'a Fixture,
    /// Simulator settings.
    pub settings: &'a SimSettings,
    /// Uncertainty around the nominal.
    pub uncertainty: Uncertainty,
    /// Candidate supports (empty: perturb the model's).
    pub supports: &'a [SupportSample],
}

impl<'a> UncertainWorld<'a> {
    /// The paper's uncertainty ([`Uncertainty::default`]) around `model`, its supports
    /// perturbed (no identified support set).
    pub fn nominal(model: &'a Model, fixture: &'a Fixture, settings: &'a SimSettings) -> Self {
        Self { model, fixture, settings, uncertainty: Uncertainty::default(), supports: &[] }
    }
}
