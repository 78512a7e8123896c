//! A dimensioned drawing of the reconstructed paper fixture (for `docs/fixture.md`): walls,
//! camera field, goal, Table II's start pose and the dimensions that define the fixture.

use crate::fixture_view::{FIGURE_PX, draw_walls_and_field, equal_aspect};
use crate::{DrawResult, Error, Figure, save};
use mesopush_core::geom::{ConvexPolygon, Pose};
use mesopush_sim::fixture::{FIELD_UM, NARROW_CHANNEL_UM, PaperFixtureParams, WIDE_CHANNEL_UM};
use plotters::prelude::*;
use std::path::Path;

/// Draws the fixture `p` with its dimensions and the peg at `peg_pose` to `path` (.png/.svg).
pub fn draw_fixture(
    p: &PaperFixtureParams,
    walls: &[ConvexPolygon],
    part: &ConvexPolygon,
    peg_pose: &Pose,
    path: &Path,
) -> Result<(), Error> {
    save(&FixtureDrawing { p, walls, part, peg_pose }, path, FIGURE_PX)
}

struct FixtureDrawing<'a> {
    p: &'a PaperFixtureParams,
    walls: &'a [ConvexPolygon],
    part: &'a ConvexPolygon,
    peg_pose: &'a Pose,
}

impl Figure for FixtureDrawing<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, plotters::coord::Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        draw(area, self.p, self.walls, self.part, self.peg_pose)
    }
}

fn draw<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    p: &PaperFixtureParams,
    walls: &[ConvexPolygon],
    part: &ConvexPolygon,
    peg_pose: &Pose,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE)?;
    let view = (-1500.0, FIELD_UM[0] + 100.0, -100.0, FIELD_UM[1] + 100.0);
    let (x0, x1, y0, y1) = view;
    let body = area
        .titled("Reconstructed paper fixture (µm; origin top-left, y down)", ("sans-serif", 20))?;
    let (w_px, h_px) = body.dim_in_pixel();
    let plot_px = (f64::from(w_px.saturating_sub(75)), f64::from(h_px.saturating_sub(55)));
    let (v0, v1, w0, w1) = equal_aspect(view, plot_px);
    let mut chart = ChartBuilder::on(&body)
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(55)
        .build_cartesian_2d(v0..v1, w1..w0)?;
    chart.configure_mesh().disable_mesh().x_desc("x [µm]").y_desc("y [µm]").draw()?;
    draw_walls_and_field(&mut chart, walls, (x0, x1, y0, y1))?;
    let mut peg: Vec<_> =
        part.transformed(peg_pose).vertices().iter().map(|v| (v.x, v.y)).collect();
    peg.push(peg[0]);
    chart.draw_series(std::iter::once(PathElement::new(peg, BLUE.stroke_width(2))))?;
    let style = ("sans-serif", 16).into_font().color(&BLACK);
    let mut dim = |a: (f64, f64), b: (f64, f64), label: String, at: (f64, f64)| -> DrawResult {
        chart.draw_series(std::iter::once(PathElement::new(vec![a, b], RED.stroke_width(2))))?;
        chart.draw_series(std::iter::once(Text::new(label, at, style.clone())))?;
        Ok(())
    };
    let xw = FIELD_UM[0] - 250.0;
    let (wt, wb) = (p.wide_top_um, p.wide_top_um + WIDE_CHANNEL_UM);
    dim((xw, wt), (xw, wb), format!("wide {WIDE_CHANNEL_UM:.0}"), (xw - 330.0, (wt + wb) / 2.0))?;
    let xn = p.x_step_um - 400.0;
    let (nt, nb) = (p.narrow_top_um, p.narrow_top_um + NARROW_CHANNEL_UM);
    dim(
        (xn, nt),
        (xn, nb),
        format!("narrow {NARROW_CHANNEL_UM:.0}"),
        (xn - 380.0, (nt + nb) / 2.0),
    )?;
    dim((0.0, 60.0), (p.x_step_um, 60.0), format!("step x = {:.0}", p.x_step_um), (50.0, 40.0))?;
    if p.chamfer_um > 0.0 {
        let c = p.chamfer_um;
        let at = (p.x_step_um + 30.0, nt - c / 2.0);
        dim((p.x_step_um, nt - c), (p.x_step_um - c, nt), format!("chamfer {c:.0} × 45°"), at)?;
    }
    dim((-1400.0, 0.0), (-1400.0, wt), format!("{wt:.0}"), (-1350.0, wt / 2.0 + 40.0))?;
    dim((-1200.0, 0.0), (-1200.0, nt), format!("{nt:.0}"), (-1150.0, nt / 2.0 + 80.0))?;
    area.present()?;
    Ok(())
}
