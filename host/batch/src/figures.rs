//! The report's figures (plotters, PNG): success over time (the running success rate with
//! its Wilson 95 % band, by trial index), the final-pose scatter over the fixture (coloured
//! by verdict), and the wall time of every trial.

use super::journal::AttemptRecord;
use super::runner::TrialVerdict;
use super::stats::wilson95;
use crate::Error;
use mesopush_core::geom::ConvexPolygon;
use mesopush_plot::DrawResult;
use mesopush_plot::fixture_view::{
    VIEW_UM, figure_px, fixture_chart, fixture_legend, split_legend,
};
use mesopush_plot::legend_band::{Entry, Mark, draw_legend};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::path::Path;

fn colour(v: TrialVerdict) -> RGBColor {
    match v {
        TrialVerdict::Inserted => RGBColor(30, 140, 60),
        TrialVerdict::Missed => RGBColor(200, 120, 0),
        TrialVerdict::Faulted => RGBColor(200, 30, 30),
        TrialVerdict::Timeout => RGBColor(120, 40, 160),
        TrialVerdict::Error => RGBColor(20, 20, 20),
    }
}

fn fail(path: &Path) -> impl Fn(mesopush_plot::Error) -> Error + '_ {
    move |e| Error::Plot(e.at(path))
}

/// Running success rate with its 95 % band, by trial index.
pub fn success_over_time(finals: &[&AttemptRecord], path: &Path) -> Result<(), Error> {
    let draw = || -> DrawResult {
        mesopush_plot::font::register()?;
        let area = BitMapBackend::new(path, (900, 450)).into_drawing_area();
        area.fill(&WHITE)?;
        let n_max = finals.last().map_or(1, |a| a.index + 1) as f64;
        let mut chart = ChartBuilder::on(&area)
            .caption("Success over the batch (running rate, Wilson 95 % band)", ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..n_max, 0.0..1.45)?;
        chart
            .configure_mesh()
            .x_desc("trial index")
            .y_desc("share of trials inserted so far")
            .y_labels(8)
            .draw()?;
        let (mut k, mut rate, mut lo, mut hi) = (0u64, vec![], vec![], vec![]);
        for (i, a) in finals.iter().enumerate() {
            k += u64::from(a.result.verdict == TrialVerdict::Inserted);
            let n = i as u64 + 1;
            let x = a.index as f64;
            let [l, h] = wilson95(k, n);
            rate.push((x, k as f64 / n as f64));
            lo.push((x, l));
            hi.push((x, h));
        }
        let band: Vec<_> = hi.iter().copied().chain(lo.iter().rev().copied()).collect();
        chart
            .draw_series(std::iter::once(Polygon::new(band, BLUE.mix(0.15).filled())))?
            .label("Wilson 95 % band")
            .legend(|(x, y)| {
                Rectangle::new([(x, y - 5), (x + 20, y + 5)], BLUE.mix(0.15).filled())
            });
        chart
            .draw_series(LineSeries::new(rate, BLUE.stroke_width(2)))?
            .label("running success rate")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE.stroke_width(2)));
        verdict_dots(
            &mut chart,
            finals,
            |a| {
                let y = if a.result.verdict == TrialVerdict::Inserted { 1.0 } else { 0.0 };
                (a.index as f64, y)
            },
            |v| {
                let y = if v == TrialVerdict::Inserted { 1 } else { 0 };
                format!("trial {} (marked at {y})", v.as_str())
            },
        )?;
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .border_style(BLACK)
            .background_style(WHITE)
            .draw()?;
        area.present()?;
        Ok(())
    };
    draw().map_err(fail(path))
}

/// Final peg positions over the fixture, coloured by verdict.
pub fn final_poses(
    finals: &[&AttemptRecord],
    walls: &[ConvexPolygon],
    goal: Option<&ConvexPolygon>,
    path: &Path,
) -> Result<(), Error> {
    let draw = || -> DrawResult {
        mesopush_plot::font::register()?;
        // Walls, field, goal and one entry per verdict with a final pose.
        let present = TrialVerdict::ALL
            .iter()
            .filter(|v| {
                finals.iter().any(|a| a.result.verdict == **v && a.result.final_pose.is_some())
            })
            .count();
        let entries = 2 + usize::from(goal.is_some()) + present;
        let area = BitMapBackend::new(path, figure_px(entries)).into_drawing_area();
        let (top, band) = split_legend(&area, entries)?;
        let title = "Final peg positions (centre of mass) by verdict";
        let mut chart = fixture_chart(&top, title, walls)?;
        let mut legend = fixture_legend();
        let (x0, x1, y0, y1) = VIEW_UM;
        if let Some(g) = goal {
            let mut pts: Vec<_> =
                g.vertices().iter().map(|v| (v.x.clamp(x0, x1), v.y.clamp(y0, y1))).collect();
            pts.push(pts[0]);
            chart.draw_series(std::iter::once(PathElement::new(pts, GREEN.stroke_width(2))))?;
            legend.push(Entry::new(Mark::Line(GREEN.to_rgba(), 2), "goal region"));
        }
        for v in TrialVerdict::ALL {
            let pts: Vec<(f64, f64)> = finals
                .iter()
                .filter(|a| a.result.verdict == v)
                .filter_map(|a| {
                    a.result.final_pose.map(|p| (p.x_um.clamp(x0, x1), p.y_um.clamp(y0, y1)))
                })
                .collect();
            if pts.is_empty() {
                continue;
            }
            let c = colour(v);
            chart.draw_series(pts.iter().map(|p| Circle::new(*p, 3, c.filled())))?;
            let text = format!("{} ({})", v.as_str(), pts.len());
            legend.push(Entry::new(Mark::Dot(c.to_rgba()), text));
        }
        draw_legend(&band, &legend)?;
        area.present()?;
        Ok(())
    };
    draw().map_err(fail(path))
}

/// What a trial's wall time covers under `runner` (the batch file's `runner`).
pub fn what_is_timed(runner: &str) -> &'static str {
    match runner {
        "rig" => "the whole loop on the firmware simulator (executor, controller, camera, tracker)",
        _ => "the host simulator and the tracker in one process (no executor, no controller)",
    }
}

/// Wall time of every trial (final attempt), by trial index, coloured by verdict; `runner`
/// names what was timed.
pub fn timing(finals: &[&AttemptRecord], runner: &str, path: &Path) -> Result<(), Error> {
    let draw = || -> DrawResult {
        mesopush_plot::font::register()?;
        let area = BitMapBackend::new(path, (900, 400)).into_drawing_area();
        area.fill(&WHITE)?;
        let n_max = finals.last().map_or(1, |a| a.index + 1) as f64;
        let t_max = finals.iter().map(|a| a.wall_time_s * 1e3).fold(1.0, f64::max) * 1.1;
        let mut chart = ChartBuilder::on(&area)
            .caption(
                format!("Wall time per trial, log writes included: {}", what_is_timed(runner)),
                ("sans-serif", 15),
            )
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(55)
            .build_cartesian_2d(0.0..n_max, 0.0..t_max * 1.3)?;
        chart.configure_mesh().x_desc("trial index").y_desc("wall time (ms)").draw()?;
        verdict_dots(
            &mut chart,
            finals,
            |a| (a.index as f64, a.wall_time_s * 1e3),
            |v| format!("trial {}", v.as_str()),
        )?;
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .border_style(BLACK)
            .background_style(WHITE)
            .draw()?;
        area.present()?;
        Ok(())
    };
    draw().map_err(fail(path))
}

/// One series of dots per verdict (absent verdicts skipped), each in the verdict's colour and
/// named in the legend: `at` places a trial, `label` names a verdict.
fn verdict_dots(
    chart: &mut ChartContext<'_, BitMapBackend<'_>, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    finals: &[&AttemptRecord],
    at: impl Fn(&AttemptRecord) -> (f64, f64),
    label: impl Fn(TrialVerdict) -> String,
) -> DrawResult {
    for v in TrialVerdict::ALL {
        let c = colour(v);
        let dots: Vec<_> = finals
            .iter()
            .filter(|a| a.result.verdict == v)
            .map(|a| Circle::new(at(a), 2, c.filled()))
            .collect();
        if dots.is_empty() {
            continue;
        }
        chart
            .draw_series(dots)?
            .label(label(v))
            .legend(move |(x, y)| Circle::new((x + 8, y), 3, c.filled()));
    }
    Ok(())
}
