//! The effect the free imaged tip names ([`crate::free_tip`]), put into the model before the
//! part is fitted again. A stage or camera effect distorts every pose the nominal support
//! fit saw, so the support it found has bent to absorb the effect; refitting only the
//! nominal parameters about that support cannot undo the bend (the independent generator's
//! 2 % image scale, seed-12 scale-00: the scale held at the free tip's 2.00 % with the four
//! nominal parameters refitted left the held-out error at 3 405 noise units against the
//! nominal's 2 281). Held at the free tip's values from the start, the whole nominal fit —
//! its support families, at the coarse step — runs again on trials it now reads through the
//! effect, and that fit is the named effect's.

use super::candidates::nominal_values;
use super::fit::Fit;
use super::free_tip::FreeTip;
use super::nominal::nominal_base;
use super::polish::NearFloor;

/// The joint fit of the stage or camera effect `free` names (its own parameters held where
/// the free tip puts them), the nominal model refitted from `near`'s prior with it in, as
/// the main pass fits the nominal model at its coarse step (`near` carries the prior, the
/// trials, the floor band and the options); None when the free tip names none.
pub fn refit_named(
    free: Option<&FreeTip>,
    near: &NearFloor<'_>,
    progress: &(dyn Fn(&str) + Sync),
) -> Option<Fit> {
    let opts = near.opts;
    let c = free?.winner(opts.floor_factor, opts.min_gain)?;
    let effect = &free?.fit_of(c)?.values;
    let p = near.prior;
    let prior = c.apply(p, &[&nominal_values(p)[..], effect].concat());
    progress(&format!("nominal refit with {} held", c.name()));
    // At the main pass's coarse step: the finer step's refit (`NearFloor::refit`) cost a
    // third more time here and predicted the held-out trials no better (seed-1 backlash-01:
    // 4.5 against 4.1 noise units; seed-12 scale-00: 10.2 against 10.6).
    let (fit, ..) = nominal_base(&prior, near.train, near.held, near.band, opts);
    let values = [&fit.values[..], effect].concat();
    let model = c.apply(&fit.base, &values);
    debug_assert_eq!(model, fit.model, "the refit's base carries the held effect");
    Some(Fit {
        candidate: c,
        values,
        model,
        base: fit.base,
        loss: fit.loss,
        n: fit.n,
        evals: fit.evals,
    })
}
