//! A figure like the paper's Fig. 6: the fixture, peg outlines along the trajectory (start
//! and end solid, intermediate dotted), and the probe tip positions as triangles.

use crate::Error;
use crate::geom::{ConvexPolygon, Pose};
use crate::sim::fixture::FIELD_UM;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// What to draw.
#[derive(Debug, Clone, Copy)]
pub struct PlanFigure<'a> {
    /// Title.
    pub title: &'a str,
    /// Fixture walls (fixture frame, µm).
    pub walls: &'a [ConvexPolygon],
    /// Goal region outline.
    pub goal: Option<&'a ConvexPolygon>,
    /// The part in its body frame.
    pub part: &'a ConvexPolygon,
    /// Peg poses along the trajectory.
    pub poses: &'a [Pose],
    /// Probe tip positions, µm.
    pub probe_um: &'a [[f64; 2]],
    /// How many intermediate outlines to draw at most.
    pub max_outlines: usize,
}

/// Draws the figure to `path`; the backend follows the extension (`.png` or `.svg`).
pub fn draw_plan(fig: &PlanFigure<'_>, path: &Path) -> Result<(), Error> {
    let size = (1011, 800);
    let res = match path.extension().and_then(|e| e.to_str()) {
        Some("svg") => draw(&SVGBackend::new(path, size).into_drawing_area(), fig),
        Some("png") => draw(&BitMapBackend::new(path, size).into_drawing_area(), fig),
        _ => return Err(Error::invalid("figure", format!("{}: use .png or .svg", path.display()))),
    };
    res.map_err(|e| Error::invalid("figure", format!("{}: {e}", path.display())))
}

pub(crate) type DrawResult = Result<(), Box<dyn std::error::Error>>;

/// Chart in fixture coordinates (µm, y down).
pub(crate) type FixtureChart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// Fills the wall polygons (clipped to the view `(x0, x1, y0, y1)`) and outlines the camera
/// field: the background shared by every fixture figure.
pub(crate) fn draw_walls_and_field<DB: DrawingBackend>(
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
pub(crate) const VIEW_UM: (f64, f64, f64, f64) =
    (-1500.0, FIELD_UM[0] + 100.0, -100.0, FIELD_UM[1] + 100.0);

/// A white area with a titled chart over [`VIEW_UM`] (y down), the walls and the field drawn.
pub(crate) fn fixture_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    title: &str,
    walls: &[ConvexPolygon],
) -> Result<FixtureChart<'a, DB>, Box<dyn std::error::Error>>
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

fn draw<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, fig: &PlanFigure<'_>) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let mut chart = fixture_chart(area, fig.title, fig.walls)?;
    let (x0, x1, y0, y1) = VIEW_UM;
    let clip = |p: &ConvexPolygon| -> Vec<(f64, f64)> {
        p.vertices().iter().map(|v| (v.x.clamp(x0, x1), v.y.clamp(y0, y1))).collect()
    };
    if let Some(g) = fig.goal {
        let mut pts = clip(g);
        pts.push(pts[0]);
        chart.draw_series(std::iter::once(PathElement::new(pts, GREEN.stroke_width(1))))?;
    }
    let n = fig.poses.len();
    let stride = (n / fig.max_outlines.max(1)).max(1);
    for (i, pose) in fig.poses.iter().enumerate() {
        let ends = i == 0 || i + 1 == n;
        if !ends && i % stride != 0 {
            continue;
        }
        let mut pts: Vec<(f64, f64)> =
            fig.part.transformed(pose).vertices().iter().map(|v| (v.x, v.y)).collect();
        pts.push(pts[0]);
        let style = if ends { BLUE.stroke_width(2) } else { BLUE.mix(0.35).stroke_width(1) };
        chart.draw_series(std::iter::once(PathElement::new(pts, style)))?;
    }
    let tips = fig.probe_um.iter().step_by((fig.probe_um.len() / 60).max(1));
    chart.draw_series(tips.map(|p| TriangleMarker::new((p[0], p[1]), 5, RED.filled())))?;
    area.present()?;
    Ok(())
}
