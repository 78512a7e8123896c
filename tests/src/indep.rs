//! An independent generator of trial logs (docs/trial-log.md, version 2) for validating
//! identification and diagnosis on data whose physics and effects share no code, types or
//! defaults with the project: exact Coulomb friction at point supports ([`crate::coulomb`]),
//! its own world, push plans, stage, effects, camera and writer. Only the file format is
//! shared. See docs/independent-generator.md.
//!
//! Layout (one concept per module): [`rng`] random streams, [`world`] the part and its
//! supports, [`effects`] the effects and their sizes, [`path`] commanded paths, [`plan`]
//! push plans, [`stage`] backlash and lead screw, [`adhesion`] the adhesive bond, [`physics`]
//! the true motion, [`camera`] frames and noise, [`writer`] trial directories, [`batch`]
//! batches and the manifest.

pub mod adhesion;
pub mod batch;
pub mod camera;
pub mod effects;
pub mod error;
pub mod path;
pub mod physics;
pub mod plan;
pub mod rng;
pub mod stage;
pub mod world;
pub mod writer;

pub use error::Error;
