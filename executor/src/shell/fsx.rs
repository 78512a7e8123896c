//! The executor's crash-safe file write (the plan store and the recorder both use it): the
//! project's one implementation, `mesopush-fsx`, which the host uses too.

pub use mesopush_fsx::{tmp_path, write_atomic, write_atomic_with};
