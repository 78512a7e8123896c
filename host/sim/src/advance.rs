//! Moving the probe along one straight segment: free-space jumps while the probe is clear of
//! the peg, steps of at most `step_um` of probe travel near it. Shared by plan replays
//! ([`mod@super::replay`]) and recorded-path replays ([`super::path`]) so both see the same
//! physics.

use super::stepper::{SimState, Simulator, StepInfo};
use crate::Error;
use mesopush_core::geom::Vec2;

/// How a segment ended.
#[derive(Debug)]
pub enum SegmentEnd {
    /// The probe reached the segment's end.
    Reached,
    /// The peg wedged: the probe stopped `done_um` along the segment.
    Jammed {
        /// Travel completed before the jam, µm.
        done_um: f64,
        /// The simulator's reason.
        cause: Error,
    },
}

/// Moves the probe by `delta_um` from `st`, calling `on_step(state, info, done_um)` after
/// every step; `budget` counts steps and is decremented (an exhausted budget is an error).
pub fn advance(
    sim: &mut Simulator,
    st: &mut SimState,
    delta_um: Vec2,
    budget: &mut usize,
    on_step: impl FnMut(&SimState, &StepInfo, f64),
) -> Result<SegmentEnd, Error> {
    advance_turning(sim, st, (delta_um, 0.0), budget, on_step)
}

/// As [`advance`], with the pusher also turning by `delta.1` rad about its reference point
/// while its reference point moves by `delta.0` µm, both in proportion. Travel (`done_um`,
/// steps, free jumps) is measured as [`Simulator::pusher_travel_um`]: the most any pusher
/// point moves.
pub fn advance_turning(
    sim: &mut Simulator,
    st: &mut SimState,
    delta: (Vec2, f64),
    budget: &mut usize,
    mut on_step: impl FnMut(&SimState, &StepInfo, f64),
) -> Result<SegmentEnd, Error> {
    let (step_um, margin) = (sim.settings().step_um, sim.settings().contact_margin_um);
    let (delta_um, d_theta_rad) = delta;
    let len = sim.pusher_travel_um(delta_um, d_theta_rad);
    let dir = delta_um / len.max(f64::MIN_POSITIVE);
    let turn = d_theta_rad / len.max(f64::MIN_POSITIVE);
    let mut done = 0.0;
    while len - done > 1e-9 {
        if *budget == 0 {
            let max = sim.settings().max_steps;
            return Err(Error::invalid("replay", format!("exceeded max_steps = {max}")));
        }
        *budget -= 1;
        let free = sim.probe_gap_um(st) - margin;
        let remaining = len - done;
        let info = if free > step_um {
            let d = free.min(remaining);
            st.probe_um += dir * d;
            st.probe_theta_rad += turn * d;
            done += d;
            StepInfo::default()
        } else {
            let d = step_um.min(remaining);
            match sim.step_turning(st, dir * d, turn * d) {
                Ok(info) => {
                    done += d;
                    info
                }
                Err(cause) => return Ok(SegmentEnd::Jammed { done_um: done, cause }),
            }
        };
        on_step(st, &info, done);
    }
    Ok(SegmentEnd::Reached)
}
