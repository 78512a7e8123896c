//! Scoring candidate plans (points of a [`PlanFamily`]) on sampled worlds: every candidate replayed in every world as one
//! flat parallel batch (rayon), collected in index order, so a score does not depend on the
//! thread count. The CEM races candidates with it; the robust design validates and confirms
//! its finalists with it.

use crate::clearance::first_wall_violation;
use crate::family::PlanFamily;
use crate::montecarlo::run_trial;
use crate::sampler::Draw;
use crate::world::UncertainWorld;
use mesopush_sim::Plan;
use mesopush_sim::plan::PegStart;
use rayon::prelude::*;

/// Success counts of every candidate on `worlds`: one flat parallel batch, in order.
pub fn successes(
    family: &dyn PlanFamily,
    cands: &[Vec<f64>],
    worlds: &[Draw],
    world: &UncertainWorld<'_>,
    start: PegStart,
) -> Vec<usize> {
    outcomes(family, cands, worlds, world, start).iter().map(|o| count(o)).collect()
}

/// Every candidate's outcome in every world of `worlds` (one flat parallel batch, in order).
/// A candidate whose probe path runs into a wall fails every world unsimulated (the
/// simulator ignores probe–wall contact; a rig would crash the needle).
pub fn outcomes(
    family: &dyn PlanFamily,
    cands: &[Vec<f64>],
    worlds: &[Draw],
    world: &UncertainWorld<'_>,
    start: PegStart,
) -> Vec<Vec<bool>> {
    let plans: Vec<Plan> = cands.iter().map(|s| family.plan(s, start, "")).collect();
    plan_outcomes(&plans, worlds, world)
}

/// Every plan's outcome in every world of `worlds` (one flat parallel batch, in order); a
/// plan whose probe path runs into a wall fails every world unsimulated.
pub fn plan_outcomes(
    plans: &[Plan],
    worlds: &[Draw],
    world: &UncertainWorld<'_>,
) -> Vec<Vec<bool>> {
    let r = world.model.probe_radius_um;
    let clear: Vec<bool> = plans
        .iter()
        .map(|p| {
            first_wall_violation(p.probe_start(), &p.moves_um, &world.fixture.walls, r).is_none()
        })
        .collect();
    let n = worlds.len();
    let ok: Vec<bool> = (0..plans.len() * n)
        .into_par_iter()
        .map(|k| {
            let (c, w) = (k / n, k % n);
            clear[c] && run_trial(&plans[c], &worlds[w], world.fixture, world.settings).inserted
        })
        .collect();
    ok.chunks(n.max(1)).map(<[bool]>::to_vec).collect()
}

/// Successes among `outcomes`.
pub(crate) fn count(outcomes: &[bool]) -> usize {
    outcomes.iter().filter(|b| **b).count()
}
