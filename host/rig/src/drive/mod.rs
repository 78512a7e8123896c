//! The loop drivers: the whole loop run in one process — host session (the client's), the
//! executor's allocation-free core, the controller and world (the plant's) — in simulated
//! time on one thread, or in real time on threads, recorded into a trial directory.
//!
//! - [`trial`]: [`trial::run_trial`], one trial through the whole loop; [`spec`]: what it is
//!   asked to do and what it reports; `prepare` and `finish`: the start and the end both
//!   clock modes share.
//! - [`simloop`]: the loop in simulated time; [`realtime`]: the same parts on threads in real
//!   time; [`pty`]: the lock-stepped pseudo-terminal of the controller's line;
//!   [`endpoint`]: the in-process executor.
//! - [`recorder`]: what the loop observes → trial directory (+ tracking); [`faults`]: faults
//!   injected and detected by class; [`figure`]: tracked vs simulated trajectory figure.
//!
//! May use: the plant (`plant`), the executor's client (`client`) and the crates below rig.
//! Neither of those modules uses this one: the dependencies run drive → plant and
//! drive → client only.

pub mod ctrl_line;
pub mod endpoint;
pub mod faults;
pub mod figure;
pub(crate) mod finish;
pub(crate) mod prepare;
pub mod pty;
pub mod realtime;
pub mod recorder;
pub mod simloop;
pub mod spec;
pub mod trial;
pub mod udp;
