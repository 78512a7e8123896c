//! Planning figures: a plan's nominal replay (Fig. 6 style), where Monte Carlo failures come
//! from (the trials' start offsets and friction, coloured by outcome) and the success rate
//! against the size of the uncertainty box. All drawn through [`mesopush_plot::save()`].

use crate::Error;
use crate::montecarlo::{SampleOutcome, SweepPoint};
use mesopush_plot::legend_band::{Entry, Mark, band_px, draw_legend};
use mesopush_plot::{DrawResult, Figure, PlanFigure, draw_plan, save};
use mesopush_sim::{Plan, Replay, Simulator, replay};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// A coordinate of a trial for a scatter axis.
type Coord<'a> = &'a dyn Fn(&SampleOutcome) -> f64;

/// Replays `plan` in `sim` and draws the replay (peg outlines and probe tips over the
/// fixture) to `path` (.png or .svg).
pub fn draw_replayed_plan(sim: &mut Simulator, plan: &Plan, path: &Path) -> Result<(), Error> {
    let r = replay(sim, plan, None)?;
    draw_replay(sim, plan, &r, path)
}

/// Draws `r`, a replay of `plan` in `sim`, as a plan view (walls, goal, peg outlines, probe
/// path; the title says whether it inserted) to `path`.
pub fn draw_replay(sim: &Simulator, plan: &Plan, r: &Replay, path: &Path) -> Result<(), Error> {
    let poses: Vec<_> = r.samples.iter().map(|s| s.peg).collect();
    let probe: Vec<_> = r.samples.iter().map(|s| s.probe_um).collect();
    let title = format!("{} — {}", plan.name, if r.inserted { "inserted" } else { "NOT inserted" });
    let fig = PlanFigure {
        title: &title,
        walls: &sim.fixture().walls,
        goal: Some(&sim.fixture().goal),
        goal_whole_part: sim.fixture().goal_whole_part,
        part: sim.model().part.polygon(),
        poses: &poses,
        probe_um: &probe,
        max_outlines: 25,
    };
    Ok(draw_plan(&fig, path)?)
}

/// Scatter of the trials' start offsets (Δx, Δy) and (Δθ, mean support μ), successes green,
/// failures red.
#[derive(Debug, Clone, Copy)]
pub struct FailuresFigure<'a> {
    /// Title.
    pub title: &'a str,
    /// The trials.
    pub trials: &'a [SampleOutcome],
}

/// Draws [`FailuresFigure`] to `path` (.png or .svg).
pub fn draw_failures(title: &str, trials: &[SampleOutcome], path: &Path) -> Result<(), Error> {
    Ok(save(&FailuresFigure { title, trials }, path, (1200, 560 + band_px(2)))?)
}

/// The range of `f` over `trials` with a 5 % margin ((−1, 1) when it is empty or flat).
fn span(trials: &[SampleOutcome], f: Coord<'_>) -> (f64, f64) {
    let (lo, hi) = trials
        .iter()
        .map(f)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    if lo.is_finite() && hi > lo {
        (lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo))
    } else {
        (-1.0, 1.0)
    }
}

impl Figure for FailuresFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        area.fill(&WHITE)?;
        let (_, h) = area.dim_in_pixel();
        let (top, band) = area.split_vertically(h.saturating_sub(band_px(2)));
        let top = top.titled(self.title, ("sans-serif", 20))?;
        let panels = top.split_evenly((1, 2));
        let mu = |t: &SampleOutcome| t.draw.model.support.mu_surface.iter().sum::<f64>() / 3.0;
        let axes: [(Coord<'_>, Coord<'_>, &str, &str); 2] = [
            (&|t| t.draw.offset[0], &|t| t.draw.offset[1], "start Δx [µm]", "start Δy [µm]"),
            (&|t| t.draw.offset[2], &mu, "start Δθ [°]", "mean support μ"),
        ];
        for (panel, (fx, fy, xl, yl)) in panels.iter().zip(axes) {
            scatter(panel, self.trials, (fx, fy), (xl, yl))?;
        }
        let legend = [
            Entry::new(Mark::Dot(GREEN.to_rgba()), "inserted"),
            Entry::new(
                Mark::Cross(RED.to_rgba()),
                "failed (jammed, missed or the needle overloaded)",
            ),
        ];
        draw_legend(&band, &legend)?;
        area.present()?;
        Ok(())
    }
}

/// One panel of [`FailuresFigure`]: `trials` at (`f.0`, `f.1`), axes labelled `labels`.
fn scatter<DB: DrawingBackend>(
    panel: &DrawingArea<DB, Shift>,
    trials: &[SampleOutcome],
    (fx, fy): (Coord<'_>, Coord<'_>),
    (xl, yl): (&str, &str),
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let (x0, x1) = span(trials, fx);
    let (y0, y1) = span(trials, fy);
    let mut chart = ChartBuilder::on(panel)
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart.configure_mesh().x_desc(xl).y_desc(yl).draw()?;
    let ok = trials.iter().filter(|t| t.inserted);
    chart.draw_series(ok.map(|t| Circle::new((fx(t), fy(t)), 3, GREEN.mix(0.6).filled())))?;
    let bad = trials.iter().filter(|t| !t.inserted);
    chart.draw_series(bad.map(|t| Cross::new((fx(t), fy(t)), 5, RED.stroke_width(2))))?;
    Ok(())
}

/// One curve of success rate against the uncertainty scale: the plan's name and its points.
pub type SweepCurve<'a> = (&'a str, &'a [SweepPoint]);

/// Success rate (with its 95 % interval) against the uncertainty box's scale, one curve per
/// plan.
#[derive(Debug, Clone, Copy)]
pub struct SweepFigure<'a> {
    /// The curves.
    pub curves: &'a [SweepCurve<'a>],
}

/// Draws [`SweepFigure`] to `path` (.png or .svg).
pub fn draw_sweep(curves: &[SweepCurve<'_>], path: &Path) -> Result<(), Error> {
    Ok(save(&SweepFigure { curves }, path, (900, 600))?)
}

impl Figure for SweepFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        area.fill(&WHITE)?;
        let all = || self.curves.iter().flat_map(|c| c.1.iter().map(|p| p.scale));
        let x1 = all().fold(1.0, f64::max) + 0.1;
        let x0 = (all().fold(1.0, f64::min) - 0.1).max(0.0);
        let mut chart = ChartBuilder::on(area)
            .caption(
                "Success rate against the uncertainty box (1 = the paper's)",
                ("sans-serif", 20),
            )
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, 0.0..1.05)?;
        chart
            .configure_mesh()
            .x_desc("uncertainty box scale (start pose and model ranges; 1 = the paper's)")
            .y_desc("share of sampled worlds inserted")
            .draw()?;
        for (i, (name, pts)) in self.curves.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            let line = pts.iter().map(|p| (p.scale, p.success_rate));
            chart.draw_series(LineSeries::new(line, color.stroke_width(2)))?.label(*name).legend(
                move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)),
            );
            let bars = pts
                .iter()
                .map(|p| PathElement::new(vec![(p.scale, p.ci_low), (p.scale, p.ci_high)], color));
            let drawn = chart.draw_series(bars)?;
            if i + 1 == self.curves.len() {
                drawn.label("Wilson 95 % interval (bars)").legend(|(x, y)| {
                    PathElement::new(vec![(x + 10, y - 6), (x + 10, y + 6)], BLACK)
                });
            }
            let dots =
                pts.iter().map(|p| Circle::new((p.scale, p.success_rate), 4, color.filled()));
            chart.draw_series(dots)?;
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
}
