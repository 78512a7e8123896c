//! Planning (issue 6): the paper's RRT over simulated pushes, a Monte Carlo estimate of a
//! plan's success under the uncertainty the paper names, and plans made robust by design.
//!
//! Every plan this module writes is an ordinary [`mesopush_sim::Plan`]: a connected probe path
//! of axis-aligned moves (pushes and the repositioning between them) that `mesopush sim` and
//! the executor accept, checked to keep the probe out of the walls and inside the executor's
//! workspace.

pub mod clearance;
pub mod error;
pub mod pushes;
pub mod route;
pub mod rrt;
pub mod shortcut;
pub mod steer;
pub mod tree;

pub use error::Error;
pub use rrt::{Progress, RrtResult, RrtSettings, plan_is_feasible, plan_rrt};
pub mod montecarlo;
pub mod sampler;
pub mod shard;

pub use montecarlo::{Estimate, MonteCarlo, Trial};
pub use sampler::{SupportSet, Uncertainty};
mod cem;
pub mod figures;
pub mod press_start;
pub mod robust;
pub mod skeleton;

pub use robust::{RobustResult, RobustSettings, World, design_robust};
pub use skeleton::Skeleton;
