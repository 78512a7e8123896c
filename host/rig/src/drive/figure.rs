//! The trial figure in the style of the paper's Fig. 6: the fixture, the tracked peg outlines
//! (blue), the host simulator's prediction for the same plan (orange, dotted centre path),
//! and the tracked centre path.
//!
//! It lives with the loop drivers: it draws what a driven trial reports (the tracked poses
//! of a [`super::spec::TrialReport`]) beside the host simulator's prediction, for
//! `mesopush demo`. It uses nothing else of the crate.

use crate::Error;
use mesopush_core::geom::{ConvexPolygon, Pose};
use mesopush_plot::fixture_view::{figure_px, fixture_chart, fixture_legend, split_legend};
use mesopush_plot::legend_band::{Entry, Mark, draw_legend};
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
    Ok(save(fig, path, figure_px(LEGEND_ENTRIES))?)
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

/// Entries of the legend: walls, field, simulated, tracked.
const LEGEND_ENTRIES: usize = 4;

fn draw<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, fig: &TrialFigure<'_>) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let (top, band) = split_legend(area, LEGEND_ENTRIES)?;
    let mut chart = fixture_chart(&top, fig.title, fig.walls)?;
    let mut legend = fixture_legend();
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
        chart.draw_series(std::iter::once(PathElement::new(path, color.stroke_width(2))))?;
        legend.push(Entry::new(Mark::Line(color.to_rgba(), 2), label));
    }
    draw_legend(&band, &legend)?;
    area.present()?;
    Ok(())
}
