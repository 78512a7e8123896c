//! The plant: the simulated physical world and the controller's side of the rig — what a
//! real rig would have on the far side of the executor's serial line and camera.
//!
//! - [`world_file`]: the world file (`worlds/*.toml`), its values range-checked by
//!   [`world_check`]; [`assemble`]: the world, its camera
//!   timing and optics assembled from a world file, a plan and the seed.
//! - [`world`]: the `World` the firmware simulator asks for poses and frames (the host's
//!   simulator with the world's own model); [`needle`]: where the needle's tip rests;
//!   [`truth`]: the ground truth at each exposure and the jam episodes; [`truth_log`]: them
//!   in the trial log.
//! - [`painter`]: rendering off the controller's loop; [`frame_png`]: a frame as PNG.
//! - [`controller`]: the simulated motion controller's sizes and construction;
//!   [`ctrl_serve`]: it served on a pseudo-terminal's master in real time.
//! - [`fwsim`]: the firmware simulator as its own process (`mesopush-fwsim`).
//! - [`start_camera`]: the simulated camera that estimates a trial's start pose.
//!
//! May use: the crates below rig (core, sim, vision, trial, protocol, firmware-sim, executor
//! for its clock and socket helpers). Never the loop drivers (`drive`) nor the executor's
//! client (`client`): the plant does not know who drives it.

pub mod assemble;
pub mod controller;
pub mod ctrl_serve;
pub mod frame_png;
pub mod fwsim;
pub mod needle;
pub mod painter;
pub mod start_camera;
pub mod truth;
pub mod truth_log;
pub mod vendor;
pub mod world;
pub mod world_check;
pub mod world_file;
