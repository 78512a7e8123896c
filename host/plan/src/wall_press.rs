//! Uncertainty-removing moves: press the part against a wall. A part pushed flat against a
//! fixture wall leaves with one coordinate and its orientation set by the wall, not by where
//! it started (the sensorless idea the paper's discussion points to: orient parts by pushing
//! them against fences).
//!
//! [`wall_press_variants`] builds, from a plan and its nominal replay, one variant per
//! direction (±x, ±y) before the first move and after each pushing move: there the probe
//! backs off (after a push), goes round behind the
//! part, pushes it along the direction until it meets the nearest wall that way (plus an
//! overshoot, which the needle's compliance absorbs), backs off again and returns to where the
//! plan left off. [`screen_wall_presses`] scores every variant and the plan on the same
//! sampled worlds; [`add_wall_presses`] keeps the best variant only if it beats the plan
//! without it, up to [`WallPressSettings::max_presses`] times; the robust design then tunes
//! all the moves of the result ([`crate::family::PathFamily`]).

use crate::clearance::{Obstacles, first_wall_violation};
use crate::montecarlo::{draws, trial_seed};
use crate::route::{merge_moves, route};
use crate::score::{count, plan_outcomes};
use crate::wall_geometry::{TOUCH_FRACTION, gap_along, overlaps, ray_distance, squared, support};
use crate::world::UncertainWorld;
use mesopush_core::geom::{ConvexPolygon, Vec2};
use mesopush_sim::plan::PegStart;
use mesopush_sim::{Plan, Simulator, replay};

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
    /// Only presses before the first move (on the part where it starts, before any push has
    /// spread its uncertainty). Default false.
    pub at_start_only: bool,
}

impl Default for WallPressSettings {
    fn default() -> Self {
        Self {
            max_gap_fraction: 0.3,
            overshoot_fraction: 0.5,
            clearance_fraction: 0.05,
            screen_samples: 64,
            max_presses: 3,
            at_start_only: false,
        }
    }
}

/// A plan with one wall press inserted.
#[derive(Debug, Clone, PartialEq)]
pub struct WallPress {
    /// After which move of the original plan (0-based) the press runs; `None`: before the
    /// first move, on the part where it starts (its start uncertainty not yet spread by a push).
    pub after_move: Option<usize>,
    /// Direction of the press: "+x", "-x", "+y" or "-y".
    pub direction: &'static str,
    /// Nominal gap between the part and the wall before the press, µm.
    pub gap_um: f64,
    /// The plan with the press.
    pub plan: Plan,
}

const DIRECTIONS: [(&str, [f64; 2]); 4] =
    [("+x", [1.0, 0.0]), ("-x", [-1.0, 0.0]), ("+y", [0.0, 1.0]), ("-y", [0.0, -1.0])];

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
    let diameter = part.diameter();
    let mut out = Vec::new();
    // Before the first move: the part where it starts, the probe where it starts.
    let outline = part.transformed(&plan.peg_start_pose());
    let at_start = Spot { outline: &outline, probe: plan.probe_start(), last_move: None };
    out.extend(at_start.variants(None, &[], &plan.moves_um, world, settings, diameter));
    let mut probe = plan.probe_start();
    let after_pushes = if settings.at_start_only { &[][..] } else { &plan.moves_um[..] };
    for (k, m) in after_pushes.iter().enumerate() {
        probe += Vec2::new(m[0], m[1]);
        let during: Vec<_> = rep.samples.iter().filter(|s| s.move_index == k).collect();
        let pushed = during.iter().any(|s| s.probe_force > 0.0);
        let Some(last) = during.last().filter(|_| pushed) else { continue };
        let outline = part.transformed(&last.peg);
        let spot = Spot { outline: &outline, probe, last_move: Some(*m) };
        let (before, after) = plan.moves_um.split_at(k + 1);
        out.extend(spot.variants(Some(k), before, after, world, settings, diameter));
    }
    let out = out
        .into_iter()
        .map(|(after_move, direction, gap_um, moves_um)| WallPress {
            after_move,
            direction,
            gap_um,
            plan: Plan { moves_um, ..plan.clone() },
        })
        .collect();
    Ok(out)
}

/// Where a press may start: the part's outline and the probe's position there, and the move
/// that brought the probe (none at the plan's start, where the probe is not touching).
struct Spot<'a> {
    outline: &'a ConvexPolygon,
    probe: Vec2,
    last_move: Option<[f64; 2]>,
}

/// A variant before it becomes a plan: after which move, direction, gap, all moves.
type Variant = (Option<usize>, &'static str, f64, Vec<[f64; 2]>);

impl Spot<'_> {
    /// One variant per direction with a wall near enough: `before`, the press, `after`.
    fn variants(
        &self,
        after_move: Option<usize>,
        before: &[[f64; 2]],
        after: &[[f64; 2]],
        world: &UncertainWorld<'_>,
        settings: &WallPressSettings,
        diameter: f64,
    ) -> Vec<Variant> {
        let mut out = Vec::new();
        for (name, d) in DIRECTIONS {
            let d = Vec2::new(d[0], d[1]);
            let press = Press {
                outline: self.outline,
                probe: self.probe,
                last_move: self.last_move,
                d,
                diameter,
            };
            if let Some((gap, moves)) = press.moves(world, settings)
                && gap <= settings.max_gap_fraction * diameter
            {
                let mut all = before.to_vec();
                all.extend(moves);
                all.extend_from_slice(after);
                out.push((after_move, name, gap, merge_moves(all)));
            }
        }
        out
    }
}

/// One press being built.
struct Press<'a> {
    outline: &'a ConvexPolygon,
    probe: Vec2,
    last_move: Option<[f64; 2]>,
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
        let tol = TOUCH_FRACTION * self.diameter;
        let (c, d) = (self.outline.centroid(), self.d);
        let gap = gap_along(self.outline, d, walls, tol)?;
        let clear = settings.clearance_fraction * self.diameter;
        let r = world.model.probe_radius_um;
        // The probe runs along the line through the centroid: it starts behind the part's
        // farthest point and meets the part where that line crosses its outline.
        let s = c - d * (support(self.outline.vertices(), c, -d) + r + clear);
        let contact = |p: &ConvexPolygon, at: Vec2| ray_distance(at, -d, p, -1.0);
        // Where the part ends: squared (the face whose normal is nearest the press flush
        // against the wall it meets), if the squared part gets there without a wall corner in
        // the way; else translated onto the first contact.
        let turned = ConvexPolygon::new(squared(self.outline, d)).ok()?;
        let squared_end = gap_along(&turned, d, walls, tol)
            .map(|g| (g, turned.translated(&(d * g))))
            .filter(|(_, p)| !overlaps(p, walls, tol));
        let (shift, moved) = match squared_end {
            Some((g, p)) if g > gap => (g, p),
            _ => (gap, self.outline.translated(&(d * gap))),
        };
        let behind = contact(&moved, c + d * shift)?;
        let overshoot = settings.overshoot_fraction * world.model.probe_deflection_limit_um;
        let e = c + d * (shift - behind - r + overshoot);
        let back = e - d * (overshoot + clear);
        // Back off along the move that brought the probe (at the plan's start it touches
        // nothing: it leaves from where it is).
        let back_dir = self.last_move.map(|m| Vec2::new(m[0], m[1]).normalize());
        let off = back_dir.map_or(self.probe, |b| self.probe - b * clear);
        let obstacles = |peg| Obstacles { walls, peg, probe_radius_um: r, peg_clearance_um: 0.0 };
        let there = route(off, s, &obstacles(Some(self.outline)))?;
        let home = route(back, off, &obstacles(Some(&moved)))?;
        // The last step back onto the plan's path must not sweep through the moved part (up
        // to touching it where the plan's push had left the probe touching the part).
        if let Some(b) = back_dir
            && !obstacles(Some(&moved)).segment_free(&off, &(self.probe - b * tol))
        {
            return None;
        }
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

    /// Monte Carlo replays the screening ran (the variants' nominal replays, one each, are
    /// not counted).
    pub fn replays(&self) -> usize {
        self.samples * (self.variants + 1)
    }
}

/// Adds up to [`WallPressSettings::max_presses`] presses to `plan`, one screening round each
/// (round `i` on the worlds of [`trial_seed`]`(seed, i)`), while the best variant beats the plan so far.
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
        let s = screen_wall_presses(&plan, start, world, settings, trial_seed(seed, i as u64))?;
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
    let plans: Vec<Plan> =
        std::iter::once(plan.clone()).chain(variants.iter().map(|v| v.plan.clone())).collect();
    let ok = plan_outcomes(&plans, &worlds, world);
    let counts: Vec<usize> = ok.iter().map(|o| count(o)).collect();
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
