//! The simulated motion controller and physical world (stage, peg, camera).
//!
//! - [`controller`]: the firmware as a sans-IO state machine in controller time: bounded
//!   segment queue, [`stage`] dynamics, position/status/heartbeat reports, clock-sync
//!   replies, stop, fault codes.
//! - [`node`]: the controller on the wire (reliable link, framing), with its own drifting
//!   clock and injected stage faults and reboots.
//! - [`line`](mod@line): a simulated serial line with seeded drop/corrupt/duplicate/delay faults;
//!   [`camera`]: a frame source with drops and black frames; [`world`]: the [`World`]
//!   trait the host implements with its simulator and renderer.
//! - [`config`]: plain-data [`CtrlConfig`] and [`FaultConfig`]; [`rng`]: the one seeded
//!   random source. Same seed → identical event sequence.
//! - [`vendor`]: byte-exact emulators of commercial micromanipulator controllers (Sutter
//!   MPC-200 and MP-285, Scientifica, Sensapex uMp), the test peers of the executor's
//!   vendor adapters, behind the [`vendor::VendorController`] trait.
//!
//! May depend on: `mesopush-protocol` only. The physical world is reached through the
//! [`World`] trait, which the host's rig implements; it never depends on host crates or the
//! executor.

#![deny(missing_docs)]

pub mod camera;
pub mod config;
pub mod controller;
pub mod error;
pub mod line;
pub mod node;
pub mod rng;
pub mod stage;
pub mod vendor;
pub mod world;

pub use config::{CtrlConfig, FaultConfig};
pub use controller::{Controller, CtrlEvent, CtrlOutput};
pub use error::SimError;
pub use node::{ControllerNode, NodeEvent};
pub use rng::SimRng;
pub use world::{PegPose, World};
