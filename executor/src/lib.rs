//! The mesopush executor: receives flashed plans, streams probe moves to the motion
//! controller at a fixed rate, timestamps camera frames and records trials.
//!
//! Not built yet (issue 5); this crate exists so the workspace has its final shape.
#![no_std]
#![deny(missing_docs)]
