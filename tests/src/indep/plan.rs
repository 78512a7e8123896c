//! Push plans: for each trial a start pose and a probe path of two strokes. A stroke goes
//! round the part at a safe radius, comes in along an edge normal (turned a little), pushes
//! at a speed drawn from 50–300 µm/s, backs off (a reversal: backlash, adhesion), dwells,
//! pushes again, retracts and dwells. The second stroke is aimed at where the clean world
//! ([`super::physics`], no effect) leaves the part after the first, so every effect of a
//! batch runs the same plans.

use super::effects::Effect;
use super::path::Path;
use super::physics::simulate;
use super::rng::Rng;
use super::world::World;
use crate::coulomb::{Pose, V2};
use std::ops::{Add, Sub};

/// Travel speed between strokes, µm/s.
pub const TRAVEL_UM_S: f64 = 300.0;
/// Strokes per trial.
pub const STROKES: usize = 2;

/// One trial's plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PushPlan {
    /// The part's true start pose.
    pub start: Pose,
    /// The commanded needle path.
    pub path: Path,
}

fn world_outline(world: &World, pose: &Pose) -> Vec<V2> {
    world
        .outline_um
        .iter()
        .map(|p| V2::new(p[0], p[1]).rot(pose.theta).add(V2::new(pose.x, pose.y)))
        .collect()
}

/// Around the part's centre `c` at radius `r` from the path's end to the direction of `to`.
fn travel_around(path: &mut Path, c: V2, r: f64, to: V2) {
    let from = path.end().sub(c);
    let a0 = from.y.atan2(from.x);
    let target = to.sub(c);
    let mut da = (target.y.atan2(target.x) - a0).rem_euclid(std::f64::consts::TAU);
    if da > std::f64::consts::PI {
        da -= std::f64::consts::TAU;
    }
    let radius = r.max(from.len());
    path.line_to(c.add(V2::new(a0.cos(), a0.sin()).scale(radius)), TRAVEL_UM_S);
    let n = (da.abs() / 0.25).ceil().max(1.0) as usize;
    for k in 1..=n {
        let a = a0 + da * k as f64 / n as f64;
        path.line_to(c.add(V2::new(a.cos(), a.sin()).scale(radius)), TRAVEL_UM_S);
    }
}

/// Where and how a stroke pushes.
struct Aim {
    at: V2,
    push: V2,
    speed: f64,
    approach: V2,
}

/// A stroke against the part at `pose`: an edge, a point on it, a direction, a speed.
fn aim(world: &World, pose: &Pose, rng: &mut Rng) -> Aim {
    let o = world_outline(world, pose);
    let e = rng.index(o.len());
    let (a, b) = (o[e], o[(e + 1) % o.len()]);
    let edge = b.sub(a);
    let normal = V2::new(edge.y, -edge.x).scale(1.0 / edge.len());
    let at = a.add(edge.scale(rng.range(0.2, 0.8)));
    let push = normal.scale(-1.0).rot(rng.range(-0.3, 0.3));
    let speed = rng.range(50.0, 300.0);
    let approach = at.sub(push.scale(world.pusher_radius_um + 100.0));
    Aim { at, push, speed, approach }
}

/// From the approach point: push, back off, dwell, push again, retract, dwell.
fn strike(path: &mut Path, aim: &Aim, rng: &mut Rng) {
    let (push, speed) = (aim.push, aim.speed);
    path.line_to(aim.approach, TRAVEL_UM_S);
    let p1 = aim.at.add(push.scale(rng.range(500.0, 1100.0)));
    path.line_to(p1, speed);
    path.dwell(0.2);
    let p2 = p1.sub(push.scale(rng.range(30.0, 80.0)));
    path.line_to(p2, speed);
    path.dwell(0.3);
    let p3 = p2.add(push.scale(rng.range(300.0, 700.0)));
    path.line_to(p3, speed);
    path.dwell(0.2);
    path.line_to(p3.sub(push.scale(rng.range(120.0, 250.0))), speed);
    path.dwell(0.3);
}

/// The plan of one trial, drawn from `seed`, aimed with `world`'s clean physics.
pub fn push_plan(world: &World, seed: u64) -> PushPlan {
    let mut rng = Rng::new(seed);
    let start = Pose {
        x: rng.range(2600.0, 3400.0),
        y: rng.range(2100.0, 2900.0),
        theta: rng.range(-0.5, 0.5),
    };
    let first = aim(world, &start, &mut rng);
    let mut path = Path::start(first.approach.sub(first.push.scale(300.0)));
    strike(&mut path, &first, &mut rng);
    for _ in 1..STROKES {
        let pose = simulate(world, &Effect::Clean, start, &path).last().pose;
        let next = aim(world, &pose, &mut rng);
        travel_around(&mut path, V2::new(pose.x, pose.y), world.reach_um() + 250.0, next.approach);
        strike(&mut path, &next, &mut rng);
    }
    PushPlan { start, path }
}
