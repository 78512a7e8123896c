//! The generator's true motion: the commanded path through the stage
//! ([`super::stage`]) moves the needle in increments of at most [`STEP_UM`]; each increment
//! moves the part by the exact-Coulomb reference ([`crate::coulomb`]) with the batch's
//! physical effect (a friction stripe, speed-dependent friction, adhesion; support drift is
//! applied to the world before). Records the true part pose and needle at every increment.

use super::adhesion::{Bond, bonded_increment};
use super::effects::Effect;
use super::path::{Path, SETPOINT_PERIOD_S};
use super::stage::Stage;
use super::world::World;
use crate::coulomb::{self, Pose, Settings, V2};
use std::ops::Sub;

/// Largest needle increment, µm.
pub const STEP_UM: f64 = 0.5;

/// The truth at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time since the trial's start, s.
    pub t_s: f64,
    /// The part's pose (COM, angle).
    pub pose: Pose,
    /// The needle's centre, µm.
    pub tip: V2,
    /// Contact force on the part, part weights (0 when free; negative: adhesion's pull).
    pub force: f64,
}

/// A trial's true motion.
#[derive(Debug, Clone, PartialEq)]
pub struct Truth {
    /// Samples in time order (the first at t = 0).
    pub samples: Vec<Sample>,
    /// Increments in contact for which no consistent contact mode existed (part left still).
    pub unresolved: usize,
    /// Increments in which adhesion dragged the part.
    pub dragged: usize,
}

impl Truth {
    /// The truth at `t_s`, linear between samples (clamped to the first and last).
    pub fn at(&self, t_s: f64) -> Sample {
        let v = &self.samples;
        let i = v.partition_point(|s| s.t_s <= t_s);
        if i == 0 {
            return v[0];
        }
        if i == v.len() {
            return v[i - 1];
        }
        let (a, b) = (v[i - 1], v[i]);
        let w = (t_s - a.t_s) / (b.t_s - a.t_s);
        let lerp = |x: f64, y: f64| x + (y - x) * w;
        Sample {
            t_s,
            pose: Pose {
                x: lerp(a.pose.x, b.pose.x),
                y: lerp(a.pose.y, b.pose.y),
                theta: lerp(a.pose.theta, b.pose.theta),
            },
            tip: V2::new(lerp(a.tip.x, b.tip.x), lerp(a.tip.y, b.tip.y)),
            force: lerp(a.force, b.force),
        }
    }

    /// The last sample.
    pub fn last(&self) -> Sample {
        *self.samples.last().expect("a truth has its start")
    }
}

/// The reference solver's settings used throughout.
pub fn settings() -> Settings {
    Settings { step: STEP_UM, slip_eps: 1e-5 }
}

/// The friction of each support at `pose`: the stripe's factor where a support lies in it.
fn part_at(base: &coulomb::Part, pose: &Pose, effect: &Effect, dt_s: f64) -> coulomb::Part {
    let mut part = base.clone();
    if let Effect::Stripe { x_from_um, x_to_um, factor } = *effect {
        for (mu, r) in part.mu.iter_mut().zip(&base.supports) {
            let x = pose.x + r.rot(pose.theta).x;
            if (x_from_um..=x_to_um).contains(&x) {
                *mu *= factor;
            }
        }
    }
    if let Effect::SpeedFriction { gain_per_um_s } = *effect {
        part.speed_gain_per_um = gain_per_um_s / dt_s;
    }
    part
}

/// How often an increment with no consistent contact mode is halved before it is left
/// unresolved.
const HALVINGS: u32 = 4;

/// One needle increment `dp` from `tip`; where no contact mode is found, the increment is
/// halved (its duration too, so velocity strengthening keeps its meaning) and walked in two
/// pieces, up to `depth` times. Mode `Some(9)`: unresolved, `pose` as far as it got.
fn advance(
    part: &coulomb::Part,
    pusher: &coulomb::Pusher,
    pose: Pose,
    tip: V2,
    dp: V2,
    warm: &mut [f64; 5],
    depth: u32,
) -> coulomb::Step {
    let r = coulomb::step(part, pusher, pose, tip, dp, &settings(), warm);
    if r.mode != Some(9) || depth == 0 {
        return r;
    }
    let mut half_part = part.clone();
    half_part.speed_gain_per_um *= 2.0;
    let half = dp.scale(0.5);
    let a = advance(&half_part, pusher, pose, tip, half, warm, depth - 1);
    if a.mode == Some(9) {
        return a;
    }
    let b = advance(&half_part, pusher, a.pose, tip + half, half, warm, depth - 1);
    if b.mode.is_none() { coulomb::Step { pose: b.pose, ..a } } else { b }
}

/// Runs `path` on `world` (already drifted for this trial) from the part at `start`.
pub fn simulate(world: &World, effect: &Effect, start: Pose, path: &Path) -> Truth {
    let base = world.part();
    let pusher = world.pusher();
    let s = settings();
    let bond = match *effect {
        Effect::Adhesion { pull_off_weight, range_um } => Some(Bond { pull_off_weight, range_um }),
        _ => None,
    };
    let mut stage = Stage::new(effect);
    let mut tip = stage.position(path.at_tick(0.0));
    let mut pose = start;
    let mut bonded = false;
    let mut warm = [0.0, 0.0, 0.0, 0.1, 0.0];
    let mut out = Truth {
        samples: vec![Sample { t_s: 0.0, pose, tip, force: 0.0 }],
        unresolved: 0,
        dragged: 0,
    };
    for tick in 1..=path.end_tick() {
        let (a, b) = (path.at_tick((tick - 1) as f64), path.at_tick(tick as f64));
        let n = (b.sub(a).len() / STEP_UM).ceil().max(1.0) as u32;
        let dt_s = SETPOINT_PERIOD_S / f64::from(n);
        for j in 1..=n {
            let frac = f64::from(j) / f64::from(n);
            let next = stage.position(path.at_tick((tick - 1) as f64 + frac));
            let dp = next.sub(tip);
            let mut force = 0.0;
            if dp.len() > 1e-12 {
                let part = part_at(&base, &pose, effect, dt_s);
                let r = advance(&part, &pusher, pose, tip, dp, &mut warm, HALVINGS);
                match r.mode {
                    Some(9) => {
                        out.unresolved += 1;
                        pose = r.pose;
                    }
                    Some(_) => {
                        pose = r.pose;
                        force = r.f_n;
                        bonded = bond.is_some() && r.f_n > 0.0 || bonded;
                    }
                    None => {
                        if let (Some(bond), true) = (bond, bonded) {
                            let (p, holds) =
                                bonded_increment(&part, &pusher, pose, tip, dp, &bond, &s);
                            out.dragged += usize::from(p != pose);
                            pose = p;
                            bonded = holds;
                        }
                    }
                }
            }
            tip = next;
            let t_s = ((tick - 1) as f64 + frac) * SETPOINT_PERIOD_S;
            out.samples.push(Sample { t_s, pose, tip, force });
        }
    }
    out
}
