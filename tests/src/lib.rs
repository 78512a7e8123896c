//! Full-loop tests (plan → flash → execute → camera → track → verdict) live in `tests/`; the
//! library holds what they share with no mesopush code: [`coulomb`], an independent reference
//! pusher with exact Coulomb friction, and [`indep`], an independent generator of trial logs
//! built on it (its own world, plans, effects, camera and writer); [`render_indep`], an
//! independent microscope (rough-edged peg, tapered needle) for the tracker's probe tip.
pub mod coulomb;
pub mod indep;
pub mod render_indep;
