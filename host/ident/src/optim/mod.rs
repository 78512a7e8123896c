//! The minimisers identification and diagnosis share, one algorithm per file, knowing nothing
//! of pushing: [`mod@nelder_mead`] (a derivative-free simplex), [`es`] (a seeded (1 + λ) evolution
//! strategy) and [`lm`] (Levenberg–Marquardt on a residual vector). Each takes plain-data
//! settings with documented defaults and returns a [`Minimum`].
//!
//! Callers: identification's joint fit (module `joint`: evolution strategy →
//! Levenberg–Marquardt → Nelder–Mead) and `mesopush-diagnose`'s fits (Nelder–Mead →
//! Levenberg–Marquardt). Every algorithm is deterministic: random draws come only from the
//! generator passed in, parallel evaluations are collected in index order.

pub mod es;
pub mod lm;
mod minimum;
pub mod nelder_mead;

pub use es::{EsSettings, evolve};
pub use lm::{LmSettings, ResidualFn, levenberg_marquardt};
pub use minimum::Minimum;
pub use nelder_mead::{Centroid, NelderMeadSettings, Stop, axis_simplex, nelder_mead};
