//! The client of an executor: the host's side of the executor's host line and what the host
//! adds to what an executor recorded.
//!
//! - [`session`]: the host's session with an executor as a sans-IO state machine (flash,
//!   arm, start, wait) — the same code drives the in-process loops and a real executor.
//! - [`hostlink`]: that session over the line to a running `mesopush-executor` process.
//! - [`hil`]: the hardware-in-the-loop workflow's host side (`mesopush flash`, `mesopush
//!   run`) and the error figures against the firmware simulator's truth file.
//! - [`rig`]: rig commands between trials (`mesopush rig status|goto|home|stop`).
//! - [`calibrate`]: `mesopush calibrate`, the camera's pixel size and rotation measured by
//!   moving the probe ([`calib_plan`]: the moves and the rests) and tracking its tip.
//! - [`complete`]: completing a trial recorded by the executor into a trial log;
//!   [`schedule`]: the setpoint schedule rebuilt from the flashed plan; [`tracking`]: a
//!   tracked frame as a pose.csv row.
//!
//! May use: the crates below rig (core, sim, vision, trial, protocol; executor for its plan
//! geometry and clock). Never the simulated plant (`plant`) nor the loop drivers
//! (`drive`): a client talks to whatever executor is at the other end of the line, real or
//! simulated.

pub mod calib_plan;
pub mod calibrate;
pub mod complete;
pub mod hil;
pub mod hostlink;
pub mod rig;
pub mod schedule;
pub mod session;
mod session_words;
pub mod tracking;
