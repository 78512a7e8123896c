//! Replays a plan through the simulator: probe moves cut into steps of probe travel (one jump
//! where the probe is clear of the peg), the trajectory recorded, the verdict judged: inserted
//! only when the peg ends in the goal *and* the needle stayed within its limit
//! ([`crate::needle`]).

use super::advance::{SegmentEnd, advance};
use super::needle::{NeedleWatch, Overload};
use super::plan::Plan;
use super::stepper::{SimState, Simulator, StepInfo, contact_label};
use crate::Error;
use mesopush_core::geom::{Pose, Vec2};
use serde::Serialize;

/// One recorded instant of a replay.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Sample {
    /// Time since the plan started, s (probe travel over speed).
    pub t_s: f64,
    /// Index of the move being executed (0-based).
    pub move_index: usize,
    /// Probe tip, µm.
    pub probe_um: [f64; 2],
    /// Peg pose.
    pub peg: Pose,
    /// Contacts carrying force and their modes, e.g. `probe:stick;wall3v:slide`.
    pub contacts: String,
    /// Probe normal force, in part weights.
    pub probe_force: f64,
    /// Whether this step solved an LCP (false: free travel or the start).
    #[serde(skip)]
    pub solved_lcp: bool,
}

/// Something that happened during a replay.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimEvent {
    /// Time, s.
    pub t_s: f64,
    /// Move index (0-based).
    pub move_index: usize,
    /// What happened.
    pub what: String,
}

/// The result of a replay.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Replay {
    /// Every step, in order (the start state first).
    pub samples: Vec<Sample>,
    /// The verdict: the peg ended inside the goal (narrow channel) and the needle was never
    /// overloaded (`overload` is `None`).
    pub inserted: bool,
    /// Whether the peg ended inside the goal, overloaded or not.
    pub peg_in_goal: bool,
    /// Final peg pose.
    pub final_pose: Pose,
    /// Time steps taken (LCP solves plus free-space jumps).
    pub steps: usize,
    /// LCP solves.
    pub lcp_solves: usize,
    /// Largest penetration of the peg into a wall seen after any step, µm.
    pub max_penetration_um: f64,
    /// Largest probe needle deflection (compliance × force; after a jam, plus the travel the
    /// probe was commanded past the point where it stopped), µm: how far the commanded tip
    /// position overlaps the peg because the needle bends.
    pub max_probe_deflection_um: f64,
    /// Largest probe normal force, part weights.
    pub max_probe_force_weights: f64,
    /// The needle's deflection limit the replay was judged against, µm (the model's
    /// `probe_deflection_limit_um`).
    pub probe_deflection_limit_um: f64,
    /// Where and how far the needle was bent beyond its limit, when it was: the plan is then
    /// not inserted, whatever the final pose.
    pub overload: Option<Overload>,
    /// Jams and other events.
    pub events: Vec<SimEvent>,
}

fn sample(t_s: f64, move_index: usize, st: &SimState, info: &StepInfo) -> Sample {
    let contacts = info
        .active
        .iter()
        .map(|(k, m)| format!("{}:{}", contact_label(*k), format!("{m:?}").to_lowercase()))
        .collect::<Vec<_>>()
        .join(";");
    Sample {
        t_s,
        move_index,
        probe_um: [st.probe_um.x, st.probe_um.y],
        peg: st.peg,
        contacts,
        probe_force: info.probe_force,
        solved_lcp: info.solved_lcp,
    }
}

/// Replays `plan` from its own start state, or from `start` when given.
pub fn replay(sim: &mut Simulator, plan: &Plan, start: Option<Pose>) -> Result<Replay, Error> {
    plan.validate()?;
    let mut st = SimState::new(start.unwrap_or(plan.peg_start_pose()), plan.probe_start());
    let mut out = Replay {
        samples: vec![sample(0.0, 0, &st, &StepInfo::default())],
        inserted: false,
        peg_in_goal: false,
        final_pose: st.peg,
        steps: 0,
        lcp_solves: 0,
        max_penetration_um: 0.0,
        max_probe_deflection_um: 0.0,
        max_probe_force_weights: 0.0,
        probe_deflection_limit_um: sim.model().probe_deflection_limit_um,
        overload: None,
        events: Vec::new(),
    };
    let mut needle = NeedleWatch::new(out.probe_deflection_limit_um);
    let mut budget = sim.settings().max_steps;
    let mut travel_um = 0.0;
    for (mi, [dx, dy]) in plan.moves_um.iter().enumerate() {
        let delta = Vec2::new(*dx, *dy);
        let speed = plan.speed_um_s;
        let end = advance(sim, &mut st, delta, &mut budget, |st, info, done| {
            out.steps += 1;
            out.lcp_solves += usize::from(info.solved_lcp);
            out.max_penetration_um = out.max_penetration_um.max(info.penetration_um);
            let t_s = (travel_um + done) / speed;
            needle.note(mi, t_s, info.probe_deflection_um, info.probe_force);
            out.samples.push(sample(t_s, mi, st, info));
        })?;
        if let SegmentEnd::Jammed { done_um, cause } = end {
            let t_s = (travel_um + done_um) / speed;
            let compliance = sim.settings().probe_compliance_um;
            needle.note_jam(mi, t_s, delta.norm() - done_um, compliance);
            out.events.push(SimEvent {
                t_s,
                move_index: mi,
                what: format!("jammed: probe stopped for the rest of the move ({cause})"),
            });
        }
        travel_um += delta.norm();
    }
    out.max_probe_deflection_um = needle.peak_deflection_um();
    out.max_probe_force_weights = needle.max_force_weights();
    out.overload = needle.overload();
    let outline = sim.model().part.polygon().transformed(&st.peg);
    out.peg_in_goal = sim.fixture().part_inserted(&outline, &st.peg.position());
    out.inserted = out.peg_in_goal && out.overload.is_none();
    out.final_pose = st.peg;
    Ok(out)
}
