//! The controller the executor drives, behind one trait.
//!
//! The core ([`crate::Executor`]) speaks the project's controller protocol
//! ([`ExecToCtrl`] / [`mesopush_protocol::ctrl::CtrlToExec`]): segments scheduled ahead in the
//! controller's clock, status for flow control, clock-sync replies, faults. A
//! [`ControllerAdapter`] stands between the core and a real controller: it takes the core's
//! messages, speaks the controller's own wire protocol (bytes on a serial line or datagrams on a
//! socket) and answers the core with the messages it expects. The project's streaming
//! controller is one adapter ([`native::NativeAdapter`]: the reliable link, byte for byte what
//! went over the line before adapters existed); point-to-point controllers that only know
//! "move to" and "where are you" are others.
//!
//! Sans-IO like the core: bytes in ([`ControllerAdapter::receive`]), bytes out
//! ([`ControllerAdapter::transmit`]), time passed in; events for the core are drained with
//! [`ControllerAdapter::next_event`]. No allocation: every queue has a fixed capacity.

pub mod native;
pub mod p2p;

use mesopush_protocol::ExecToCtrl;
use mesopush_protocol::ctrl::CtrlToExec;

/// What an adapter tells the core.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AdapterEvent {
    /// A controller message, as the core understands it.
    Ctrl(CtrlToExec),
    /// The link to the controller went down (the core stops a trial in progress).
    LinkDown,
}

/// Counters every adapter keeps.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct AdapterStats {
    /// Core messages the adapter had no room for.
    pub dropped_commands: u64,
    /// Times the link went down.
    pub link_downs: u64,
    /// Received frames or replies that could not be read (too long, garbled).
    pub unreadable: u64,
    /// Moves a point-to-point controller completed and the adapter checked at their target
    /// (or skipped as shorter than the device executes); 0 for the native link, whose
    /// controller reports its own.
    pub moves_done: u64,
}

/// A motion controller as the core sees it.
pub trait ControllerAdapter {
    /// Takes the core's message for the controller at `now_us` (executor clock). A message
    /// the adapter has no room for is counted in [`AdapterStats::dropped_commands`].
    fn command(&mut self, now_us: u64, msg: &ExecToCtrl);

    /// Bytes from the controller: any chunk of a serial line, or one whole datagram. Returns
    /// how many were consumed; it stops early once an event is waiting, so the caller drains
    /// [`Self::next_event`] and calls again with the rest.
    fn receive(&mut self, now_us: u64, bytes: &[u8]) -> usize;

    /// Time passed: timeouts, polls, schedules. Call at least at [`Self::next_deadline_us`].
    fn poll(&mut self, now_us: u64);

    /// The next event for the core, if any.
    fn next_event(&mut self) -> Option<AdapterEvent>;

    /// The next bytes to write to the controller (a frame, a command or a datagram),
    /// encoded into `buf`; `None` when nothing is due at `now_us`.
    fn transmit<'b>(&mut self, now_us: u64, buf: &'b mut [u8]) -> Option<&'b [u8]>;

    /// When [`Self::poll`] is next needed, executor µs; `None` when nothing is pending.
    fn next_deadline_us(&self) -> Option<u64>;

    /// Counters.
    fn stats(&self) -> AdapterStats;
}
