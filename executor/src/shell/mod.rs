//! The std shell: the executor core on real byte links, in real time.
//!
//! Threads: one reader per serial line pushes fixed-size byte chunks into a bounded
//! crossbeam channel (preallocated: no allocation per read); the loop thread owns the
//! [`crate::endpoint::Endpoint`], waits on the channels until the core's next deadline, feeds
//! bytes, frames and ticks in, writes the frames it produces and hands log records to the
//! recorder's channel without ever blocking on it (a full channel is counted, never waited
//! for). Time comes from a [`crate::clock::Clock`]. Byte links are behind [`port::ByteRead`]
//! / [`port::ByteWrite`], implemented for serial ports (`serialport::TTYPort`, which also
//! gives pseudo-terminal pairs) and for in-memory pipes.

pub mod port;
pub mod runner;

pub use port::{ByteRead, ByteWrite, Chunk};
pub use runner::{Shell, ShellStats};
