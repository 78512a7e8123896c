//! Where each candidate's search starts. A simplex only finds what its start can see, so the
//! starts come from the physics of each effect's signature:
//! - a friction patch shows only where the peg's supports straddle the patch's edge (a
//!   uniform change of the surface friction scales every support force alike and moves
//!   nothing): its edge is scanned where the supports travelled ([`patch`]);
//! - a support drift is a trend of the support over the trials' places in the batch: a
//!   regression of per-trial support shifts on the trial index, and a grid about the training
//!   trials' mean index ([`drift`]);
//! - every other effect starts from the nominal optimum with each combination of its grid.

mod context;
pub mod drift;
pub mod patch;

pub use context::StartContext;

use crate::candidates::Effect;
use crate::data::TrialData;
use crate::fit::refit_nominal;

/// Start vectors (full parameter vectors) of `c` from the nominal optimum `nominal`.
pub fn starts(
    c: Effect,
    nominal: &[f64],
    train: &[TrialData],
    ctx: &StartContext<'_>,
) -> Vec<Vec<f64>> {
    let mut out = signature_starts(c, nominal, train, ctx);
    // The effect off (its parameters at zero; a patch as wide as the plate with the nominal
    // friction): the extended model nests the nominal one, so its fit is never worse.
    out.push(off(c, nominal));
    out
}

/// The full parameter vector of `c` with its effect off at the nominal optimum.
fn off(c: Effect, nominal: &[f64]) -> Vec<f64> {
    let mut v: Vec<f64> = nominal.to_vec();
    if c == Effect::FrictionPatch {
        let p = c.effect_params();
        v.extend([nominal[1], p[1].lo, p[2].lo, p[3].hi, p[4].hi]);
    } else {
        v.extend(c.effect_params().iter().map(|_| 0.0));
    }
    v
}

fn signature_starts(
    c: Effect,
    nominal: &[f64],
    train: &[TrialData],
    ctx: &StartContext<'_>,
) -> Vec<Vec<f64>> {
    match c {
        Effect::FrictionPatch => patch::patch_starts(nominal, train, ctx),
        Effect::SpeedFriction => profile_starts(c, grid_starts(c, nominal), train, ctx),
        Effect::SupportDrift => {
            let mut s = drift::drift_starts(nominal, train);
            s.extend(drift::drift_trend_start(nominal, train, ctx));
            profile_starts(c, s, train, ctx)
        }
        Effect::Adhesion => {
            // The nominal fit absorbs an adhesive drag with surface friction (it ends at its
            // bound); start the adhesion grid from the prior surface friction too.
            let mut prior = nominal.to_vec();
            prior[1] = ctx.prior_mu[1];
            let mut s = grid_starts(c, nominal);
            s.extend(grid_starts(c, &prior));
            s
        }
        _ => grid_starts(c, nominal),
    }
}

/// Profile starts: `out` and, for each of its starts, the nominal parameters refitted with
/// the effect held there — the nominal optimum has absorbed what
/// it could of the effect, and the effect at that optimum can look worse than none.
fn profile_starts(
    c: Effect,
    mut out: Vec<Vec<f64>>,
    train: &[TrialData],
    ctx: &StartContext<'_>,
) -> Vec<Vec<f64>> {
    let profiled: Vec<Vec<f64>> = out
        .iter()
        .map(|v| {
            refit_nominal(c, ctx.base, train, ctx.settings, ctx.noise, v, ctx.evals_per_trial).0
        })
        .collect();
    out.extend(profiled);
    out
}

fn grid_starts(c: Effect, nominal: &[f64]) -> Vec<Vec<f64>> {
    let mut out = vec![nominal.to_vec()];
    for p in c.effect_params() {
        let grid = if p.grid.is_empty() { &[0.0][..] } else { p.grid };
        out = out
            .iter()
            .flat_map(|v| grid.iter().map(move |g| [v.as_slice(), &[*g]].concat()))
            .collect();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_starts_are_every_combination() {
        let nominal = [0.8, 0.3, 0.0, 0.0];
        let s = grid_starts(Effect::Backlash, &nominal);
        assert_eq!(s.len(), 9);
        assert!(s.iter().all(|v| v.len() == 6 && v[..4] == nominal));
    }
}
