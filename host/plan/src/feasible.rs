//! The one check every plan passes before it is kept: replayed from its start, it inserts the
//! peg without jamming and without bending the needle beyond the model's limit (an overloaded
//! replay is never inserted, [`mesopush_sim::needle`]), and its probe path stays out of the
//! walls and inside the executor's workspace (the simulator ignores probe–wall contact, so
//! the replay alone cannot tell).

use crate::Error;
use crate::clearance::first_wall_violation;
use mesopush_sim::{Plan, Simulator, replay};

/// Whether `plan`, replayed from its start, inserts the peg without jamming or overloading the
/// needle and keeps the probe out of the walls and inside the executor's workspace.
pub fn plan_is_feasible(sim: &mut Simulator, plan: &Plan) -> Result<bool, Error> {
    let r = sim.model().probe_radius_um;
    if first_wall_violation(plan.probe_start(), &plan.moves_um, &sim.fixture().walls, r).is_some() {
        return Ok(false);
    }
    let rep = replay(sim, plan, None)?;
    Ok(rep.inserted && rep.events.is_empty())
}
