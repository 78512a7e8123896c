//! The view every plan-space figure draws on: fixture coordinates in µm with y down (as the
//! camera sees them), the walls filled and the camera field outlined.

use crate::{DrawResult, Error};
use mesopush_core::geom::ConvexPolygon;
use mesopush_sim::fixture::FIELD_UM;
use plotters::coord::Shift;
use plotters::prelude::*;

/// Chart in fixture coordinates (µm, y down).
pub type FixtureChart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// Fills the wall polygons (clipped to the view `(x0, x1, y0, y1)`) and outlines the camera
/// field: the background shared by every fixture figure.
pub fn draw_walls_and_field<DB: DrawingBackend>(
    chart: &mut FixtureChart<'_, DB>,
    walls: &[ConvexPolygon],
    (x0, x1, y0, y1): (f64, f64, f64, f64),
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    for w in walls {
        let pts: Vec<_> =
            w.vertices().iter().map(|v| (v.x.clamp(x0, x1), v.y.clamp(y0, y1))).collect();
        chart.draw_series(std::iter::once(Polygon::new(pts, RGBColor(190, 190, 200).filled())))?;
    }
    let (w, h) = (FIELD_UM[0], FIELD_UM[1]);
    let field = vec![(0.0, 0.0), (w, 0.0), (w, h), (0.0, h), (0.0, 0.0)];
    chart.draw_series(std::iter::once(PathElement::new(field, BLACK.stroke_width(1))))?;
    Ok(())
}

/// The view of the trajectory figures, `(x0, x1, y0, y1)` in µm: the camera field with room
/// on the left for the peg's start and the probe's approach.
pub const VIEW_UM: (f64, f64, f64, f64) =
    (-1500.0, FIELD_UM[0] + 100.0, -100.0, FIELD_UM[1] + 100.0);

/// A white area with a titled chart over [`VIEW_UM`] (y down), the walls and the field drawn.
pub fn fixture_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    title: &str,
    walls: &[ConvexPolygon],
) -> Result<FixtureChart<'a, DB>, Error>
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE)?;
    let (x0, x1, y0, y1) = VIEW_UM;
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(55)
        .build_cartesian_2d(x0..x1, y1..y0)?;
    chart.configure_mesh().x_desc("x [µm]").y_desc("y [µm] (down)").disable_mesh().draw()?;
    draw_walls_and_field(&mut chart, walls, VIEW_UM)?;
    Ok(chart)
}
