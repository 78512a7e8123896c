//! `diagnose`: closing the loop with measured data. Identify the nominal model on a training
//! split of the trials, compute the held-out residuals (peg pose and imaged probe tip, measured
//! minus simulated), analyse their structure, fit every effect of the library
//! ([`mesopush_sim::effects`]) together with the nominal parameters, and attribute the residual to
//! the effect that explains it on held-out trials — or say honestly that none does, or that
//! the residual is already at the measurement floor. `docs/diagnose.md` has the method.
//!
//! Layers, bottom up: the trials ([`data`]), their prediction ([`predict`]) and residuals
//! ([`residual`], [`tip`], [`structure`]); the stage and camera effects on the free tip alone
//! ([`free_tip`]); the candidates ([`candidates`]), what the fits
//! minimise ([`objective`]) and the fitter ([`fit`], on the minimisers of
//! [`mesopush_ident::optim`]); where each search starts ([`starts`]); the verdict
//! ([`decide`], [`adequacy`]) and the whole diagnosis ([`attribute`], [`options`], [`polish`]); its report
//! ([`report`]). Batches to test it on: [`synth`] (synthetic, one undeclared effect),
//! [`rig_batch`] (through the whole simulated loop) and the experiment over both, [`confusion`].
//!
//! May depend on: `mesopush-core`, `mesopush-sim`, `mesopush-trial`, `mesopush-ident`,
//! `mesopush-rig` and `mesopush-plot` (its embedded font). Never on planning, batches or the command line.

pub mod adequacy;
pub mod attribute;
pub mod candidates;
pub mod confusion;
pub mod data;
pub mod decide;
pub mod effect_refit;
pub mod error;
pub mod figure;
pub mod fit;
pub mod free_support;
pub mod free_tip;
pub mod heldout;
pub mod memo;
pub mod nominal;
pub mod objective;
pub mod options;
pub mod polish;
pub mod predict;
pub mod replay;
pub mod report;
pub mod residual;
pub mod rig_batch;
pub mod start_pose;
pub mod starts;
pub mod structure;
pub mod synth;
pub mod tip;

pub use attribute::{Diagnosis, diagnose};
pub use candidates::Effect;
pub use data::TrialData;
pub use decide::{EffectScore, Verdict};
pub use error::Error;
pub use options::Options;
