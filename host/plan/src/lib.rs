//! mesopush plan: designing pushing plans and measuring how robust they are. Three layers,
//! each on the ones before it:
//!
//! - **The paper's RRT** (section II-B, III-B): [`rrt`] over peg poses whose edges are
//!   simulated probe pushes ([`pushes`]), grown by [`steer`] (with the probe's repositioning,
//!   [`route`], kept clear by [`clearance`]), shortened by [`shortcut`]; every kept plan passes
//!   [`feasible`].
//! - **Monte Carlo robustness**: a plan's success probability under the paper's uncertainty
//!   ([`sampler`], [`montecarlo`]), split into shards and merged ([`shard`]), reported with
//!   figures and per-trial CSVs ([`robustness`], [`figures`]).
//! - **Robust design** (beyond the paper): the cross-entropy method over a [`family`] of
//!   plans — a [`skeleton`] of Table II's shape, or the moves of any plan (an RRT's,
//!   [`rrt_starts`], or a file's), with uncertainty-removing presses against the walls
//!   ([`wall_press`]) — scored on sampled worlds ([`world`], [`score`]), in rounds with
//!   validation and confirmation ([`robust`]), run under a budget of replays with a fresh
//!   check ([`robust_search`]).
//!
//! Every plan this crate writes is an ordinary [`mesopush_sim::Plan`]: a connected probe path
//! of axis-aligned moves (pushes and the repositioning between them) that `mesopush sim` and
//! the executor accept, checked to keep the probe out of the walls and inside the executor's
//! workspace.
//!
//! May depend on: `mesopush-core` (geometry, statistics, shard files, atomic writes),
//! `mesopush-sim` (the simulator), `mesopush-plot` (figures), `mesopush-protocol` (unit
//! conversions) and `mesopush-executor` (its workspace and speed limits). Never on vision,
//! trial, rig, ident, diagnose, batch or cli: a plan is designed from a model and a fixture,
//! not from recorded trials or a running rig.

pub mod error;

pub mod clearance;
pub mod feasible;
pub mod pushes;
pub mod route;
pub mod rrt;
pub mod rrt_settings;
pub mod rrt_starts;
pub mod shortcut;
pub mod steer;
pub mod tree;

pub mod figures;
pub mod montecarlo;
pub mod robustness;
pub mod sampler;
pub mod shard;

mod cem;
pub mod family;
pub mod press_start;
pub mod robust;
pub mod robust_search;
pub mod robust_settings;
pub mod score;
pub mod skeleton;
pub mod staged;
pub mod wall_geometry;
pub mod wall_press;
pub mod world;

pub use error::Error;
pub use family::{PathFamily, PlanFamily, Table2Family};
pub use feasible::plan_is_feasible;
pub use montecarlo::{MonteCarlo, SampleOutcome, SuccessEstimate};
pub use robust::{RobustResult, design_robust};
pub use robust_search::{Init, RobustReport, RobustSearch, search_robust};
pub use robust_settings::RobustSettings;
pub use rrt::{RrtProgress, RrtResult, RrtRun, plan_rrt, plan_rrt_within};
pub use rrt_settings::RrtSettings;
pub use sampler::Uncertainty;
pub use skeleton::Skeleton;
pub use world::UncertainWorld;
