//! `diagnose`: closing the loop with measured data. Identify the nominal model on a training
//! split of the trials, compute the held-out residuals (peg pose and imaged probe tip, measured
//! minus simulated), analyse their structure, fit every effect of the library
//! ([`mesopush_sim::effects`]) together with the nominal parameters, and attribute the residual to
//! the effect that explains it on held-out trials — or say honestly that none does, or that
//! the residual is already at the measurement floor. `docs/diagnose.md` has the method.

pub mod adequacy;
pub mod attribute;
pub mod candidates;
pub mod data;
pub mod decide;
pub mod error;
pub mod fit;
pub mod patch;
pub mod predict;
pub mod report;
pub mod residual;
pub mod rig_batch;
pub mod starts;
pub mod structure;
pub mod synth;
pub mod tip;

pub use attribute::{Diagnosis, Options, Verdict, diagnose};
pub use candidates::Candidate;
pub use data::TrialData;
pub use error::Error;
