//! The std shell: the executor core on real byte links, in real time.
//!
//! Threads: one reader per serial line pushes fixed-size byte chunks into a bounded queue
//! ([`rt_queue`]: preallocated, and a waiter sleeps instead of spinning on a preempted
//! peer, so a real-time thread never livelocks on a normal one); the loop thread owns the
//! [`crate::endpoint::Endpoint`], waits on the queues (one [`rt_queue::Bell`]) until the
//! core's next deadline, feeds bytes, frames and ticks in, writes the frames it produces and
//! hands log records to a normal-priority forwarder, and so to the recorder's channel, without
//! ever blocking on it (a full queue is counted, never waited for). Before a segment's send deadline the loop sleeps until `spin_us` before it, then
//! spins on the clock (hybrid wait: a sleep wakes tens to hundreds of µs late); each
//! segment's write is timed against its schedule ([`timing`]). [`rt`] optionally locks
//! memory, raises the loop to `SCHED_FIFO` and pins it to a CPU. Time comes from a [`crate::clock::Clock`]. Byte links are behind [`port::ByteRead`]
//! / [`port::ByteWrite`], implemented for serial ports (`serialport::TTYPort`, which also
//! gives pseudo-terminal pairs), for in-memory pipes and for a Unix socket host line
//! ([`unix_line`]). Camera frames come from the camera channel ([`camera_source`], a Unix socket) or a
//! V4L2 camera (`camera_v4l`, feature `v4l`), chosen by [`camera_addr`]; the
//! recorder thread ([`record`]) writes the raw frame part of each trial log.

#[cfg(unix)]
pub mod camera_addr;
#[cfg(unix)]
pub mod camera_source;
#[cfg(all(unix, feature = "v4l"))]
pub mod camera_v4l;
#[cfg(unix)]
pub mod controller;
pub mod fsx;
pub mod port;
#[cfg(unix)]
pub mod record;
pub mod rt;
pub mod rt_queue;
pub mod runner;
pub mod timing;
#[cfg(unix)]
pub mod unix_line;

pub use port::{ByteRead, ByteWrite, Chunk};
pub use runner::{Shell, ShellOptions, ShellStats};
pub use timing::SendTiming;
