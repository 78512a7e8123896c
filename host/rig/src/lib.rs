//! The whole loop without hardware (issue 5): the host flashes a plan into the executor,
//! which streams it to the firmware simulator's controller over a real pseudo-terminal; the
//! simulated stage moves the probe in a simulated world (the host's simulator with the
//! world's own model) that a simulated camera films; the executor stamps the frames, the
//! recorder writes the trial directory, the host tracks the frames and judges the result.
//!
//! - [`world_file`]: the world file (`worlds/*.toml`); [`world`]: the `World` the firmware
//!   simulator asks for poses and frames; [`needle`]: where the needle's tip rests.
//! - [`session`]: the host's side of the executor line (flash, arm, start, wait).
//! - [`pty`]: the lock-stepped pseudo-terminal; [`simloop`]: the loop in simulated time;
//!   [`realtime`]: the same parts on threads in real time.
//! - [`recorder`]: log records and frames → trial directory (+ tracking).
//! - [`trial`]: [`run_trial`], [`TrialSpec`], [`TrialReport`]; [`truth_log`]: truth.csv and
//!   jam events; [`figure`]: tracked vs
//!   simulated trajectory figure.

pub(crate) mod build;
pub mod complete;
pub mod ctrl_serve;
pub mod error;
pub mod faults;
pub mod figure;
pub mod fwsim;
pub mod hil;
pub mod hostlink;
pub mod needle;
pub mod painter;
pub mod pty;
pub mod realtime;
pub mod recorder;
pub mod session;
pub mod simloop;
pub mod start_camera;
pub mod trial;
pub mod truth_log;
pub mod world;
pub mod world_file;

pub use error::Error;
pub use faults::{FaultClasses, FaultCount};
pub use trial::{ClockMode, Progress, TrialReport, TrialSpec, run_trial};
pub use world_file::WorldFile;
