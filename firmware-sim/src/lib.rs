//! The simulated motion controller and physical world (stage, peg, camera).
//!
//! Not built yet (issue 5); this crate exists so the workspace has its final shape.
