//! The nominal model of a set-up: what one would assume before fitting anything, from the
//! facts the data's README states — the set-up's part and the two-finger hand, a uniform
//! pressure over the part's face (what the authors' planner assumed) as its equivalent
//! three-point support ([`SupportDistribution::uniform_pressure`]), and finger friction 0.3,
//! within the 0.25–0.4 the planner assumed. The surface friction (0.3) does not change a
//! quasi-static push when it is the same at every support; it is there for completeness.

use super::setup::SetUp;
use super::trial_meta::{part, pusher};
use crate::Error;
use mesopush_sim::{Model, SupportDistribution};

/// Finger–part friction of the nominal model (the middle of the planner's 0.25–0.4).
pub const NOMINAL_MU_FINGER: f64 = 0.3;
/// Surface friction of the nominal model.
pub const NOMINAL_MU_SURFACE: f64 = 0.3;

/// The nominal model of `set_up`, validated.
pub fn nominal_model(set_up: SetUp) -> Result<Model, Error> {
    let part = part(set_up)?;
    let pusher = pusher();
    let model = Model {
        support: SupportDistribution::uniform_pressure(&part, NOMINAL_MU_SURFACE),
        part,
        mu_probe: NOMINAL_MU_FINGER,
        probe_radius_um: pusher.max_radius_um(),
        pusher: Some(pusher),
        ..Model::default()
    };
    model.validate()?;
    Ok(model)
}
