//! mesopush core: the vocabulary every host crate shares — plane geometry ([`geom`]), input
//! checks that name field, value and range ([`check`]), the
//! statistics the reports quote ([`stats`]), files written atomically ([`fsx`]) and the one
//! shape of a run split into shards ([`shard`]).
//!
//! Units (one convention for the whole host): lengths in µm, angles in rad, time in s, all
//! `f64`, with the unit in every field name (`x_um`, `theta_rad`, `speed_um_s`). Conversions
//! to the wire's sized integers live in `mesopush_protocol::units` only.
//!
//! May depend on: `mesopush-fsx` (the one atomic file write, shared with the executor) and
//! nothing else of mesopush. Every other host crate depends on it.

pub mod check;
pub mod error;
pub mod fsx;
pub mod geom;
pub mod shard;
pub mod stats;

pub use error::Error;
