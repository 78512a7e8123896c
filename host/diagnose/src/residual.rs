//! Residuals (measured minus predicted) of one trial: peg x, y, θ per frame and, where the
//! tracker imaged it, the probe tip; the inputs they are conditioned on (commanded probe
//! velocity, reversals, contact force, position); and the measurement floor, estimated from
//! the measurement's high-frequency part so it needs no model.

use super::data::TrialData;
use super::predict::Prediction;
use mesopush_core::geom::Vec2;
use mesopush_core::stats::percentile;
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

/// Robust σ of white noise from second differences: median |Δ²| · 1.4826 / √6, the median
/// taken as the sample at rank n/2 (the upper one of an even count:
/// [`percentile`] at 0.5, not the mean of the middle two).
fn sigma_of(mut d: Vec<f64>) -> Option<f64> {
    if d.len() < 3 {
        return None;
    }
    percentile(&mut d, 0.5).map(|m| m * 1.4826 / 6f64.sqrt())
}

/// The σ of one series' noise: from every window's second difference, unless the series
/// repeats itself exactly at rest (a third of its windows or more with a second difference
/// of exactly zero: a deterministic tracker on a noise-free image gives the same pose for
/// the same picture), then from the windows where the object moves steadily (`moving[k]`
/// for the window centred on frame k + 1), where its place on the pixel grid changes and
/// the tracker's error shows. A real camera's sensor noise shows at rest, and there most
/// frames of a trial are.
fn sigma_series(v: &[f64], moving: &[bool]) -> Option<f64> {
    let d2: Vec<f64> = v.windows(3).map(|w| (w[2] - 2.0 * w[1] + w[0]).abs()).collect();
    let scale = v.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1.0);
    let repeats = d2.iter().filter(|d| **d <= 1e-12 * scale).count();
    if 3 * repeats < d2.len() {
        return sigma_of(d2);
    }
    sigma_of(d2.iter().zip(moving).filter(|(_, m)| **m).map(|(d, _)| *d).collect())
}

/// Pools per-series σ estimates (root mean square).
fn pooled(series: impl Iterator<Item = (Vec<f64>, Vec<bool>)>) -> Option<f64> {
    let s: Vec<f64> = series.filter_map(|(v, m)| sigma_series(&v, &m)).collect();
    (!s.is_empty()).then(|| (s.iter().map(|x| x * x).sum::<f64>() / s.len() as f64).sqrt())
}

/// Per window of three frames (centred on frame k + 1): whether `pos` moved by more than
/// `thr` (a step no noise makes) in both of its frame steps (the object moves through the
/// whole window: no contact onset or stop inside it).
fn moving_windows(pos: &[Vec2], thr: f64) -> Vec<bool> {
    pos.windows(3).map(|w| (w[1] - w[0]).norm() > thr && (w[2] - w[1]).norm() > thr).collect()
}

/// Margin around a window in which the command must not change, s: covers a camera's
/// timestamp latency (up to ~100 ms) and the stage's response.
const STEADY_MARGIN_S: f64 = 0.12;

/// Whether the commanded probe velocity is one and the same (within 5 %, not zero) over
/// `[t0_s − margin, t1_s + margin]`: a quasi-static push at a steady command moves the peg
/// smoothly, so the second differences there are the tracker's, not the motion's (contact
/// onset, release and reversals change the peg's velocity within a frame).
fn steady_command(cmd: &[mesopush_sim::ProbePoint], t0_s: f64, t1_s: f64) -> bool {
    let (a, b) = (t0_s - STEADY_MARGIN_S, t1_s + STEADY_MARGIN_S);
    let i0 = cmd.partition_point(|p| p.t_s <= a).max(1);
    let i1 = cmd.partition_point(|p| p.t_s < b);
    if i0 >= cmd.len() || i1 >= cmd.len() {
        return false;
    }
    let vel = |i: usize| {
        let dt = cmd[i].t_s - cmd[i - 1].t_s;
        (dt > 0.0).then(|| (cmd[i].probe_um - cmd[i - 1].probe_um) / dt)
    };
    let Some(v0) = vel(i0) else { return false };
    if v0.norm() < 1.0 {
        return false;
    }
    (i0..=i1).all(|i| vel(i).is_none_or(|v| (v - v0).norm() <= 0.05 * v0.norm()))
}

/// Per window of three frames of `t`: whether the peg moves (see [`moving_windows`]) under
/// a steady command.
fn steady_peg_windows(t: &TrialData, thr: f64) -> Vec<bool> {
    let pos: Vec<Vec2> = t.frames.iter().map(|m| m.pose.position()).collect();
    moving_windows(&pos, thr)
        .into_iter()
        .zip(t.frames.windows(3))
        .map(|(m, w)| m && steady_command(&t.cmd, w[0].t_s, w[2].t_s))
        .collect()
}

impl Noise {
    /// The measurement floor of a batch, from the measured series themselves (the motion is
    /// smooth at 30 Hz, the tracker's noise is not): second differences over all frames, or,
    /// for a tracker that repeats itself exactly at rest, over the frames where the peg (for
    /// the pose channels) or the tip (for the tip channel) moves under a steady command —
    /// see `sigma_series` and `steady_command`. No simulator and no declared noise enter.
    pub fn estimate(trials: &[TrialData]) -> Self {
        // Moving: more than 1 µm per frame step (a tracker's noise is well below, a push at
        // ≥ 30 µm/s filmed at ≤ 30 Hz is above).
        const MOVE_UM: f64 = 1.0;
        let ch =
            |f: &dyn Fn(&super::data::Measured) -> Option<f64>| {
                pooled(trials.iter().map(|t| {
                    (t.frames.iter().filter_map(f).collect(), steady_peg_windows(t, MOVE_UM))
                }))
            };
        let x = ch(&|m| Some(m.pose.x_um));
        let y = ch(&|m| Some(m.pose.y_um));
        let xy = match (x, y) {
            (Some(a), Some(b)) => ((a * a + b * b) / 2.0).sqrt(),
            _ => 1.0,
        };
        let th = ch(&|m| Some(m.pose.theta_rad)).unwrap_or(1e-3);
        let tip_ch = |f: &dyn Fn(&Vec2) -> f64| {
            pooled(trials.iter().filter(|t| t.has_tips()).map(|t| {
                let tips: Vec<(f64, Vec2)> =
                    t.frames.iter().filter_map(|m| m.tip_um.map(|p| (m.t_s, p))).collect();
                let pos: Vec<Vec2> = tips.iter().map(|p| p.1).collect();
                let steady = moving_windows(&pos, MOVE_UM)
                    .into_iter()
                    .zip(tips.windows(3))
                    .map(|(m, w)| m && steady_command(&t.cmd, w[0].0, w[2].0))
                    .collect();
                (pos.iter().map(f).collect(), steady)
            }))
        };
        let tip = match (tip_ch(&|p| p.x), tip_ch(&|p| p.y)) {
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

/// The time of the latest commanded direction reversal (either axis) among the command's
/// first `i` points, for every `i` (entry 0 and 1: none, −∞): one pass over the command
/// instead of one per frame.
fn reversals_before(c: &[mesopush_sim::ProbePoint]) -> Vec<f64> {
    let mut out = Vec::with_capacity(c.len().max(2));
    out.extend([f64::NEG_INFINITY; 2]);
    let mut last_rev = f64::NEG_INFINITY;
    let mut last_sign = [0.0f64; 2];
    for k in 1..c.len().saturating_sub(1) {
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
        out.push(last_rev);
    }
    out
}

/// Commanded velocity at `t_s` and the time of the latest reversal before it
/// (`reversals` from [`reversals_before`] of the same command).
fn cmd_state(data: &TrialData, reversals: &[f64], t_s: f64) -> (Vec2, f64) {
    let c = &data.cmd;
    let i = c.partition_point(|p| p.t_s <= t_s).clamp(1, c.len() - 1);
    let dt = (c[i].t_s - c[i - 1].t_s).max(1e-9);
    let v = (c[i].probe_um - c[i - 1].probe_um) / dt;
    (v, t_s - reversals[i])
}

impl Residual {
    /// Measured minus predicted for every frame of `data` (the imaged tip as
    /// [`super::tip::tip_residuals`] explains).
    pub fn new(data: &TrialData, pred: &Prediction) -> Self {
        let tips = super::tip::tip_residuals(data, pred);
        let reversals = reversals_before(&data.cmd);
        let frames = data
            .frames
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let p = pred.poses[i];
                let (cmd_vel_um_s, since_reversal_s) = cmd_state(data, &reversals, m.t_s);
                FrameResidual {
                    t_s: m.t_s,
                    peg: [
                        m.pose.x_um - p.x_um,
                        m.pose.y_um - p.y_um,
                        m.pose.theta_rad - p.theta_rad,
                    ],
                    tip: tips[i],
                    cmd_vel_um_s,
                    pos_um: m.pose.position(),
                    force: pred.force[i],
                    since_reversal_s,
                }
            })
            .collect();
        Self { frames }
    }

    /// Appends every residual scalar divided by its channel's noise σ (peg x, y, θ, then the
    /// imaged tip x, y where imaged), frame by frame: the vector whose sum of squares is
    /// [`Residual::weighted_sse`].
    pub fn weighted_into(&self, noise: &Noise, out: &mut Vec<f64>) {
        for f in &self.frames {
            out.extend([
                f.peg[0] / noise.xy_um,
                f.peg[1] / noise.xy_um,
                f.peg[2] / noise.theta_rad,
            ]);
            if let Some(t) = f.tip {
                out.extend([t[0] / noise.tip_um, t[1] / noise.tip_um]);
            }
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::{Measured, open_plate};
    use mesopush_core::geom::Pose;
    use rand::{RngExt, SeedableRng};

    /// A tracker whose error depends only on where the peg lies (a rendered image: the same
    /// picture gives the same pose): exact repeats while the peg rests, an error of σ once
    /// it moves across pixels.
    fn rendered_like(sigma: f64, seed: u64) -> TrialData {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut frames = Vec::new();
        let mut x = 1000.0;
        for k in 0..300 {
            let moving = (k / 50) % 2 == 1;
            if moving {
                x += 10.0;
            }
            // A bias fixed by the place: drawn afresh for each new place, repeated at rest.
            let bias = if moving || k == 0 {
                let u: f64 = rng.random_range(-1.0..1.0);
                u * sigma * 3f64.sqrt()
            } else {
                frames.last().map_or(0.0, |f: &Measured| f.pose.x_um - x)
            };
            frames.push(Measured {
                t_s: k as f64 / 30.0,
                pose: Pose::new(x + bias, 800.0 + bias, 0.0),
                tip_um: None,
            });
        }
        // A steady command throughout (300 µm/s along x, 100 Hz setpoints).
        let cmd = (0..=1100)
            .map(|i| mesopush_sim::ProbePoint {
                t_s: i as f64 * 0.01,
                probe_um: mesopush_core::geom::Vec2::new(3.0 * i as f64, 0.0),
                probe_theta_rad: 0.0,
            })
            .collect();
        TrialData {
            id: format!("t{seed}"),
            index: seed as usize,
            part: mesopush_sim::Model::default().part,
            probe_radius_um: 12.5,
            pusher: mesopush_sim::Pusher::single(12.5),
            registration_tol_um: None,
            pose_rows_dropped: 0,
            log_gaps_s: Vec::new(),
            fixture: open_plate(),
            cmd,
            frames,
            start_sensitivity: None,
        }
    }

    /// The one-pass reversal times are the per-frame scan's (which cost a diagnosis 40 % of
    /// its time): a random walk of a command with pauses and reversals on both axes.
    #[test]
    fn reversals_in_one_pass_match_the_scan_up_to_each_point() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut p = Vec2::new(0.0, 0.0);
        let cmd: Vec<mesopush_sim::ProbePoint> = (0..400)
            .map(|i| {
                let step = |r: &mut rand_chacha::ChaCha8Rng| match r.random_range(0..4) {
                    0 => 0.0,
                    _ => r.random_range(-3.0..3.0),
                };
                p += Vec2::new(step(&mut rng), step(&mut rng));
                mesopush_sim::ProbePoint::new(i as f64 * 0.01, p)
            })
            .collect();
        let fast = reversals_before(&cmd);
        for (i, fast_i) in fast.iter().enumerate().skip(1) {
            let (mut last_rev, mut last_sign) = (f64::NEG_INFINITY, [0.0f64; 2]);
            for k in 1..i {
                let d = cmd[k].probe_um - cmd[k - 1].probe_um;
                for (a, s) in last_sign.iter_mut().enumerate() {
                    let da = if a == 0 { d.x } else { d.y };
                    if da.abs() > 1e-6 {
                        if *s != 0.0 && da.signum() != *s {
                            last_rev = cmd[k].t_s;
                        }
                        *s = da.signum();
                    }
                }
            }
            assert_eq!(fast_i.to_bits(), last_rev.to_bits(), "point {i}");
        }
        assert!(fast.iter().filter(|t| t.is_finite()).count() > 300, "reversals seen");
    }

    /// Caught by the full-loop backlash batch: a peg at rest in a rendered image tracks
    /// identically frame to frame, the median second difference over all frames was ~0 and
    /// the floor 6× too low, so a model mismatch looked significant.
    #[test]
    fn the_floor_of_a_tracker_that_repeats_at_rest_comes_from_the_moving_frames() {
        let trials: Vec<TrialData> = (0..4).map(|s| rendered_like(0.5, s)).collect();
        let n = Noise::estimate(&trials);
        assert!((0.35..0.7).contains(&n.xy_um), "floor {} µm, true 0.5", n.xy_um);
    }

    #[test]
    fn the_floor_of_white_noise_at_rest_is_its_sigma() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut t = rendered_like(0.0, 0);
        for f in &mut t.frames {
            f.pose.x_um += 0.3 * (rng.random_range(-1.0f64..1.0) * 3f64.sqrt());
            f.pose.y_um += 0.3 * (rng.random_range(-1.0f64..1.0) * 3f64.sqrt());
        }
        let n = Noise::estimate(&[t]);
        assert!((0.22..0.4).contains(&n.xy_um), "floor {} µm, true 0.3", n.xy_um);
    }
}
