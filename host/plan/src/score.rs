//! Scoring plan skeletons on sampled worlds: every candidate replayed in every world as one
//! flat parallel batch (rayon), collected in index order, so a score does not depend on the
//! thread count. The CEM races candidates with it; the robust design validates and confirms
//! its finalists with it.

use crate::montecarlo::run_trial;
use crate::sampler::Draw;
use crate::skeleton::Skeleton;
use crate::world::UncertainWorld;
use mesopush_sim::Plan;
use mesopush_sim::plan::PegStart;
use rayon::prelude::*;

/// Success counts of every candidate on `worlds`: one flat parallel batch, in order.
pub fn successes(
    cands: &[Skeleton],
    worlds: &[Draw],
    world: &UncertainWorld<'_>,
    start: PegStart,
) -> Vec<usize> {
    outcomes(cands, worlds, world, start).iter().map(|o| count(o)).collect()
}

/// Every candidate's outcome in every world of `worlds` (one flat parallel batch, in order).
pub fn outcomes(
    cands: &[Skeleton],
    worlds: &[Draw],
    world: &UncertainWorld<'_>,
    start: PegStart,
) -> Vec<Vec<bool>> {
    let plans: Vec<Plan> = cands.iter().map(|s| s.to_plan("", start)).collect();
    let n = worlds.len();
    let ok: Vec<bool> = (0..plans.len() * n)
        .into_par_iter()
        .map(|k| run_trial(&plans[k / n], &worlds[k % n], world.fixture, world.settings).inserted)
        .collect();
    ok.chunks(n.max(1)).map(<[bool]>::to_vec).collect()
}

/// Successes among `outcomes`.
pub(crate) fn count(outcomes: &[bool]) -> usize {
    outcomes.iter().filter(|b| **b).count()
}
