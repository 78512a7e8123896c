//! mesopush-rig: the whole loop without hardware (issue 5), and the host's side of a real
//! one. The host flashes a plan into the executor, which streams it to the firmware
//! simulator's controller over a real pseudo-terminal; the simulated stage moves the probe in
//! a simulated world (the host's simulator with the world's own model) that a simulated
//! camera films; the executor stamps the frames, the recorder writes the trial directory, the
//! host tracks the frames and judges the result.
//!
//! Three modules, with one-way dependencies between them (drive → plant, drive → client;
//! plant and client use neither each other nor drive):
//! - [`plant`]: the simulated physical world and the controller's side — world file, world,
//!   needle, painter, truth, the served controller, the `mesopush-fwsim` process, the start
//!   camera.
//! - [`client`]: the client of an executor — the host session, the line to an executor
//!   process, the hardware-in-the-loop workflow, completing a recorded trial.
//! - [`drive`]: the loop drivers — [`run_trial`] in simulated or real time, the recorder,
//!   the fault counts and the trial figure.
//!
//! May depend on: mesopush-core, -sim, -vision, -trial, -plot, -protocol, -executor,
//! -framestore and -firmware-sim. Never on mesopush-ident, -plan, -diagnose, -batch or -cli (they build on
//! this crate).

pub mod client;
pub mod drive;
pub mod error;
pub mod plant;

pub use drive::faults::{FaultClasses, FaultCount};
pub use drive::spec::{ClockMode, TrialProgress, TrialReport, TrialSpec};
pub use drive::trial::run_trial;
pub use error::Error;
pub use plant::world_file::WorldFile;
