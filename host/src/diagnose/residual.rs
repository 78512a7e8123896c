//! Residuals (measured minus predicted) of one trial: peg x, y, θ per frame and, where the
//! tracker imaged it, the probe tip; the inputs they are conditioned on (commanded probe
//! velocity, reversals, contact force, position); and the measurement floor, estimated from
//! the measurement's high-frequency part so it needs no model.

use super::data::TrialData;
use super::predict::Prediction;
use crate::geom::Vec2;
use serde::Serialize;

/// Noise standard deviations of the measurement channels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Noise {
    /// Peg position, per axis, µm.
    pub xy_um: f64,
    /// Peg angle, rad.
    pub theta_rad: f64,
    /// Imaged probe tip, per axis, µm.
    pub tip_um: f64,
}

/// Robust σ of white noise from second differences: median |Δ²| · 1.4826 / √6.
fn sigma_from_second_differences(v: &[f64]) -> Option<f64> {
    if v.len() < 5 {
        return None;
    }
    let mut d: Vec<f64> = v.windows(3).map(|w| (w[2] - 2.0 * w[1] + w[0]).abs()).collect();
    d.sort_by(f64::total_cmp);
    Some(d[d.len() / 2] * 1.4826 / 6f64.sqrt())
}

fn pooled(series: impl Iterator<Item = Vec<f64>>) -> Option<f64> {
    let s: Vec<f64> = series.filter_map(|v| sigma_from_second_differences(&v)).collect();
    (!s.is_empty()).then(|| (s.iter().map(|x| x * x).sum::<f64>() / s.len() as f64).sqrt())
}

impl Noise {
    /// The measurement floor of a batch, from the measured series themselves (the motion is
    /// smooth at 30 Hz, the tracker's noise is not).
    pub fn estimate(trials: &[TrialData]) -> Self {
        let ch = |f: &dyn Fn(&super::data::Measured) -> Option<f64>| {
            pooled(trials.iter().map(|t| t.frames.iter().filter_map(f).collect::<Vec<f64>>()))
        };
        let x = ch(&|m| Some(m.pose.x_um));
        let y = ch(&|m| Some(m.pose.y_um));
        let xy = match (x, y) {
            (Some(a), Some(b)) => ((a * a + b * b) / 2.0).sqrt(),
            _ => 1.0,
        };
        let th = ch(&|m| Some(m.pose.theta_rad)).unwrap_or(1e-3);
        let tx = ch(&|m| m.tip_um.map(|t| t.x));
        let ty = ch(&|m| m.tip_um.map(|t| t.y));
        let tip = match (tx, ty) {
            (Some(a), Some(b)) => ((a * a + b * b) / 2.0).sqrt(),
            _ => xy,
        };
        Self { xy_um: xy.max(0.02), theta_rad: th.max(2e-5), tip_um: tip.max(0.02) }
    }
}

/// One frame's residual and the inputs at it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameResidual {
    /// Stamp, s.
    pub t_s: f64,
    /// Peg residual x, y (µm) and θ (rad).
    pub peg: [f64; 3],
    /// Imaged-tip residual x, y (µm), when imaged.
    pub tip: Option<[f64; 2]>,
    /// Commanded probe velocity at the stamp, µm/s.
    pub cmd_vel_um_s: Vec2,
    /// Measured peg position, µm.
    pub pos_um: Vec2,
    /// Predicted probe contact force, part weights.
    pub force: f64,
    /// Time since the last commanded direction reversal (either axis), s (∞ if none yet).
    pub since_reversal_s: f64,
}

/// All residuals of one trial.
#[derive(Debug, Clone, PartialEq)]
pub struct Residual {
    /// Per frame, in time order.
    pub frames: Vec<FrameResidual>,
}

/// Commanded velocity at `t_s` and the time of the latest reversal before it.
fn cmd_state(data: &TrialData, t_s: f64) -> (Vec2, f64) {
    let c = &data.cmd;
    let i = c.partition_point(|p| p.t_s <= t_s).clamp(1, c.len() - 1);
    let dt = (c[i].t_s - c[i - 1].t_s).max(1e-9);
    let v = (c[i].probe_um - c[i - 1].probe_um) / dt;
    let mut last_rev = f64::NEG_INFINITY;
    let mut last_sign = [0.0f64; 2];
    for k in 1..i {
        let d = c[k].probe_um - c[k - 1].probe_um;
        for (a, s) in last_sign.iter_mut().enumerate() {
            let da = if a == 0 { d.x } else { d.y };
            if da.abs() > 1e-6 {
                if *s != 0.0 && da.signum() != *s {
                    last_rev = c[k].t_s;
                }
                *s = da.signum();
            }
        }
    }
    (v, t_s - last_rev)
}

impl Residual {
    /// Measured minus predicted for every frame of `data`.
    pub fn new(data: &TrialData, pred: &Prediction) -> Self {
        let frames = data
            .frames
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let p = pred.poses[i];
                let (cmd_vel_um_s, since_reversal_s) = cmd_state(data, m.t_s);
                FrameResidual {
                    t_s: m.t_s,
                    peg: [
                        m.pose.x_um - p.x_um,
                        m.pose.y_um - p.y_um,
                        m.pose.theta_rad - p.theta_rad,
                    ],
                    tip: m.tip_um.map(|t| [t.x - pred.tips_um[i].x, t.y - pred.tips_um[i].y]),
                    cmd_vel_um_s,
                    pos_um: m.pose.position(),
                    force: pred.force[i],
                    since_reversal_s,
                }
            })
            .collect();
        Self { frames }
    }

    /// Σ squared residuals over noise variances, and how many scalars entered.
    pub fn weighted_sse(&self, noise: &Noise) -> (f64, usize) {
        let (wxy, wth, wtip) =
            (noise.xy_um.powi(-2), noise.theta_rad.powi(-2), noise.tip_um.powi(-2));
        let mut s = 0.0;
        let mut n = 0;
        for f in &self.frames {
            s += (f.peg[0].powi(2) + f.peg[1].powi(2)) * wxy + f.peg[2].powi(2) * wth;
            n += 3;
            if let Some(t) = f.tip {
                s += (t[0].powi(2) + t[1].powi(2)) * wtip;
                n += 2;
            }
        }
        (s, n)
    }
}

/// Mean squared errors of a set of residuals: `xy_um2` = mean of dx² + dy² (the X,Y MSE of
/// Table I), `theta_rad2` = mean dθ², `tip_um2` = mean imaged-tip dx² + dy² (0 when none).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Mse {
    /// Peg position, µm².
    pub xy_um2: f64,
    /// Peg angle, rad².
    pub theta_rad2: f64,
    /// Imaged probe tip, µm².
    pub tip_um2: f64,
}

impl Mse {
    /// Over every frame of `residuals`.
    pub fn of(residuals: &[Residual]) -> Self {
        let (mut xy, mut th, mut tip, mut n, mut nt) = (0.0, 0.0, 0.0, 0usize, 0usize);
        for f in residuals.iter().flat_map(|r| &r.frames) {
            xy += f.peg[0].powi(2) + f.peg[1].powi(2);
            th += f.peg[2].powi(2);
            n += 1;
            if let Some(t) = f.tip {
                tip += t[0].powi(2) + t[1].powi(2);
                nt += 1;
            }
        }
        let n = n.max(1) as f64;
        Self { xy_um2: xy / n, theta_rad2: th / n, tip_um2: tip / nt.max(1) as f64 }
    }

    /// The error in noise units (1 per channel at the floor), peg and tip channels summed.
    pub fn normalised(&self, noise: &Noise, with_tip: bool) -> f64 {
        let peg =
            self.xy_um2 / (2.0 * noise.xy_um.powi(2)) + self.theta_rad2 / noise.theta_rad.powi(2);
        peg + if with_tip { self.tip_um2 / (2.0 * noise.tip_um.powi(2)) } else { 0.0 }
    }
}
