//! The held-out residual figure (`residuals.png`): one row per held-out trial, the nominal
//! model's residual on the left and the extended model's on the right, so no two trials'
//! curves are drawn over each other. Every panel shares one residual scale (so before and
//! after compare by eye), names its trial and model, and carries a legend above the data.

use super::attribute::Diagnosis;
use super::residual::Residual;
use crate::Error;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// At most this many held-out trials are drawn (the rest are named in the last caption).
pub const MAX_ROWS: usize = 6;

/// Height of one trial's row, px.
const ROW_PX: u32 = 250;

/// Held-out peg position residuals (measured − predicted) over time, as PNG.
pub fn plot(d: &Diagnosis, path: &Path) -> Result<(), Error> {
    let err =
        |e: &dyn std::fmt::Display| Error::Parse { path: path.into(), message: e.to_string() };
    let n = d.residuals.0.len().clamp(1, MAX_ROWS);
    let rows = u32::try_from(n).unwrap_or(1);
    mesopush_plot::font::register().map_err(|e| err(&e))?;
    let root = BitMapBackend::new(path, (1200, 40 + ROW_PX * rows)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let title = match d.residuals.0.len() {
        k if k > MAX_ROWS => format!(
            "Held-out peg position residual, measured − predicted (first {MAX_ROWS} of {k} trials)"
        ),
        _ => "Held-out peg position residual, measured − predicted".to_owned(),
    };
    let body = root.titled(&title, ("sans-serif", 20)).map_err(|e| err(&e))?;
    let lim = scale_um(d);
    let cells = body.split_evenly((n, 2));
    for (k, pair) in cells.chunks(2).enumerate() {
        let id = d.heldout.get(k).map_or("?", |t| t.id.as_str());
        let sides = [("nominal model", &d.residuals.0), ("extended model", &d.residuals.1)];
        for (cell, (model, res)) in pair.iter().zip(sides) {
            if let Some(r) = res.get(k) {
                panel(cell, &format!("{id}: {model}"), r, lim).map_err(|e| err(&e))?;
            }
        }
    }
    root.present().map_err(|e| err(&e))
}

/// The largest |residual| over every drawn panel, µm (at least 1).
fn scale_um(d: &Diagnosis) -> f64 {
    [&d.residuals.0, &d.residuals.1]
        .iter()
        .flat_map(|res| res.iter().take(MAX_ROWS))
        .flat_map(|r| r.frames.iter())
        .flat_map(|f| [f.peg[0].abs(), f.peg[1].abs()])
        .filter(|v| v.is_finite())
        .fold(1.0, f64::max)
}

/// One trial under one model: its x and y residual against time, the legend in headroom
/// above the data.
fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    r: &Residual,
    lim_um: f64,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let tmax = r.frames.iter().map(|f| f.t_s).fold(1.0, f64::max);
    let mut ch = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 16))
        .margin(8)
        .x_label_area_size(32)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..tmax, -lim_um..lim_um * 1.6)?;
    ch.configure_mesh()
        .x_desc("time since the trial's start (s)")
        .y_desc("residual (µm)")
        .light_line_style(WHITE)
        .draw()?;
    let axes = [("peg x residual (µm)", RED), ("peg y residual (µm)", BLUE)];
    for (a, (label, colour)) in axes.into_iter().enumerate() {
        let pts = r.frames.iter().filter(|f| f.peg[a].is_finite()).map(|f| (f.t_s, f.peg[a]));
        ch.draw_series(LineSeries::new(pts, colour.stroke_width(1)))?
            .label(label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], colour.stroke_width(2)));
    }
    ch.draw_series(LineSeries::new([(0.0, 0.0), (tmax, 0.0)], BLACK.mix(0.4)))?;
    ch.configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .draw()
}
