//! Simulation against measurement, per trial a plan view (tracked and simulated outlines at
//! start, middle and end; centre-of-mass paths; the pusher's path) over the orientation
//! against time: the paper's Fig. 5 (best and worst trial under the identified parameters,
//! [`draw_fig5`]) and `mesopush replay`'s figure ([`draw_tracks`]).

use crate::Error;
use crate::IdentTrial;
use crate::score::{Candidate, Score, ScoreSettings, pose_at, simulate};
use mesopush_core::geom::Pose;
use mesopush_plot::fixture_view::equal_aspect;
use mesopush_plot::legend_band::{Entry, Mark, band_px, draw_legend};
use mesopush_plot::{DrawResult, Figure, save};
use mesopush_sim::{Part, ProbePoint};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// One trial's panel.
#[derive(Debug, Clone, Copy)]
pub struct Fig5Trial<'a> {
    /// The trial.
    pub trial: &'a IdentTrial,
    /// Panel label, e.g. `best`.
    pub label: &'a str,
    /// Its score under the candidate.
    pub score: Score,
}

/// Draws the panels side by side to `path` (`.png` or `.svg`).
pub fn draw_fig5(
    panels: &[Fig5Trial<'_>],
    c: &Candidate,
    settings: &ScoreSettings,
    path: &Path,
) -> Result<(), Error> {
    // The simulations run here, before drawing: the figure only draws what it is given.
    let sims: Vec<Option<Vec<(f64, Pose)>>> = panels
        .iter()
        .map(|p| {
            let (samples, _) = simulate(p.trial, c, settings)?;
            let t0 = p.trial.path[0].t_s;
            let at = p.trial.measured.iter().map(|(t, _)| (*t, pose_at(&samples, *t)));
            Some(std::iter::once((t0, p.trial.start)).chain(at).collect())
        })
        .collect();
    let tracks: Vec<TrackPanel<'_>> = panels
        .iter()
        .zip(sims)
        .map(|(p, sim)| TrackPanel {
            part: &p.trial.part,
            path: &p.trial.path,
            measured: std::iter::once((p.trial.path[0].t_s, p.trial.start))
                .chain(p.trial.measured.iter().copied())
                .collect(),
            title: format!(
                "{} trial {}: X,Y MSE {:.3} µm², θ MSE {:.5} deg²",
                p.label,
                p.trial.id,
                p.score.xy_mse_um2,
                p.score.theta_mse_deg2()
            ),
            sim,
        })
        .collect();
    draw_tracks(&tracks, path)
}

/// One panel of a tracks figure: a trial's part, pusher path and measured poses, the
/// simulated poses at the same times (`None`: the simulation failed; the panel stays
/// empty), and a title.
#[derive(Debug, Clone)]
pub struct TrackPanel<'a> {
    /// The pushed part.
    pub part: &'a Part,
    /// The pusher's path (its reference point).
    pub path: &'a [ProbePoint],
    /// Measured poses as (time s, pose), the start first.
    pub measured: Vec<(f64, Pose)>,
    /// Simulated poses at the measured times (the same length as `measured`).
    pub sim: Option<Vec<(f64, Pose)>>,
    /// The panel's title.
    pub title: String,
}

/// Draws the panels side by side to `path` (`.png` or `.svg`).
pub fn draw_tracks(panels: &[TrackPanel<'_>], path: &Path) -> Result<(), Error> {
    let size = (720 * panels.len().max(1) as u32, 800 + band_px(LEGEND.len()));
    Ok(save(&Tracks { panels }, path, size)?)
}

struct Tracks<'a> {
    panels: &'a [TrackPanel<'a>],
}

/// The legend, in a band under the panels (never over the data): what each mark is (the
/// outlines are at the start, the middle and the end; the simulation at the tracked times).
const LEGEND: [(Mark, &str); 5] = [
    (Mark::Line(RGBAColor(0, 0, 0, 0.5), 1), "pusher (reference point)"),
    (Mark::Line(RGBAColor(0, 0, 255, 1.0), 2), "tracked: outlines, centre path"),
    (Mark::Line(RGBAColor(255, 0, 0, 1.0), 1), "simulated: outlines, centre path"),
    (Mark::Dot(RGBAColor(0, 0, 255, 1.0)), "tracked θ"),
    (Mark::Line(RGBAColor(255, 0, 0, 1.0), 2), "simulated θ"),
];

impl Figure for Tracks<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        area.fill(&WHITE)?;
        let (_, h) = area.dim_in_pixel();
        let (panels, band) = area.split_vertically(h.saturating_sub(band_px(LEGEND.len())));
        let legend: Vec<Entry> = LEGEND.iter().map(|(m, t)| Entry::new(*m, *t)).collect();
        draw_legend(&band, &legend)?;
        let cells = panels.split_evenly((1, self.panels.len().max(1)));
        for (panel, cell) in self.panels.iter().zip(cells) {
            let Some(sim) = panel.sim.as_ref().filter(|s| s.len() == panel.measured.len()) else {
                continue;
            };
            let (top, bottom) = cell.split_vertically(520);
            plan_view(&top, panel, sim)?;
            theta_view(&bottom, panel, sim)?;
        }
        area.present()?;
        Ok(())
    }
}

fn outline(part: &mesopush_sim::Part, pose: &Pose) -> Vec<(f64, f64)> {
    let mut pts: Vec<(f64, f64)> =
        part.polygon().transformed(pose).vertices().iter().map(|v| (v.x, v.y)).collect();
    pts.push(pts[0]);
    pts
}

fn plan_view<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &TrackPanel<'_>,
    sim: &[(f64, Pose)],
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let meas: Vec<Pose> = p.measured.iter().map(|m| m.1).collect();
    let mut pts: Vec<(f64, f64)> = p.path.iter().map(|q| (q.probe_um.x, q.probe_um.y)).collect();
    for pose in meas.iter().chain(sim.iter().map(|s| &s.1)) {
        pts.extend(outline(p.part, pose));
    }
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in &pts {
        (x0, x1, y0, y1) = (x0.min(*x), x1.max(*x), y0.min(*y), y1.max(*y));
    }
    // Equal aspect: µm per pixel the same along x and y over the plotting area (the cell
    // less its caption, margins and label areas), the data with a margin of 5 % of the part.
    let body = area.titled(&p.title, ("sans-serif", 13))?;
    let (margin, x_label, y_label) = (10u32, 30u32, 70u32);
    let (w_px, h_px) = body.dim_in_pixel();
    let plot_px = (
        f64::from(w_px.saturating_sub(2 * margin + y_label).max(1)),
        f64::from(h_px.saturating_sub(2 * margin + x_label).max(1)),
    );
    let pad = 0.05 * p.part.char_length_um();
    let (vx0, vx1, vy0, vy1) = equal_aspect((x0 - pad, x1 + pad, y0 - pad, y1 + pad), plot_px);
    let mut chart = ChartBuilder::on(&body)
        .margin(margin)
        .x_label_area_size(x_label)
        .y_label_area_size(y_label)
        .build_cartesian_2d(vx0..vx1, vy1..vy0)?;
    chart.configure_mesh().x_desc("x [µm]").y_desc("y [µm] (down)").disable_mesh().draw()?;
    let probe: Vec<(f64, f64)> = p.path.iter().map(|q| (q.probe_um.x, q.probe_um.y)).collect();
    chart.draw_series(std::iter::once(PathElement::new(probe, BLACK.mix(0.5).stroke_width(1))))?;
    let n = meas.len() - 1;
    for k in [0, n / 2, n] {
        chart.draw_series(std::iter::once(PathElement::new(
            outline(p.part, &meas[k]),
            BLUE.stroke_width(2),
        )))?;
        chart.draw_series(std::iter::once(PathElement::new(
            outline(p.part, &sim[k].1),
            RED.stroke_width(1),
        )))?;
    }
    let mpath: Vec<(f64, f64)> = meas.iter().map(|q| (q.x_um, q.y_um)).collect();
    chart.draw_series(std::iter::once(PathElement::new(mpath, BLUE.stroke_width(2))))?;
    let spath: Vec<(f64, f64)> = sim.iter().map(|q| (q.1.x_um, q.1.y_um)).collect();
    chart.draw_series(std::iter::once(PathElement::new(spath, RED.stroke_width(1))))?;
    Ok(())
}

fn theta_view<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &TrackPanel<'_>,
    sim: &[(f64, Pose)],
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let deg = |r: f64| r.to_degrees();
    let meas: Vec<(f64, f64)> = p.measured.iter().map(|(t, q)| (*t, deg(q.theta_rad))).collect();
    let simd: Vec<(f64, f64)> = sim.iter().map(|(t, q)| (*t, deg(q.theta_rad))).collect();
    let times = p.path.iter().map(|q| q.t_s).chain(p.measured.iter().map(|m| m.0));
    let (t0, t1) = times.fold((f64::MAX, f64::MIN), |(a, b), t| (a.min(t), b.max(t)));
    let all = meas.iter().chain(&simd).map(|v| v.1);
    let (lo, hi) = all.fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
    let pad = 0.05 * (hi - lo).max(0.1);
    let mut chart = ChartBuilder::on(area)
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(50)
        .build_cartesian_2d(t0..t1, lo - pad..hi + pad)?;
    chart.configure_mesh().x_desc("t [s]").y_desc("θ [deg]").draw()?;
    chart.draw_series(meas.iter().map(|v| Circle::new(*v, 2, BLUE.filled())))?;
    chart.draw_series(std::iter::once(PathElement::new(simd, RED.stroke_width(2))))?;
    Ok(())
}
