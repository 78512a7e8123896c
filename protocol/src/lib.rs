//! Wire types shared by the mesopush host, executor and motion-controller firmware.
//!
//! `no_std`, no allocation: only message types, framing, checksums and version checks.
#![no_std]
#![deny(missing_docs)]
