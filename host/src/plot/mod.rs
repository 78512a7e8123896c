//! Figures a person would rather look at than read (plotters, PNG and SVG).

pub mod fig5;
pub mod fig6;
pub mod fixture_fig;

pub use fig6::{PlanFigure, draw_plan};
pub use fixture_fig::draw_fixture;
