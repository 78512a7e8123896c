//! The view every plan-space figure draws on: fixture coordinates in µm with y down (as the
//! camera sees them), the walls filled and the camera field outlined.

use crate::legend_band::{Entry, Mark, band_px};
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

/// The grey of the walls.
const WALL_GREY: RGBColor = RGBColor(190, 190, 200);

/// Fills the wall polygons (clipped to the view `(x0, x1, y0, y1)`) and outlines the camera
/// field: the background shared by every fixture figure ([`fixture_legend`] names them).
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
        chart.draw_series(std::iter::once(Polygon::new(pts, WALL_GREY.filled())))?;
    }
    let (w, h) = (FIELD_UM[0], FIELD_UM[1]);
    let field = vec![(0.0, 0.0), (w, 0.0), (w, h), (0.0, h), (0.0, 0.0)];
    chart.draw_series(std::iter::once(PathElement::new(field, BLACK.stroke_width(1))))?;
    Ok(())
}

/// The legend entries of what [`draw_walls_and_field`] draws.
pub fn fixture_legend() -> Vec<Entry> {
    vec![
        Entry::new(Mark::Box(WALL_GREY.to_rgba()), "fixture walls"),
        Entry::new(Mark::Line(BLACK.to_rgba(), 1), "camera field of view"),
    ]
}

/// The canvas of a fixture figure whose legend band holds `entries` entries, px.
pub fn figure_px(entries: usize) -> (u32, u32) {
    (FIGURE_PX.0, FIGURE_PX.1 + band_px(entries))
}

/// A figure's area and the legend band under it.
pub type FigureAndBand<DB> = (DrawingArea<DB, Shift>, DrawingArea<DB, Shift>);

/// Fills `area` white and splits it into the figure (above) and the band for a legend of
/// `entries` entries (below, [`crate::legend_band::draw_legend`]).
pub fn split_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: usize,
) -> Result<FigureAndBand<DB>, Error>
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE)?;
    let (_, h) = area.dim_in_pixel();
    Ok(area.split_vertically(h.saturating_sub(band_px(entries))))
}

/// The view of the trajectory figures, `(x0, x1, y0, y1)` in µm: the camera field with room
/// on the left for the peg's start and the probe's approach.
pub const VIEW_UM: (f64, f64, f64, f64) =
    (-1500.0, FIELD_UM[0] + 100.0, -100.0, FIELD_UM[1] + 100.0);

/// Canvas of the fixture figures without their legend band, px: the view at equal aspect
/// with little to spare ([`figure_px`] adds the band).
pub const FIGURE_PX: (u32, u32) = (1011, 620);

/// A white area with a titled chart over [`VIEW_UM`] (y down), the walls and the field drawn
/// and labelled for the legend. The view is widened about its centre along one axis so a µm
/// spans as many pixels along x as along y (equal aspect, whatever the canvas size).
pub fn fixture_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    title: &str,
    walls: &[ConvexPolygon],
) -> Result<FixtureChart<'a, DB>, Error>
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE)?;
    let (margin, x_label, y_label) = (10u32, 35u32, 55u32);
    let body = area.titled(title, ("sans-serif", 20))?;
    let (w_px, h_px) = body.dim_in_pixel();
    let plot_px = (
        f64::from(w_px.saturating_sub(2 * margin + y_label).max(1)),
        f64::from(h_px.saturating_sub(2 * margin + x_label).max(1)),
    );
    let (x0, x1, y0, y1) = equal_aspect(VIEW_UM, plot_px);
    let mut chart = ChartBuilder::on(&body)
        .margin(margin)
        .x_label_area_size(x_label)
        .y_label_area_size(y_label)
        .build_cartesian_2d(x0..x1, y1..y0)?;
    chart.configure_mesh().x_desc("x (µm)").y_desc("y (µm, down)").disable_mesh().draw()?;
    draw_walls_and_field(&mut chart, walls, VIEW_UM)?;
    Ok(chart)
}

/// `view` `(x0, x1, y0, y1)` widened about its centre along x or y so that its µm per pixel
/// is the same along both axes of a plotting area of `plot_px` (width, height) pixels.
pub fn equal_aspect(view: (f64, f64, f64, f64), plot_px: (f64, f64)) -> (f64, f64, f64, f64) {
    let (x0, x1, y0, y1) = view;
    let um_per_px = ((x1 - x0) / plot_px.0).max((y1 - y0) / plot_px.1);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let (hx, hy) = (0.5 * um_per_px * plot_px.0, 0.5 * um_per_px * plot_px.1);
    (cx - hx, cx + hx, cy - hy, cy + hy)
}

#[cfg(test)]
mod tests {
    use super::equal_aspect;

    /// The plan figures drew 4 900 µm over 936 px and 2 700 µm over 720 px (5.2 against
    /// 3.8 µm per pixel): a peg looked squashed.
    #[test]
    fn equal_aspect_gives_one_scale_and_keeps_the_view() {
        let view = (-1500.0, 3400.0, -100.0, 2600.0);
        for plot in [(936.0, 720.0), (400.0, 900.0), (1000.0, 100.0)] {
            let (x0, x1, y0, y1) = equal_aspect(view, plot);
            let (sx, sy) = ((x1 - x0) / plot.0, (y1 - y0) / plot.1);
            assert!((sx - sy).abs() <= 1e-12 * sx, "{sx} vs {sy}");
            assert!(x0 <= view.0 && x1 >= view.1 && y0 <= view.2 && y1 >= view.3);
            // Only one axis is widened: the other is the view's own.
            let kept_x = (x1 - x0 - 4900.0).abs() < 1e-9;
            let kept_y = (y1 - y0 - 2700.0).abs() < 1e-9;
            assert!(kept_x || kept_y);
        }
    }
}
