//! Where a friction patch's search starts, from where the data says its edge can be.
//!
//! The physics: quasi-static motion depends on the *ratios* of the friction forces, so a
//! patch the whole peg sits on moves nothing; it shows only while the peg's supports
//! straddle its edge. An edge can therefore only be seen where a support travelled while
//! the peg moved, and the edge positions tried are the quantiles of the support points'
//! plate coordinates over the training frames in which the peg moved (per axis). At each,
//! a half-plane patch (the side above the edge) with a friction below and above the
//! plate's is scored on the training loss: the loss profile along each axis, read at the
//! places the supports crossed. The best edge (per axis) then gets:
//! - the nominal parameters refitted with the patch held (the nominal fit has bent them,
//!   above all μ_probe and the support's place, to absorb the patch), the edge re-scanned
//!   with them, the patch friction scanned on a ratio grid;
//! - the rectangle's other sides, one at a time, scanned on the same grids, each kept only
//!   when it lowers the training loss by `SIDE_MIN_GAIN` (10 %) or more; tried for the
//!   half-plane and for its mirror (the other side of the edge as the patch, frictions
//!   swapped: the same motion, a different rectangle to grow), so a finite patch inside
//!   the workspace is reachable from whichever of its edges the scan found.
//!
//! The frictions of every start are the prior ones (the base model's μ_probe and surface μ;
//! the support's place is the nominal fit's): the nominal fit absorbs a patch by driving
//! them to their bounds (on the patch batches of the confusion run μ_probe sat at 1.5
//! against a true 0.65–0.76, and a finite-difference step cannot leave a bound), and a
//! patch friction measured against a surface μ at its bound of 1.2 could not reach a ratio
//! above 1.7 (a uniform μ moves nothing, so the surface μ is free to start anywhere).

use super::context::StartContext;
use crate::candidates::{Effect, NOMINAL};
use crate::data::TrialData;
use crate::objective::{loss, residual_vector};
use mesopush_core::stats::percentile;
use mesopush_ident::optim::{LmSettings, levenberg_marquardt};
use rayon::prelude::*;

/// Spacing of the edge positions scanned, µm: well inside the loss's basin about a true
/// edge (±30 µm wide for the paper's peg: a support crossing the edge a little earlier or
/// later changes the stroke).
const EDGE_STEP_UM: f64 = 20.0;
/// At most this many edge positions per axis (a wider workspace is scanned coarser).
const MAX_EDGES: usize = 80;
/// Local minima of each axis's loss profile refined further.
const MINIMA: usize = 1;
/// Patch-to-plate friction ratios of the edge scan (the patch slipperier or grippier).
const SCAN_RATIOS: [f64; 2] = [1.0 / 3.0, 3.0];
/// A rectangle side beyond the half-plane is kept when it lowers the training loss by at
/// least this fraction. A side the training strokes see changes whole strokes (a
/// half-plane over the wrong region leaves 10–100× the loss at the truth), while a side
/// placed where only a stroke or two barely reaches buys a fraction of a per cent and
/// wrecks the held-out trials (the friction-patch batch of seed 12: 0.15 % better on the
/// training trials, 100× worse held out).
const SIDE_MIN_GAIN: f64 = 0.1;
/// A peg counts as moving between frames beyond this step, µm (a tracker's noise is well
/// below it).
const MOVE_UM: f64 = 1.0;

/// The plate coordinates (per axis) of the support points (of `base` shifted by
/// `nominal[2..4]`) at every training frame where the peg moved since the frame before.
fn support_track(nominal: &[f64], train: &[TrialData], ctx: &StartContext<'_>) -> [Vec<f64>; 2] {
    let pts = Effect::Nominal.apply(ctx.base, &nominal[..NOMINAL.len()]).support.points();
    let mut out = [Vec::new(), Vec::new()];
    for t in train {
        for w in t.frames.windows(2) {
            let step = (w[1].pose.position() - w[0].pose.position()).norm();
            let turn_um = (w[1].pose.theta_rad - w[0].pose.theta_rad).abs() * 500.0;
            if step.max(turn_um) <= MOVE_UM {
                continue;
            }
            for p in &pts {
                let q = w[1].pose.transform_point(p);
                out[0].push(q.x);
                out[1].push(q.y);
            }
        }
    }
    out
}

/// Edge positions over the span of `v` (its 1st to 99th percentile: where supports went
/// while the peg moved), evenly spaced at [`EDGE_STEP_UM`] or coarser so there are at most
/// [`MAX_EDGES`].
fn edge_grid(mut v: Vec<f64>) -> Vec<f64> {
    let (Some(lo), Some(hi)) = (percentile(&mut v, 0.01), percentile(&mut v, 0.99)) else {
        return Vec::new();
    };
    let n = ((hi - lo) / EDGE_STEP_UM).floor().clamp(1.0, MAX_EDGES as f64) as usize;
    let step = (hi - lo) / n as f64;
    (0..n).map(|k| lo + (k as f64 + 0.5) * step).collect()
}

/// A patch's rectangle and friction: `lo`/`hi` per axis, `mu` inside.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Rect {
    lo: [f64; 2],
    hi: [f64; 2],
    mu: f64,
}

/// The full parameter vector of the patch candidate: `nom` (its surface μ the plate's),
/// then the patch.
fn vector(nom: &[f64], r: &Rect) -> Vec<f64> {
    let mut v = nom[..NOMINAL.len()].to_vec();
    v.extend([r.mu, r.lo[0], r.lo[1], r.hi[0], r.hi[1]]);
    v
}

/// Scores of a set of patches at nominal parameters `nom` (training loss; in parallel,
/// collected in order, so deterministic).
fn losses(nom: &[f64], rects: &[Rect], train: &[TrialData], ctx: &StartContext<'_>) -> Vec<f64> {
    let c = Effect::FrictionPatch;
    rects
        .par_iter()
        .map(|r| loss(train, &c.apply(ctx.base, &vector(nom, r)), ctx.settings, ctx.noise).0)
        .collect()
}

/// The best of `rects` and its loss (the first on ties).
fn best_of(
    nom: &[f64],
    rects: Vec<Rect>,
    train: &[TrialData],
    ctx: &StartContext<'_>,
) -> Option<(Rect, f64)> {
    let l = losses(nom, &rects, train, ctx);
    rects.into_iter().zip(l).min_by(|a, b| a.1.total_cmp(&b.1))
}

/// The half-plane above `edge` on `axis` with friction `mu` (the other sides at the
/// parameter bounds, far outside any workspace).
fn half_plane(axis: usize, edge: f64, mu: f64) -> Rect {
    let p = Effect::FrictionPatch.effect_params();
    let mut r = Rect { lo: [p[1].lo, p[2].lo], hi: [p[3].hi, p[4].hi], mu };
    r.lo[axis] = edge;
    r
}

/// The same motion with the other side of the edge as the patch: the half-plane below the
/// edge, the frictions swapped (returned as the new plate μ and the rectangle).
fn mirror(axis: usize, r: &Rect, plate_mu: f64) -> (f64, Rect) {
    let p = Effect::FrictionPatch.effect_params();
    let mut m = Rect { lo: [p[1].lo, p[2].lo], hi: [p[3].hi, p[4].hi], mu: plate_mu };
    m.hi[axis] = r.lo[axis];
    (r.mu, m)
}

/// Friction-patch starts (full parameter vectors) from the nominal optimum `nominal`.
pub fn patch_starts(nominal: &[f64], train: &[TrialData], ctx: &StartContext<'_>) -> Vec<Vec<f64>> {
    let track = support_track(nominal, train, ctx);
    let grids = [edge_grid(track[0].clone()), edge_grid(track[1].clone())];
    let prior = [ctx.prior_mu[0], ctx.prior_mu[1], 0.0, 0.0];
    let bent = [prior[0], prior[1], nominal[2], nominal[3]];
    let mut found: Vec<(Vec<f64>, Rect, f64, usize)> = Vec::new();
    for nom in [bent, prior] {
        for (axis, grid) in grids.iter().enumerate() {
            for hp in profile_minima(&nom, axis, grid, train, ctx) {
                let (n, r, l) = refine_edge(&nom, axis, hp, train, ctx);
                found.push((n, r, l, axis));
            }
        }
    }
    found.sort_by(|a, b| a.2.total_cmp(&b.2));
    let mut out: Vec<Vec<f64>> = found.iter().map(|f| vector(&f.0, &f.1)).collect();
    if let Some((n, hp, _, axis)) = found.into_iter().next() {
        let (mu_m, m) = mirror(axis, &hp, n[1]);
        let mut n_m = n.clone();
        n_m[1] = mu_m;
        for (n, r) in [(n, hp), (n_m, m)] {
            let grown = grow(&n, r, &grids, train, ctx);
            if grown != r {
                out.push(vector(&n, &grown));
            }
        }
    }
    out
}

/// The [`MINIMA`] lowest local minima of the training loss over the half-planes above each
/// edge of `grid` on `axis` (each edge at the better of [`SCAN_RATIOS`]).
fn profile_minima(
    nom: &[f64],
    axis: usize,
    grid: &[f64],
    train: &[TrialData],
    ctx: &StartContext<'_>,
) -> Vec<Rect> {
    let rects: Vec<Rect> =
        grid.iter().flat_map(|&e| SCAN_RATIOS.map(|q| half_plane(axis, e, q * nom[1]))).collect();
    let l = losses(nom, &rects, train, ctx);
    let prof: Vec<(Rect, f64)> = rects
        .chunks(SCAN_RATIOS.len())
        .zip(l.chunks(SCAN_RATIOS.len()))
        .filter_map(|(r, l)| {
            r.iter().copied().zip(l.iter().copied()).min_by(|a, b| a.1.total_cmp(&b.1))
        })
        .collect();
    let mut minima: Vec<(Rect, f64)> = (0..prof.len())
        .filter(|&i| {
            let left = i == 0 || prof[i].1 <= prof[i - 1].1;
            let right = i + 1 == prof.len() || prof[i].1 <= prof[i + 1].1;
            left && right
        })
        .map(|i| prof[i])
        .collect();
    minima.sort_by(|a, b| a.1.total_cmp(&b.1));
    minima.into_iter().take(MINIMA).map(|m| m.0).collect()
}

/// The half-plane `hp` (on `axis`) fitted together with the nominal parameters `nom`:
/// Levenberg–Marquardt over the nominal parameters, the patch friction and the edge, the
/// edge measured from the support's shift along its axis. The edge and the support's place
/// trade against each other (a support crosses the edge where the support plus the peg's
/// pose meets it): with the support held, the nominal fit's bent support puts the best
/// edge tens of µm off, and a search over both in plate coordinates must crawl along that
/// valley. Returns the nominal parameters, the half-plane and the training loss.
fn refine_edge(
    nom: &[f64],
    axis: usize,
    hp: Rect,
    train: &[TrialData],
    ctx: &StartContext<'_>,
) -> (Vec<f64>, Rect, f64) {
    let c = Effect::FrictionPatch;
    let k = NOMINAL.len();
    let params = c.params();
    let bounded: Vec<_> = params[..=k].iter().chain([&params[k + 1 + axis]]).copied().collect();
    let clamp = |x: &[f64]| -> Vec<f64> {
        x.iter().zip(&bounded).map(|(v, p)| v.clamp(p.lo, p.hi)).collect()
    };
    let rect = |x: &[f64]| {
        let mut r = Rect { mu: x[k], ..hp };
        r.lo[axis] = x[k + 1] + x[2 + axis];
        r
    };
    let res = |x: &[f64]| -> Option<Vec<f64>> {
        let x = clamp(x);
        let m = c.apply(ctx.base, &vector(&x, &rect(&x)));
        residual_vector(train, &m, ctx.settings, ctx.noise)
    };
    let h: Vec<f64> = bounded.iter().map(|p| p.step * 0.05).collect();
    let x0: Vec<f64> =
        nom[..k].iter().copied().chain([hp.mu, hp.lo[axis] - nom[2 + axis]]).collect();
    let budget = 3 * ctx.evals_per_trial.max(2 * (k + 6));
    let m = levenberg_marquardt(&res, &x0, &h, budget, &LmSettings::DEFAULT);
    let x = clamp(&m.x);
    (x[..k].to_vec(), rect(&x), m.value)
}

/// The rectangle grown from `r` one side at a time (the sides still at a bound, in turn):
/// each side's position scanned on its axis's grid (keeping the rectangle non-empty) and
/// kept when it lowers the training loss by [`SIDE_MIN_GAIN`] or more.
fn grow(
    nom: &[f64],
    mut r: Rect,
    grids: &[Vec<f64>; 2],
    train: &[TrialData],
    ctx: &StartContext<'_>,
) -> Rect {
    let c = Effect::FrictionPatch;
    let p = c.effect_params();
    let mut l = loss(train, &c.apply(ctx.base, &vector(nom, &r)), ctx.settings, ctx.noise).0;
    for (axis, upper) in [(0, false), (0, true), (1, false), (1, true)] {
        let at_bound =
            if upper { r.hi[axis] >= p[3 + axis].hi } else { r.lo[axis] <= p[1 + axis].lo };
        if !at_bound {
            continue;
        }
        // Every other edge of the scan: a side is a coarser feature than the edge found first.
        let tries: Vec<Rect> = grids[axis]
            .iter()
            .step_by(2)
            .filter(|&&e| if upper { e > r.lo[axis] } else { e < r.hi[axis] })
            .map(|&e| {
                let mut t = r;
                if upper {
                    t.hi[axis] = e
                } else {
                    t.lo[axis] = e
                }
                t
            })
            .collect();
        if let Some((t, lt)) = best_of(nom, tries, train, ctx)
            && lt < (1.0 - SIDE_MIN_GAIN) * l
        {
            (r, l) = (t, lt);
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_edge_grid_spans_where_the_supports_went_at_the_edge_step() {
        let v: Vec<f64> = (0..1000).map(|k| 1000.0 + k as f64).collect();
        let g = edge_grid(v);
        let step = |w: &[f64]| w[1] - w[0];
        assert!(g.windows(2).all(|w| (EDGE_STEP_UM..1.1 * EDGE_STEP_UM).contains(&step(w))));
        assert!(g[0] > 1000.0 && g[0] < 1000.0 + 2.0 * EDGE_STEP_UM, "{g:?}");
        assert!(*g.last().unwrap() > 1999.0 - 2.0 * EDGE_STEP_UM, "{g:?}");
        // A wide workspace is scanned coarser, never with more than MAX_EDGES positions.
        let wide: Vec<f64> = (0..10_000).map(|k| k as f64 * 10.0).collect();
        assert_eq!(edge_grid(wide).len(), MAX_EDGES);
        assert_eq!(edge_grid(vec![5.0; 100]), vec![5.0]);
        assert!(edge_grid(Vec::new()).is_empty());
    }

    #[test]
    fn a_mirrored_half_plane_is_the_other_side_with_the_frictions_swapped() {
        let hp = half_plane(1, 1300.0, 0.9);
        let (plate, m) = mirror(1, &hp, 0.3);
        assert_eq!((plate, m.mu), (0.9, 0.3));
        let f = |r: &Rect, y: f64| {
            mesopush_sim::effects::FrictionPatch { min_um: r.lo, max_um: r.hi, mu_surface: r.mu }
                .contains([1500.0, y])
        };
        assert!(f(&hp, 1400.0) && !f(&hp, 1200.0));
        assert!(!f(&m, 1400.0) && f(&m, 1200.0));
    }
}
