//! Emulators of commercial micromanipulator controllers, as test peers of the executor's
//! vendor adapters.
//!
//! Each emulator speaks one vendor's wire protocol byte for byte, as documented in public
//! sources (vendor manuals and SDK headers, and the open drivers acq4, Micro-Manager,
//! ScanImage, pyIVLS, sensapex-py), including the quirks those drivers work around. They
//! were written from those sources only, independently of the executor's adapters, so an
//! adapter tested against them is checked against the documentation, not against itself.
//! Every module says which behaviour is documented and which is an inferred choice.
//!
//! - [`mpc200`]: Sutter MPC-200 / ROE-200 (binary, 128000 baud);
//! - [`mp285`]: Sutter MP-285 (binary with CR, 9600 baud);
//! - [`scientifica`]: Scientifica LinLab motion cards v2/v3 (ASCII);
//! - [`sensapex`]: Sensapex uMp over SMCP1 UDP datagrams ([`smcp`] is the frame codec);
//! - [`motion`]: the shared point-to-point stage model; [`serial`]: UART byte timing;
//!   [`mpc200_rx`], [`linlab`], [`umprequest`]: each protocol's input decoding.
//!
//! All are sans-IO state machines in the controller's simulated clock, driven through
//! the [`VendorController`] trait ([`controller`]).

pub mod controller;
pub mod linlab;
pub mod motion;
pub mod mp285;
pub mod mpc200;
pub mod mpc200_rx;
pub mod scientifica;
pub mod sensapex;
pub mod serial;
pub mod smcp;
pub mod umprequest;

pub use controller::VendorController;
pub use mp285::{Mp285, Mp285Settings};
pub use mpc200::{Mpc200, Mpc200Settings};
pub use scientifica::{Card, Scientifica, ScientificaSettings};
pub use sensapex::{Sensapex, SensapexSettings};
