//! A figure like the paper's Fig. 6: the fixture, peg outlines along the trajectory (start
//! and end bold, intermediate faint), the goal region and the probe tip positions as
//! triangles, each named in the legend; equal aspect.

use crate::fixture_view::{VIEW_UM, figure_px, fixture_chart, fixture_legend, split_legend};
use crate::legend_band::{Entry, Mark, draw_legend};
use crate::{DrawResult, Error, Figure, save};
use mesopush_core::geom::{ConvexPolygon, Pose};
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
    /// Whether the goal asks for the whole part inside it (else: its centre by the insert
    /// depth); only the legend's words.
    pub goal_whole_part: bool,
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
    save(fig, path, figure_px(LEGEND_ENTRIES))
}

impl Figure for PlanFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        draw(area, self)
    }
}

/// Entries of the legend: walls, field, goal, peg at the ends, peg between, probe tips.
const LEGEND_ENTRIES: usize = 6;

fn draw<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, fig: &PlanFigure<'_>) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let (top, band) = split_legend(area, LEGEND_ENTRIES)?;
    let mut chart = fixture_chart(&top, fig.title, fig.walls)?;
    let mut legend = fixture_legend();
    let (x0, x1, y0, y1) = VIEW_UM;
    let clip = |p: &ConvexPolygon| -> Vec<(f64, f64)> {
        p.vertices().iter().map(|v| (v.x.clamp(x0, x1), v.y.clamp(y0, y1))).collect()
    };
    if let Some(g) = fig.goal {
        let mut pts = clip(g);
        pts.push(pts[0]);
        chart.draw_series(std::iter::once(PathElement::new(pts, GREEN.stroke_width(2))))?;
        legend.push(Entry::new(
            Mark::Line(GREEN.to_rgba(), 2),
            if fig.goal_whole_part {
                "goal region (inserted: the whole part inside it)"
            } else {
                "goal region (inserted: peg centre inside by the insert depth)"
            },
        ));
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
        if i == 0 {
            legend.push(Entry::new(Mark::Line(BLUE.to_rgba(), 2), "peg at start and end"));
        } else if i == stride && i + 1 != n {
            legend.push(Entry::new(Mark::Line(BLUE.mix(0.35), 1), "peg in between"));
        }
    }
    let tips = fig.probe_um.iter().step_by((fig.probe_um.len() / 60).max(1));
    chart.draw_series(tips.map(|p| TriangleMarker::new((p[0], p[1]), 5, RED.filled())))?;
    legend.push(Entry::new(Mark::Triangle(RED.to_rgba()), "probe tip (sampled positions)"));
    draw_legend(&band, &legend)?;
    area.present()?;
    Ok(())
}
