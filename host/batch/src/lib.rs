//! Unattended trial batches (`mesopush batch`): many trials of a plan against a world, run
//! by a [`TrialRunner`] under a journal that survives being killed at any moment, with
//! per-trial timeouts, retries, sharding by trial index into independent processes, a merge
//! of shard outputs, and a report (success rate with its 95 % interval, failure reasons,
//! timing, figures). The engine knows trials only through the runner trait. One process
//! per batch directory (a kernel lock); every final record carries its trial directory's
//! checksum, and every reader verifies it and counts lost, damaged, duplicated and foreign
//! records. See `docs/batch.md`.
//!
//! May depend on: `mesopush-core`, `mesopush-sim`, `mesopush-vision`, `mesopush-trial`,
//! `mesopush-plot`, `mesopush-plan` and `mesopush-rig` (its runners drive the simulator or the
//! whole loop). Never on identification, diagnosis or the CLI.

pub mod check;
pub mod digest;
pub mod engine;
pub mod error;
pub mod factory;
pub mod figures;
pub mod integrity;
pub mod journal;
pub mod leftovers;
pub mod lock;
pub mod merge;
pub mod policy;
pub mod report;
pub mod rig_runner;
pub mod runner;
pub mod sim_runner;
pub mod space;
pub mod spec;
pub mod stats;
pub mod supervise;

pub use engine::{BatchConfig, BatchProgress, Manifest, Session, run};
pub use error::Error;
pub use factory::runner_factory;
pub use rig_runner::RigRunner;
pub use runner::{Cancel, RunnerFactory, TrialJob, TrialResult, TrialRunner, TrialVerdict};
pub use sim_runner::SimRunner;
pub use spec::BatchSpec;
