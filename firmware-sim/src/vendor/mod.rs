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
//! - [`motion`]: the shared point-to-point stage model; [`serial`]: UART byte timing.
//!
//! All are sans-IO state machines in the controller's simulated clock, driven through
//! [`VendorController`].

pub mod linlab;
pub mod motion;
pub mod mp285;
pub mod mpc200;
pub mod scientifica;
pub mod sensapex;
pub mod serial;
pub mod smcp;
pub mod umprequest;

pub use mp285::{Mp285, Mp285Settings};
pub use mpc200::{Mpc200, Mpc200Settings};
pub use scientifica::{Card, Scientifica, ScientificaSettings};
pub use sensapex::{Sensapex, SensapexSettings};

/// A vendor controller on its link, fed bytes and time, emitting reply bytes.
///
/// Time is the controller's simulated clock in µs; calls must not go back in time (an
/// earlier `now_us` is treated as the latest one seen). Every method first advances the
/// controller to `now_us`, so calling [`poll`](Self::poll) is only needed to make time pass
/// when nothing is sent or read.
pub trait VendorController {
    /// Bytes from the host arriving at `now_us`: serial bytes in any chunking, or exactly one
    /// whole UDP datagram.
    fn receive(&mut self, now_us: u64, bytes: &[u8]);

    /// Advances motion and timers to `now_us`.
    fn poll(&mut self, now_us: u64);

    /// The next reply due by `now_us`: for a serial link, the bytes fully sent by then (as
    /// many as fit in `buf`); for UDP, one whole datagram (cut to `buf`'s length, as a
    /// socket does). `None` when nothing is due.
    fn transmit(&mut self, now_us: u64, buf: &mut [u8]) -> Option<usize>;

    /// The true x, y position of the probe (stage) in nm at the last time seen, for the
    /// simulated world. After a stall this differs from what the controller reports.
    fn probe_nm(&self) -> (i32, i32);

    /// The true z position in nm (held by the pushing task; reported for completeness).
    fn probe_z_nm(&self) -> i32;

    /// The next time something changes without input (a reply byte leaves, a move ends, a
    /// notification is due), µs; `None` when nothing is pending.
    fn next_deadline_us(&self) -> Option<u64>;
}

/// Steps × `nm_per_step` as nm, rounded and saturated to `i32`.
pub(crate) fn steps_to_nm(steps: i64, nm_per_step: f64) -> i32 {
    let nm = (steps as f64 * nm_per_step).round();
    nm.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
}

/// Saturates a step count to the `i32` a device reports.
pub(crate) fn to_i32(v: i64) -> i32 {
    i32::try_from(v).unwrap_or(if v < 0 { i32::MIN } else { i32::MAX })
}
