//! The trial figure in the style of the paper's Fig. 6: the fixture, the tracked peg outlines
//! (blue), the host simulator's prediction for the same plan (orange, dotted centre path),
//! and the tracked centre path.
//!
//! It lives with the loop drivers: it draws what a driven trial reports (the tracked poses
//! of a [`super::spec::TrialReport`]) beside the host simulator's prediction, for
//! `mesopush demo`. It uses nothing else of the crate.

use crate::Error;
use mesopush_core::geom::{ConvexPolygon, Pose};
use mesopush_plot::fixture_view::{FIGURE_PX, fixture_chart};
use mesopush_plot::{DrawResult, Figure, save};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// What to draw.
#[derive(Debug, Clone, Copy)]
pub struct TrialFigure<'a> {
    /// Title.
    pub title: &'a str,
    /// Fixture walls.
    pub walls: &'a [ConvexPolygon],
    /// The part, body frame.
    pub part: &'a ConvexPolygon,
    /// Tracked poses (unflagged), in time order.
    pub tracked: &'a [Pose],
    /// Simulated poses, in time order.
    pub simulated: &'a [Pose],
}

/// Draws to `path` (`.png` or `.svg`).
pub fn draw_trial(fig: &TrialFigure<'_>, path: &Path) -> Result<(), Error> {
    Ok(save(fig, path, FIGURE_PX)?)
}

impl Figure for TrialFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        draw(area, self)
    }
}

fn outline(part: &ConvexPolygon, pose: &Pose) -> Vec<(f64, f64)> {
    let mut pts: Vec<(f64, f64)> =
        part.transformed(pose).vertices().iter().map(|v| (v.x, v.y)).collect();
    pts.push(pts[0]);
    pts
}

fn draw<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, fig: &TrialFigure<'_>) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let mut chart = fixture_chart(area, fig.title, fig.walls)?;
    let orange = RGBColor(230, 120, 20);
    for (poses, color, label) in [
        (fig.simulated, orange, "simulated by the host model: outlines, centre path"),
        (fig.tracked, BLUE, "tracked by the camera: outlines, centre path"),
    ] {
        let n = poses.len();
        let stride = (n / 12).max(1);
        for (i, p) in poses.iter().enumerate() {
            let ends = i == 0 || i + 1 == n;
            if ends || i % stride == 0 {
                let style =
                    if ends { color.stroke_width(2) } else { color.mix(0.3).stroke_width(1) };
                chart
                    .draw_series(std::iter::once(PathElement::new(outline(fig.part, p), style)))?;
            }
        }
        let path: Vec<(f64, f64)> = poses.iter().map(|p| (p.x_um, p.y_um)).collect();
        chart
            .draw_series(std::iter::once(PathElement::new(path, color.stroke_width(2))))?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .draw()?;
    area.present()?;
    Ok(())
}
