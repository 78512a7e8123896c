//! Full-loop tests (plan → flash → execute → camera → track → verdict) live in `tests/`.
