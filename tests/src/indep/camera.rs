//! The camera and tracker: 30 Hz frames stamped from the trial's start, each showing the
//! truth `delay` before its stamp (camera latency), through the image's scale error about
//! its origin, with tracker noise on the part's pose and on the imaged needle.

use super::effects::Effect;
use super::physics::Truth;
use super::rng::Rng;
use crate::coulomb::{Pose, V2};

/// Frames per second.
pub const FRAME_RATE_HZ: f64 = 30.0;
/// The nominal frame period as trial.json states it, µs.
pub const FRAME_PERIOD_US: f64 = 33333.3;

/// Tracker noise (standard deviations).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Noise {
    /// Part position per axis, µm.
    pub xy_um: f64,
    /// Part angle, rad.
    pub theta_rad: f64,
    /// Imaged needle per axis, µm.
    pub tip_um: f64,
}

impl Default for Noise {
    fn default() -> Self {
        Self { xy_um: 1.0, theta_rad: 0.002, tip_um: 1.0 }
    }
}

/// One tracked frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Stamp, µs since the trial's start.
    pub t_us: i64,
    /// Frame index.
    pub index: u64,
    /// Tracked part pose.
    pub pose: Pose,
    /// Imaged needle centre, µm.
    pub tip: V2,
}

/// What the image shows of the world point `p` (the scale error about its origin).
fn imaged(p: V2, effect: &Effect) -> V2 {
    match *effect {
        Effect::Scale { gain, origin_um } => V2::new(
            origin_um[0] + (p.x - origin_um[0]) * (1.0 + gain[0]),
            origin_um[1] + (p.y - origin_um[1]) * (1.0 + gain[1]),
        ),
        _ => p,
    }
}

/// The imaged angle: the direction of the image of the part's body x axis.
fn imaged_angle(theta: f64, effect: &Effect) -> f64 {
    let Effect::Scale { gain, .. } = *effect else {
        return theta;
    };
    let (s, c) = theta.sin_cos();
    let d = (s * (1.0 + gain[1])).atan2(c * (1.0 + gain[0])) - theta;
    theta + (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

/// The frames of a trial (stamps `round(k · 10⁶ / 30)` µs up to the truth's end).
pub fn frames(truth: &Truth, effect: &Effect, noise: &Noise, rng: &mut Rng) -> Vec<Frame> {
    let delay_s = match *effect {
        Effect::Latency { delay_s } => delay_s,
        _ => 0.0,
    };
    let end_s = truth.last().t_s;
    let mut out = Vec::new();
    for k in 0u64.. {
        let t_us = (k as f64 * 1e6 / FRAME_RATE_HZ).round() as i64;
        let t_s = t_us as f64 * 1e-6;
        if t_s > end_s {
            break;
        }
        let s = truth.at(t_s - delay_s);
        let c = imaged(V2::new(s.pose.x, s.pose.y), effect);
        let pose = Pose {
            x: c.x + noise.xy_um * rng.normal(),
            y: c.y + noise.xy_um * rng.normal(),
            theta: imaged_angle(s.pose.theta, effect) + noise.theta_rad * rng.normal(),
        };
        let t = imaged(s.tip, effect);
        let tip = V2::new(t.x + noise.tip_um * rng.normal(), t.y + noise.tip_um * rng.normal());
        out.push(Frame { t_us, index: k, pose, tip });
    }
    out
}
