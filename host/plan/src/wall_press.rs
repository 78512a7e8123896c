//! Uncertainty-removing moves: press the part against a wall. A part pushed flat against a
//! fixture wall leaves with one coordinate and its orientation set by the wall, not by where
//! it started (the sensorless idea the paper's discussion points to: orient parts by pushing
//! them against fences).
//!
//! [`wall_press_variants`] builds, from a plan and its nominal replay, one variant per pushing
//! move and direction (±x, ±y): after that push the probe backs off, goes round behind the
//! part, pushes it along the direction until it meets the nearest wall that way (plus an
//! overshoot, which the needle's compliance absorbs), backs off again and returns to where the
//! plan left off. [`screen_wall_presses`] keeps the variant that succeeds most often on sampled
//! worlds, and only if it beats the plan without it; the robust design then tunes all its
//! moves ([`crate::family::PathFamily`]).

use crate::clearance::{Obstacles, first_wall_violation};
use crate::montecarlo::draws;
use crate::route::{merge_moves, route};
use crate::world::UncertainWorld;
use mesopush_core::geom::{ConvexPolygon, Vec2, cross};
use mesopush_sim::plan::PegStart;
use mesopush_sim::{Plan, Simulator, replay};
use rayon::prelude::*;

/// Settings of the wall presses (plain data; lengths as fractions of the part's diameter or
/// of the needle's deflection limit, so they scale with the part and the probe).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallPressSettings {
    /// Walls farther from the nominal part than this fraction of its diameter are not
    /// pressed against (the rest of the plan could not follow so large a shift). Default 0.3.
    pub max_gap_fraction: f64,
    /// How far past the nominal contact the press goes, as a fraction of the needle's
    /// deflection limit (a part that started nearer the wall bends the needle by at most this
    /// much more). Default 0.5.
    pub overshoot_fraction: f64,
    /// Back-off and approach clearance, as a fraction of the part's diameter. Default 0.05.
    pub clearance_fraction: f64,
    /// Worlds each variant is screened on. Default 64.
    pub screen_samples: usize,
    /// Most presses added, one after another: each round screens the variants of the plan
    /// the last round chose, on new worlds, and stops when none beats it. Default 3.
    pub max_presses: usize,
}

impl Default for WallPressSettings {
    fn default() -> Self {
        Self {
            max_gap_fraction: 0.3,
            overshoot_fraction: 0.5,
            clearance_fraction: 0.05,
            screen_samples: 64,
            max_presses: 3,
        }
    }
}

/// A plan with one wall press inserted.
#[derive(Debug, Clone, PartialEq)]
pub struct WallPress {
    /// After which move of the original plan (0-based) the press runs.
    pub after_move: usize,
    /// Direction of the press: "+x", "-x", "+y" or "-y".
    pub direction: &'static str,
    /// Nominal gap between the part and the wall before the press, µm.
    pub gap_um: f64,
    /// The plan with the press.
    pub plan: Plan,
}

const DIRECTIONS: [(&str, [f64; 2]); 4] =
    [("+x", [1.0, 0.0]), ("-x", [-1.0, 0.0]), ("+y", [0.0, 1.0]), ("-y", [0.0, -1.0])];

/// Distance along `d` from `p` to the boundary of convex `poly`, if the ray meets it.
fn ray_distance(p: Vec2, d: Vec2, poly: &ConvexPolygon) -> Option<f64> {
    let v = poly.vertices();
    (0..v.len())
        .filter_map(|i| {
            let (a, b) = (v[i], v[(i + 1) % v.len()]);
            let e = b - a;
            let den = cross(&d, &e);
            if den.abs() < 1e-12 {
                return None;
            }
            let t = cross(&(a - p), &e) / den;
            let s = cross(&(a - p), &d) / den;
            (t >= 0.0 && (0.0..=1.0).contains(&s)).then_some(t)
        })
        .min_by(f64::total_cmp)
}

/// How far `part` can translate along `d` before it touches one of `walls`.
pub fn gap_along(part: &ConvexPolygon, d: Vec2, walls: &[ConvexPolygon]) -> Option<f64> {
    let from_part = walls
        .iter()
        .flat_map(|w| part.vertices().iter().filter_map(move |v| ray_distance(*v, d, w)));
    let from_walls =
        walls.iter().flat_map(|w| w.vertices().iter().filter_map(|u| ray_distance(*u, -d, part)));
    from_part.chain(from_walls).min_by(f64::total_cmp)
}

/// Every wall-press variant of `plan` (see the module header), in move then direction order.
pub fn wall_press_variants(
    plan: &Plan,
    world: &UncertainWorld<'_>,
    settings: &WallPressSettings,
) -> Result<Vec<WallPress>, crate::Error> {
    let mut sim =
        Simulator::new(world.model.clone(), world.fixture.clone(), world.settings.clone())?;
    let rep = replay(&mut sim, plan, None)?;
    let part = world.model.part.polygon();
    let v = part.vertices();
    let diameter =
        v.iter().flat_map(|a| v.iter().map(move |b| (*a - *b).norm())).fold(0.0, f64::max);
    let mut probe = plan.probe_start();
    let mut out = Vec::new();
    for (k, m) in plan.moves_um.iter().enumerate() {
        probe += Vec2::new(m[0], m[1]);
        let during: Vec<_> = rep.samples.iter().filter(|s| s.move_index == k).collect();
        let pushed = during.iter().any(|s| s.probe_force > 0.0);
        let Some(last) = during.last().filter(|_| pushed) else { continue };
        let outline = part.transformed(&last.peg);
        for (name, d) in DIRECTIONS {
            let d = Vec2::new(d[0], d[1]);
            let press = Press { outline: &outline, probe, last_move: *m, d, diameter };
            if let Some((gap, moves)) = press.moves(world, settings)
                && gap <= settings.max_gap_fraction * diameter
            {
                let mut all = plan.moves_um[..=k].to_vec();
                all.extend(moves);
                all.extend_from_slice(&plan.moves_um[k + 1..]);
                let plan = Plan { moves_um: merge_moves(all), ..plan.clone() };
                out.push(WallPress { after_move: k, direction: name, gap_um: gap, plan });
            }
        }
    }
    Ok(out)
}

/// Whether `part` and one of `walls` overlap by more than a micrometre.
fn overlaps(part: &ConvexPolygon, walls: &[ConvexPolygon]) -> bool {
    walls.iter().any(|w| {
        part.vertices().iter().any(|v| w.signed_distance(v) < -1.0)
            || w.vertices().iter().any(|v| part.signed_distance(v) < -1.0)
    })
}

/// The largest extent of `v` from `c` along `d`.
fn support(v: &[Vec2], c: Vec2, d: Vec2) -> f64 {
    v.iter().map(|p| (*p - c).dot(&d)).fold(f64::NEG_INFINITY, f64::max)
}

/// The vertices of `outline` turned about its centroid so that the edge whose outward normal
/// is nearest `d` faces along `d` exactly.
fn squared(outline: &ConvexPolygon, d: Vec2) -> Vec<Vec2> {
    let v = outline.vertices();
    let c = outline.centroid();
    let best = (0..v.len())
        .max_by(|&a, &b| outline.edge_normal(a).dot(&d).total_cmp(&outline.edge_normal(b).dot(&d)))
        .unwrap_or(0);
    let n = outline.edge_normal(best);
    let turn = cross(&n, &d).atan2(n.dot(&d));
    let (sn, cs) = turn.sin_cos();
    v.iter()
        .map(|p| {
            let q = *p - c;
            c + Vec2::new(cs * q.x - sn * q.y, sn * q.x + cs * q.y)
        })
        .collect()
}

/// One press being built.
struct Press<'a> {
    outline: &'a ConvexPolygon,
    probe: Vec2,
    last_move: [f64; 2],
    d: Vec2,
    diameter: f64,
}

impl Press<'_> {
    /// The gap to the wall and the moves of the press, returning to `probe`; `None` when no
    /// wall lies that way or the probe cannot get there and back.
    fn moves(
        &self,
        world: &UncertainWorld<'_>,
        settings: &WallPressSettings,
    ) -> Option<(f64, Vec<[f64; 2]>)> {
        let walls = &world.fixture.walls;
        let gap = gap_along(self.outline, self.d, walls).filter(|g| *g > 1.0)?;
        let clear = settings.clearance_fraction * self.diameter;
        let r = world.model.probe_radius_um;
        let c = self.outline.centroid();
        let behind = support(self.outline.vertices(), c, -self.d);
        let s = c - self.d * (behind + r + clear);
        let overshoot = settings.overshoot_fraction * world.model.probe_deflection_limit_um;
        // Where the probe must reach: the part translated until it touches the wall, or —
        // when it turns flat against the wall first — squared, with the face whose normal is
        // nearest the press flush against it; whichever is farther.
        let square = squared(self.outline, self.d);
        let to_wall =
            walls.iter().filter_map(|w| ray_distance(c, self.d, w)).min_by(f64::total_cmp);
        let flush = to_wall.map_or(f64::NEG_INFINITY, |t| {
            t - support(&square, c, self.d) - support(&square, c, -self.d)
        });
        // Squared only where the squared part fits there (no wall corner in the way).
        let shift = self.d * (to_wall.unwrap_or(0.0) - support(&square, c, self.d));
        let squared_at_wall = ConvexPolygon::new(square.iter().map(|p| *p + shift).collect())
            .ok()
            .filter(|p| flush > gap - behind && !overlaps(p, walls));
        let (reach, moved) = match squared_at_wall {
            Some(p) => (flush, p),
            None => (gap - behind, self.outline.translated(&(self.d * gap))),
        };
        let e = c + self.d * (reach - r + overshoot);
        let back = e - self.d * clear;
        let lm = Vec2::new(self.last_move[0], self.last_move[1]);
        let off = self.probe - lm.normalize() * clear;
        let obstacles = |peg| Obstacles { walls, peg, probe_radius_um: r, peg_clearance_um: 0.0 };
        let there = route(off, s, &obstacles(Some(self.outline)))?;
        let home = route(back, off, &obstacles(Some(&moved)))?;
        let mut moves = vec![[off.x - self.probe.x, off.y - self.probe.y]];
        moves.extend(there);
        moves.push([e.x - s.x, e.y - s.y]);
        moves.push([back.x - e.x, back.y - e.y]);
        moves.extend(home);
        moves.push([self.probe.x - off.x, self.probe.y - off.y]);
        Some((gap, moves))
    }
}

/// What the screening found: the successes of the plan without a press and of the best
/// variant (None when no variant was tried), on the same worlds.
#[derive(Debug, Clone, PartialEq)]
pub struct Screened {
    /// Successes of the plan as given.
    pub without: usize,
    /// The best variant and its successes, if any variant ran.
    pub best: Option<(WallPress, usize)>,
    /// Worlds each ran on.
    pub samples: usize,
    /// Variants screened.
    pub variants: usize,
}

impl Screened {
    /// Whether the best variant beat the plan without it on the screening worlds.
    pub fn improves(&self) -> bool {
        self.best.as_ref().is_some_and(|b| b.1 > self.without)
    }

    /// Replays the screening ran.
    pub fn replays(&self) -> usize {
        self.samples * (self.variants + 1)
    }
}

/// Adds up to [`WallPressSettings::max_presses`] presses to `plan`, one screening round each
/// (round `i` on the worlds of `seed + i`), while the best variant beats the plan so far.
/// Returns the plan and every round's screening.
pub fn add_wall_presses(
    plan: &Plan,
    start: PegStart,
    world: &UncertainWorld<'_>,
    settings: &WallPressSettings,
    seed: u64,
) -> Result<(Plan, Vec<Screened>), crate::Error> {
    let mut plan = plan.clone();
    let mut rounds = Vec::new();
    for i in 0..settings.max_presses {
        let s = screen_wall_presses(&plan, start, world, settings, seed.wrapping_add(i as u64))?;
        let improves = s.improves();
        if let Some((best, _)) = s.best.as_ref().filter(|_| improves) {
            plan = best.plan.clone();
        }
        rounds.push(s);
        if !improves {
            break;
        }
    }
    Ok((plan, rounds))
}

/// Screens every wall-press variant of `plan` on `settings.screen_samples` worlds drawn from
/// `seed` (with the plan itself on the same worlds); variants whose probe path enters a wall
/// or whose nominal replay does not insert are not screened.
pub fn screen_wall_presses(
    plan: &Plan,
    start: PegStart,
    world: &UncertainWorld<'_>,
    settings: &WallPressSettings,
    seed: u64,
) -> Result<Screened, crate::Error> {
    let plan = &Plan { peg_start: start, ..plan.clone() };
    let mut sim =
        Simulator::new(world.model.clone(), world.fixture.clone(), world.settings.clone())?;
    let r = world.model.probe_radius_um;
    let variants: Vec<WallPress> = wall_press_variants(plan, world, settings)?
        .into_iter()
        .filter(|v| {
            let p = &v.plan;
            first_wall_violation(p.probe_start(), &p.moves_um, &world.fixture.walls, r).is_none()
                && p.validate().is_ok()
                && replay(&mut sim, p, None).is_ok_and(|rep| rep.inserted && rep.events.is_empty())
        })
        .collect();
    let n = settings.screen_samples.max(1);
    let worlds = draws(world.model, &world.uncertainty, world.supports, n, seed);
    let plans: Vec<&Plan> = std::iter::once(plan).chain(variants.iter().map(|v| &v.plan)).collect();
    let ok: Vec<bool> = (0..plans.len() * n)
        .into_par_iter()
        .map(|k| {
            crate::montecarlo::run_trial(
                plans[k / n],
                &worlds[k % n],
                world.fixture,
                world.settings,
            )
            .inserted
        })
        .collect();
    let counts: Vec<usize> = ok.chunks(n).map(|c| c.iter().filter(|b| **b).count()).collect();
    let best = (1..plans.len()).fold(None, |b: Option<usize>, i| {
        if b.is_none_or(|b| counts[i] > counts[b]) { Some(i) } else { b }
    });
    Ok(Screened {
        without: counts[0],
        best: best.map(|i| (variants[i - 1].clone(), counts[i])),
        samples: n,
        variants: variants.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gap_to_a_wall_is_the_translation_that_makes_them_touch() {
        let part = ConvexPolygon::rectangle(200.0, 100.0).unwrap();
        let wall = mesopush_sim::fixture::rect(-1000.0, -400.0, 1000.0, -300.0).unwrap();
        // The part's top edge at y = −50, the wall's bottom at y = −300: 250 along −y.
        let g = gap_along(&part, Vec2::new(0.0, -1.0), std::slice::from_ref(&wall)).unwrap();
        assert!((g - 250.0).abs() < 1e-9, "{g}");
        // Nothing that way along +y.
        assert_eq!(gap_along(&part, Vec2::new(0.0, 1.0), &[wall]), None);
        // A wall corner poking down at x = 0 meets the part's top edge (vertex of the wall).
        let spike = ConvexPolygon::new(vec![
            Vec2::new(-10.0, -500.0),
            Vec2::new(10.0, -500.0),
            Vec2::new(0.0, -120.0),
        ])
        .unwrap();
        let g = gap_along(&part, Vec2::new(0.0, -1.0), &[spike]).unwrap();
        assert!((g - 70.0).abs() < 1e-9, "{g}");
    }
}
