//! An independent quasi-static pusher with exact Coulomb friction: the reference the
//! project's simulator is checked against. It shares no code, types or defaults with the
//! mesopush crates (its own vectors, polygons and solver), so agreement is evidence, not
//! self-consistency.
//!
//! Model: a rigid convex part on a plane, carried by point supports with known normal forces
//! `Nᵢ` and friction `μᵢ` (Coulomb: a sliding support's force is exactly `−μᵢNᵢ·v̂ᵢ`, the
//! circle, not a polygon), pushed by one rigid disc with contact friction `μₚ`. Quasi-static:
//! the pusher's contact force balances the support forces (force and moment). Each pusher
//! increment `δp` is solved for the part's increment `(dx, dy, dθ)` and the contact force
//! `(fₙ, fₜ)` by Newton's method on the balance and contact equations, once for a sticking and
//! once for each sliding contact; the mode whose solution satisfies its own inequalities is
//! taken. Slip directions are regularised below `slip_eps` (a tiny fraction of the step).
//! [`step`] is one increment (with its contact force), [`drag`] one increment of a disc bonded
//! to the part (adhesion); a support's μ may grow with its sliding speed
//! ([`Part::speed_gain_per_um`]). The independent trial generator ([`crate::indep`]) runs on
//! these.

use std::ops::{Add, Sub};
mod vec2;
pub use vec2::V2;

/// The part: outline and supports in its body frame (origin at the centre of mass).
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    /// Convex outline, counter-clockwise.
    pub outline: Vec<V2>,
    /// Support points.
    pub supports: Vec<V2>,
    /// Normal force at each support (they sum to the weight).
    pub normal: Vec<f64>,
    /// Friction coefficient at each support.
    pub mu: Vec<f64>,
    /// Velocity strengthening: a support that moves `δ` in an increment has the friction
    /// coefficient `μᵢ (1 + speed_gain_per_um · |δ|)` (0: rate-independent Coulomb). A
    /// caller stepping in time sets it to the gain per µm/s divided by the increment's
    /// duration.
    pub speed_gain_per_um: f64,
}

impl Part {
    /// Normal forces of three supports carrying a unit weight at the origin (statics).
    pub fn three_point(outline: Vec<V2>, supports: [V2; 3], mu: f64) -> Self {
        let [a, b, c] = supports;
        // N_a + N_b + N_c = 1 and Σ N r = 0: barycentric coordinates of the origin.
        let area = (b.sub(a)).cross(c.sub(a));
        let na = b.cross(c) / area;
        let nb = c.cross(a) / area;
        let nc = a.cross(b) / area;
        Self {
            outline,
            supports: supports.to_vec(),
            normal: vec![na, nb, nc],
            mu: vec![mu; 3],
            speed_gain_per_um: 0.0,
        }
    }
}

/// Pose of the part: position of the centre of mass and orientation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// θ, rad.
    pub theta: f64,
}

/// The disc pusher and the contact friction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pusher {
    /// Disc radius.
    pub radius: f64,
    /// Part–pusher friction.
    pub mu: f64,
}

/// Contact between the disc at `p` and the part at `pose`: (gap, outward unit normal of the
/// part at the closest point, closest point).
pub fn contact(part: &Part, pose: &Pose, p: V2, radius: f64) -> (f64, V2, V2) {
    let world: Vec<V2> =
        part.outline.iter().map(|v| v.rot(pose.theta).add(V2::new(pose.x, pose.y))).collect();
    let n = world.len();
    let mut best = (f64::INFINITY, V2::default(), V2::default());
    for i in 0..n {
        let (a, b) = (world[i], world[(i + 1) % n]);
        let ab = b.sub(a);
        let t = (p.sub(a).dot(ab) / ab.dot(ab)).clamp(0.0, 1.0);
        let q = a.add(ab.scale(t));
        let d = p.sub(q).len();
        if d < best.0 {
            let edge_normal = V2::new(ab.y, -ab.x).scale(1.0 / ab.len());
            let normal =
                if t > 0.0 && t < 1.0 || d < 1e-12 { edge_normal } else { p.sub(q).scale(1.0 / d) };
            best = (d, normal, q);
        }
    }
    let inside = world.iter().enumerate().all(|(i, a)| {
        let b = world[(i + 1) % n];
        b.sub(*a).cross(p.sub(*a)) >= 0.0
    });
    let signed = if inside { -best.0 } else { best.0 };
    (signed - radius, best.1, best.2)
}

/// Settings of the reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Pusher travel per increment.
    pub step: f64,
    /// Slip speeds below this (per increment) are regularised.
    pub slip_eps: f64,
}

/// The residual of the balance and contact equations for unknowns
/// `u = [dx, dy, dθ, fₙ, fₜ]` in contact mode `mode` (0 stick, ±1 slide).
fn residual(part: &Part, pose: &Pose, c: &Ctx, u: &[f64; 5], mode: i32, eps: f64) -> [f64; 5] {
    let [dx, dy, dth, fn_, ft] = *u;
    let (mut fx, mut fy, mut tau) = (0.0, 0.0, 0.0);
    for i in 0..part.supports.len() {
        let r = part.supports[i].rot(pose.theta);
        let v = V2::new(dx - dth * r.y, dy + dth * r.x);
        let mu = part.mu[i] * (1.0 + part.speed_gain_per_um * v.len());
        let k = mu * part.normal[i] / (v.dot(v) + eps * eps).sqrt();
        let f = v.scale(-k);
        fx += f.x;
        fy += f.y;
        tau += r.cross(f);
    }
    let fp = c.n.scale(-fn_).add(c.t.scale(ft));
    let rc = c.point.sub(V2::new(pose.x, pose.y));
    let vc = V2::new(dx - dth * rc.y, dy + dth * rc.x);
    let rel = c.dp.sub(vc);
    let kin_n = rel.dot(c.n.scale(-1.0)) - c.close;
    let kin_t = match mode {
        0 => rel.dot(c.t),
        s => ft - f64::from(s) * c.mu * fn_,
    };
    [fx + fp.x, fy + fp.y, tau + rc.cross(fp), kin_n, kin_t]
}

struct Ctx {
    n: V2,
    t: V2,
    point: V2,
    dp: V2,
    close: f64,
    mu: f64,
}

fn solve5(a: [[f64; 5]; 5], b: [f64; 5]) -> Option<[f64; 5]> {
    let mut m = [[0.0; 6]; 5];
    for i in 0..5 {
        m[i][..5].copy_from_slice(&a[i]);
        m[i][5] = b[i];
    }
    for col in 0..5 {
        let piv = (col..5).max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))?;
        if m[piv][col].abs() < 1e-300 {
            return None;
        }
        m.swap(col, piv);
        let pivot_row = m[col];
        for (r, row) in m.iter_mut().enumerate() {
            if r != col {
                let k = row[col] / pivot_row[col];
                for (x, p) in row.iter_mut().zip(&pivot_row).skip(col) {
                    *x -= k * p;
                }
            }
        }
    }
    Some(std::array::from_fn(|i| m[i][5] / m[i][i]))
}

/// Newton's method from `start`; when it fails at the regularisation `eps`, it is walked
/// down from a coarse regularisation (continuation), each solution starting the next.
fn solve_mode(
    part: &Part,
    pose: &Pose,
    c: &Ctx,
    mode: i32,
    eps: f64,
    scale: f64,
    start: [f64; 5],
) -> Option<[f64; 5]> {
    if let Some(u) = newton(part, pose, c, mode, eps, scale, start) {
        return Some(u);
    }
    let mut u = start;
    let mut e = 0.1 * scale;
    while e > eps {
        u = newton(part, pose, c, mode, e, scale, u)?;
        e *= 0.1;
    }
    newton(part, pose, c, mode, eps, scale, u)
}

fn newton(
    part: &Part,
    pose: &Pose,
    c: &Ctx,
    mode: i32,
    eps: f64,
    scale: f64,
    start: [f64; 5],
) -> Option<[f64; 5]> {
    let mut u = start;
    let norm = |r: &[f64; 5]| r.iter().map(|x| x * x).sum::<f64>().sqrt();
    let mut r = residual(part, pose, c, &u, mode, eps);
    for _ in 0..100 {
        if norm(&r) < 1e-13 {
            return Some(u);
        }
        let mut jac = [[0.0; 5]; 5];
        for j in 0..5 {
            // Differences well below the regularisation, so the stiff regime is resolved.
            let hk = (1e-7 * scale).min(0.01 * eps);
            let h = if j == 2 {
                hk / 1000.0
            } else if j < 2 {
                hk
            } else {
                1e-9
            };
            let mut up = u;
            up[j] += h;
            let rp = residual(part, pose, c, &up, mode, eps);
            for i in 0..5 {
                jac[i][j] = (rp[i] - r[i]) / h;
            }
        }
        let step = solve5(jac, r.map(|x| -x))?;
        let mut t = 1.0;
        loop {
            let trial: [f64; 5] = std::array::from_fn(|i| u[i] + t * step[i]);
            let rt = residual(part, pose, c, &trial, mode, eps);
            if norm(&rt) < norm(&r) || t < 1e-6 {
                u = trial;
                r = rt;
                break;
            }
            t *= 0.5;
        }
    }
    (norm(&r) < 1e-9).then_some(u)
}

/// Moves the part at `pose` while the pusher's centre goes from `from` to `to`; returns the
/// part's pose after each increment (the last is the end pose).
pub fn push(part: &Part, pusher: &Pusher, pose: Pose, from: V2, to: V2, s: &Settings) -> Vec<Pose> {
    push_traced(part, pusher, pose, from, to, s).into_iter().map(|(p, _)| p).collect()
}

/// [`push`], with each increment's contact mode: `None` free, `Some(0)` stick, `Some(±1)`
/// sliding along ±t, `Some(9)` no consistent mode (the part was left where it was).
pub fn push_traced(
    part: &Part,
    pusher: &Pusher,
    mut pose: Pose,
    from: V2,
    to: V2,
    s: &Settings,
) -> Vec<(Pose, Option<i32>)> {
    let total = to.sub(from);
    let n = (total.len() / s.step).ceil().max(1.0) as usize;
    let dp = total.scale(1.0 / n as f64);
    let mut p = from;
    let mut out = Vec::with_capacity(n);
    let mut warm = [dp.x, dp.y, 0.0, 0.1, 0.0];
    for _ in 0..n {
        let r = step(part, pusher, pose, p, dp, s, &mut warm);
        pose = r.pose;
        p = p.add(dp);
        out.push((pose, r.mode));
    }
    out
}

/// One increment's outcome.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// The part's pose after the increment.
    pub pose: Pose,
    /// `None` free, `Some(0)` stick, `Some(±1)` sliding along ±t, `Some(9)` no consistent
    /// mode (the part was left where it was).
    pub mode: Option<i32>,
    /// Contact force on the part along the inward normal (negative: a pull), part weights.
    pub f_n: f64,
    /// Contact force along the tangent `t = (−n.y, n.x)`, part weights.
    pub f_t: f64,
    /// The part's outward normal at the contact (before the increment).
    pub normal: V2,
    /// The contact point on the part (before the increment).
    pub point: V2,
}

fn apply(pose: Pose, u: &[f64; 5]) -> Pose {
    Pose { x: pose.x + u[0], y: pose.y + u[1], theta: pose.theta + u[2] }
}

/// One pusher increment `dp` from the disc centre `p`: the part's motion and the contact
/// force. `warm` carries the last solution between increments (start it at
/// `[dp.x, dp.y, 0, 0.1, 0]`).
pub fn step(
    part: &Part,
    pusher: &Pusher,
    pose: Pose,
    p: V2,
    dp: V2,
    s: &Settings,
    warm: &mut [f64; 5],
) -> Step {
    let (gap, normal, point) = contact(part, &pose, p, pusher.radius);
    let free = Step { pose, mode: None, f_n: 0.0, f_t: 0.0, normal, point };
    let approach = dp.dot(normal.scale(-1.0));
    // Leaving a contact closed to rounding (a gap of −1e-9 µm after a push) is free too.
    if gap > approach || approach <= 0.0 && gap >= -1e-6 * s.step {
        return free;
    }
    let c = Ctx {
        n: normal,
        t: V2::new(-normal.y, normal.x),
        point,
        dp,
        close: gap.max(-s.step),
        mu: pusher.mu,
    };
    // The last solution first; where no mode converges from it, cold starts.
    let cold = |f: f64, t: f64| [dp.x, dp.y, 0.0, f, t];
    let starts = [*warm, cold(0.1, 0.0), cold(0.3, 0.1), cold(0.3, -0.1)];
    for (mode, start) in starts.iter().flat_map(|st| [0, 1, -1].map(|m| (m, *st))) {
        let Some(u) = solve_mode(part, &pose, &c, mode, s.slip_eps, s.step, start) else {
            continue;
        };
        let (fn_, ft) = (u[3], u[4]);
        let rc = c.point.sub(V2::new(pose.x, pose.y));
        let vc = V2::new(u[0] - u[2] * rc.y, u[1] + u[2] * rc.x);
        let slip = c.dp.sub(vc).dot(c.t);
        let ok = fn_ >= -1e-12
            && match mode {
                0 => ft.abs() <= pusher.mu * fn_ + 1e-9,
                m => slip * f64::from(m) >= -1e-9 * s.step,
            };
        if ok {
            *warm = u;
            return Step { pose: apply(pose, &u), mode: Some(mode), f_n: fn_, f_t: ft, ..free };
        }
    }
    Step { mode: Some(9), ..free }
}

/// One increment of a disc at `p` (gap ≥ 0 from the part) bonded to the part: the contact
/// point follows the disc rigidly, both ways, so that the gap after the increment is
/// `target_gap`. Returns the motion and the bond's force on the part (`f_n < 0`: a pull),
/// or `None` when no quasi-static motion exists.
pub fn drag(
    part: &Part,
    pusher: &Pusher,
    pose: Pose,
    p: V2,
    dp: V2,
    target_gap: f64,
    s: &Settings,
) -> Option<Step> {
    let (gap, normal, point) = contact(part, &pose, p, pusher.radius);
    let c = Ctx {
        n: normal,
        t: V2::new(-normal.y, normal.x),
        point,
        dp,
        close: gap - target_gap,
        mu: pusher.mu,
    };
    let start = [dp.x, dp.y, 0.0, -0.1, 0.0];
    let u = solve_mode(part, &pose, &c, 0, s.slip_eps, s.step, start)?;
    Some(Step { pose: apply(pose, &u), mode: Some(0), f_n: u[3], f_t: u[4], normal, point })
}
