//! mesopush host library: the quasi-static pushing simulator and everything built on it.
//!
//! Units (one convention for the whole host): lengths in µm, angles in rad, time in s, all
//! `f64`, with the unit in every field name (`x_um`, `theta_rad`, `speed_um_s`). Conversions
//! to the wire's sized integers (nm `i32`, µs `u64`, nm/s `u32`) live in [`units`] only.

pub mod batch;
pub mod diagnose;
pub mod effects;
pub mod error;
pub mod geom;
pub mod ident;
pub mod lcp;
pub mod plan;
pub mod plot;
pub mod rig;
pub mod sim;
pub mod trial;
pub mod units;
pub mod vision;

pub use error::Error;
