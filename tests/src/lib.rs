//! Full-loop tests (plan → flash → execute → camera → track → verdict) live in `tests/`; the
//! library holds what they share with no mesopush code: [`coulomb`], an independent reference
//! pusher with exact Coulomb friction.
pub mod coulomb;
