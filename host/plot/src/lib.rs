//! mesopush plot: figures a person would rather look at than read (plotters, PNG and SVG).
//! The shared pieces every figure uses — [`save()`] (backend by extension), the fixture view in
//! plan coordinates ([`fixture_view`]) — and the figures of the fixture and of a plan.
//! Figures of a concern live with it (identification's Fig. 5 in `mesopush-ident`, robustness
//! in `mesopush-plan`, batches in `mesopush-batch`) and draw with these pieces.
//!
//! May depend on: `mesopush-core` (geometry) and `mesopush-sim` (fixture dimensions). It only
//! draws what it is given: it never runs a simulation. Text is drawn with the font it embeds
//! ([`font`]), so figures need no system fonts.

pub mod error;
pub mod fixture_drawing;
pub mod fixture_view;
pub mod font;
pub mod legend_band;
pub mod plan_view;
pub mod save;

pub use error::Error;
pub use fixture_drawing::draw_fixture;
pub use plan_view::{PlanFigure, draw_plan};
pub use save::{DrawResult, Figure, save};
