//! Robustness figures: where failures come from (the trials' start offsets and friction,
//! coloured by outcome) and the success rate against the size of the uncertainty box.

use super::montecarlo::Trial;
use crate::Error;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

type DrawResult = Result<(), Box<dyn std::error::Error>>;
/// A coordinate of a trial for a scatter axis.
type Coord<'a> = &'a dyn Fn(&Trial) -> f64;

fn render(
    path: &Path,
    size: (u32, u32),
    f: impl Fn(&DrawingArea<BitMapBackend<'_>, Shift>) -> DrawResult,
    g: impl Fn(&DrawingArea<SVGBackend<'_>, Shift>) -> DrawResult,
) -> Result<(), Error> {
    let res = match path.extension().and_then(|e| e.to_str()) {
        Some("svg") => g(&SVGBackend::new(path, size).into_drawing_area()),
        Some("png") => f(&BitMapBackend::new(path, size).into_drawing_area()),
        _ => return Err(Error::invalid("figure", format!("{}: use .png or .svg", path.display()))),
    };
    res.map_err(|e| Error::invalid("figure", format!("{}: {e}", path.display())))
}

/// Scatter of the trials' start offsets (Δx, Δy) and (Δθ, mean support μ), successes green,
/// failures red, to `path` (.png or .svg).
pub fn draw_failures(title: &str, trials: &[Trial], path: &Path) -> Result<(), Error> {
    render(path, (1200, 560), |a| failures(a, title, trials), |a| failures(a, title, trials))
}

fn failures<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    trials: &[Trial],
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE)?;
    let area = area.titled(title, ("sans-serif", 20))?;
    let panels = area.split_evenly((1, 2));
    let span = |f: &dyn Fn(&Trial) -> f64| {
        let (lo, hi) = trials
            .iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
        if lo.is_finite() && hi > lo {
            (lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo))
        } else {
            (-1.0, 1.0)
        }
    };
    let mu = |t: &Trial| t.draw.model.support.mu_surface.iter().sum::<f64>() / 3.0;
    let axes: [(Coord<'_>, Coord<'_>, &str, &str); 2] = [
        (&|t| t.draw.offset[0], &|t| t.draw.offset[1], "start Δx [µm]", "start Δy [µm]"),
        (&|t| t.draw.offset[2], &mu, "start Δθ [°]", "mean support μ"),
    ];
    for (panel, (fx, fy, xl, yl)) in panels.iter().zip(axes) {
        let (x0, x1) = span(fx);
        let (y0, y1) = span(fy);
        let mut chart = ChartBuilder::on(panel)
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart.configure_mesh().x_desc(xl).y_desc(yl).draw()?;
        let ok = trials.iter().filter(|t| t.inserted);
        chart
            .draw_series(ok.map(|t| Circle::new((fx(t), fy(t)), 3, GREEN.mix(0.6).filled())))?
            .label("inserted")
            .legend(|(x, y)| Circle::new((x, y), 4, GREEN.filled()));
        let bad = trials.iter().filter(|t| !t.inserted);
        chart
            .draw_series(bad.map(|t| Cross::new((fx(t), fy(t)), 5, RED.stroke_width(2))))?
            .label("failed")
            .legend(|(x, y)| Cross::new((x, y), 5, RED.stroke_width(2)));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
    }
    area.present()?;
    Ok(())
}

/// One curve of success rate against the uncertainty scale: (scale, rate, ci_low, ci_high).
pub type SweepCurve<'a> = (&'a str, &'a [(f64, f64, f64, f64)]);

/// Success rate (with its 95 % interval) against the uncertainty box's scale, one curve per
/// plan, to `path` (.png or .svg).
pub fn draw_sweep(curves: &[SweepCurve<'_>], path: &Path) -> Result<(), Error> {
    render(path, (900, 600), |a| sweep(a, curves), |a| sweep(a, curves))
}

fn sweep<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, curves: &[SweepCurve<'_>]) -> DrawResult
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE)?;
    let x1 = curves.iter().flat_map(|c| c.1.iter().map(|p| p.0)).fold(1.0, f64::max) + 0.1;
    let mut chart = ChartBuilder::on(area)
        .caption("Success rate against the uncertainty box (1 = the paper's)", ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..x1, 0.0..1.05)?;
    chart.configure_mesh().x_desc("uncertainty scale").y_desc("success rate").draw()?;
    for (i, (name, pts)) in curves.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let line = pts.iter().map(|p| (p.0, p.1));
        chart.draw_series(LineSeries::new(line, color.stroke_width(2)))?.label(*name).legend(
            move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)),
        );
        let bars = pts.iter().map(|p| PathElement::new(vec![(p.0, p.2), (p.0, p.3)], color));
        chart.draw_series(bars)?;
        chart.draw_series(pts.iter().map(|p| Circle::new((p.0, p.1), 4, color.filled())))?;
    }
    chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
    area.present()?;
    Ok(())
}
