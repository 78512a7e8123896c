//! Replaying a recorded probe path (what a trial log's probe.csv holds) instead of a plan:
//! the probe goes straight from waypoint to waypoint, the peg follows quasi-statically, and
//! the peg pose is reported at every waypoint's time. Identification and diagnosis compare
//! these poses with the tracked ones.

use super::advance::{SegmentEnd, advance_turning};
use super::stepper::{SimState, Simulator};
use crate::Error;
use mesopush_core::geom::{Pose, Vec2};

/// One waypoint of a probe path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbePoint {
    /// Time since the trial started, s.
    pub t_s: f64,
    /// The pusher's reference point (the probe tip centre of a one-disc pusher), µm
    /// (fixture frame).
    pub probe_um: Vec2,
    /// The pusher's angle, rad (0 for a pusher that does not turn).
    pub probe_theta_rad: f64,
}

impl ProbePoint {
    /// A waypoint of a pusher that does not turn.
    pub fn new(t_s: f64, probe_um: Vec2) -> Self {
        Self { t_s, probe_um, probe_theta_rad: 0.0 }
    }
}

/// The simulated state at one waypoint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathSample {
    /// Time since the trial started, s.
    pub t_s: f64,
    /// Where the simulated probe is (behind the waypoint after a jam), µm.
    pub probe_um: Vec2,
    /// Peg pose.
    pub peg: Pose,
    /// Probe normal force at the last step before the waypoint, part weights.
    pub probe_force: f64,
}

/// A whole path replay.
#[derive(Debug, Clone, PartialEq)]
pub struct PathReplay {
    /// One sample per waypoint, in order.
    pub samples: Vec<PathSample>,
    /// Segments on which the peg wedged (the probe then skips to the next waypoint's
    /// direction from where it stopped).
    pub jams: usize,
    /// Time steps taken.
    pub steps: usize,
    /// LCP solves.
    pub lcp_solves: usize,
    /// How far the peg was moved at the start to clear a pusher recorded inside it (within
    /// the registration tolerance), µm (0 when it started clear).
    pub start_separation_um: f64,
}

/// Follows `path` from the peg at `start`; the pusher starts at the first waypoint. A pusher
/// recorded inside the peg by no more than the registration tolerance
/// ([`crate::SimSettings::registration_tol`], a fraction of the part's size) is resolved by
/// moving the peg clear first (separate, then push); deeper is refused.
pub fn follow_path(
    sim: &mut Simulator,
    start: Pose,
    path: &[ProbePoint],
) -> Result<PathReplay, Error> {
    let Some(first) = path.first() else {
        return Err(Error::invalid("probe path", "no waypoints"));
    };
    if let Some(w) =
        path.windows(2).find(|w| w[1].t_s.partial_cmp(&w[0].t_s).is_none_or(|o| o.is_lt()))
    {
        return Err(Error::invalid(
            "probe path",
            format!("time goes backwards at t = {} s → {} s", w[0].t_s, w[1].t_s),
        ));
    }
    let mut st =
        SimState { peg: start, probe_um: first.probe_um, probe_theta_rad: first.probe_theta_rad };
    let start_separation_um = separate(sim, &mut st)?;
    let mut out = PathReplay {
        samples: Vec::with_capacity(path.len()),
        jams: 0,
        steps: 0,
        lcp_solves: 0,
        start_separation_um,
    };
    let mut budget = sim.settings().max_steps.max(path.len() * 4);
    let mut force = 0.0;
    out.samples.push(PathSample {
        t_s: first.t_s,
        probe_um: st.probe_um,
        peg: st.peg,
        probe_force: 0.0,
    });
    let mut prev_t_s = first.t_s;
    for w in &path[1..] {
        let delta = w.probe_um - st.probe_um;
        let turn = w.probe_theta_rad - st.probe_theta_rad;
        let dt_s = w.t_s - prev_t_s;
        prev_t_s = w.t_s;
        if dt_s > 0.0 {
            sim.set_probe_speed_um_s(sim.pusher_travel_um(delta, turn) / dt_s);
        }
        let end = advance_turning(sim, &mut st, (delta, turn), &mut budget, |_, info, _| {
            out.steps += 1;
            out.lcp_solves += usize::from(info.solved_lcp);
            force = info.probe_force;
        })?;
        if matches!(end, SegmentEnd::Jammed { .. }) {
            out.jams += 1;
        }
        out.samples.push(PathSample {
            t_s: w.t_s,
            probe_um: st.probe_um,
            peg: st.peg,
            probe_force: force,
        });
    }
    Ok(out)
}

/// Moves the peg at `st` clear of a pusher recorded inside it by more than the penetration
/// tolerance and at most the registration tolerance (each time along the deepest disc's
/// contact normal, a few times for several discs); returns the distance moved, µm.
fn separate(sim: &mut Simulator, st: &mut SimState) -> Result<f64, Error> {
    let settings = sim.settings();
    let (pen_tol, reg_um) = (
        settings.penetration_tol_um,
        settings.registration_tol * sim.model().part.char_length_um(),
    );
    let depth = -sim.probe_gap_um(st);
    if depth > reg_um {
        return Err(Error::invalid(
            "probe path",
            format!(
                "the pusher starts {depth:.1} µm inside the part, more than the registration \
                 tolerance ({reg_um:.1} µm = registration_tol {} × the part's size): check the \
                 trial's first pose and pusher geometry",
                sim.settings().registration_tol
            ),
        ));
    }
    let mut moved = 0.0;
    for _ in 0..8 {
        let peg = sim.model().part.polygon().transformed(&st.peg);
        let deepest = sim
            .pusher()
            .discs_at(&st.pusher_pose())
            .enumerate()
            .filter_map(|(k, (c, r))| crate::contact::probe_contact(&peg, k, &c, r, 0.0))
            .min_by(|a, b| a.gap_um.total_cmp(&b.gap_um));
        match deepest {
            Some(c) if -c.gap_um > pen_tol => {
                let push = c.normal * (-c.gap_um);
                st.peg.x_um += push.x;
                st.peg.y_um += push.y;
                moved += push.norm();
            }
            _ => return Ok(moved),
        }
    }
    Err(Error::invalid(
        "probe path",
        "the pusher starts inside the part from several sides and cannot be separated from it",
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Fixture, Model, Plan, SimSettings, replay};

    fn sim() -> Simulator {
        Simulator::new(Model::default(), Fixture::paper(), SimSettings::default()).unwrap()
    }

    /// The plan's own probe path, as waypoints every 2 µm.
    fn waypoints(plan: &Plan) -> Vec<ProbePoint> {
        let mut p = plan.probe_start();
        let mut t = 0.0;
        let mut out = vec![ProbePoint::new(0.0, p)];
        for [dx, dy] in &plan.moves_um {
            let d = Vec2::new(*dx, *dy);
            let n = (d.norm() / 2.0).ceil() as usize;
            for _ in 0..n {
                p += d / n as f64;
                t += d.norm() / n as f64 / plan.speed_um_s;
                out.push(ProbePoint::new(t, p));
            }
        }
        out
    }

    #[test]
    fn following_table2s_probe_path_ends_where_the_plan_replay_ends() {
        let plan = Plan::table2();
        let by_plan = replay(&mut sim(), &plan, None).unwrap();
        let by_path = follow_path(&mut sim(), plan.peg_start_pose(), &waypoints(&plan)).unwrap();
        let (a, b) = (by_plan.final_pose, by_path.samples.last().unwrap().peg);
        assert!((a.x_um - b.x_um).abs() < 5.0 && (a.y_um - b.y_um).abs() < 5.0, "{a:?} vs {b:?}");
        assert!((a.theta_rad - b.theta_rad).abs() < 0.01);
        assert_eq!(by_path.samples.len(), waypoints(&plan).len());
    }

    /// `reset` stands in for a new simulator where a replay restarts (diagnosis restarts
    /// once per stroke): it must leave no trace of the steps before it, bit for bit.
    #[test]
    fn a_reset_simulator_replays_bit_for_bit_as_a_new_one() {
        let plan = Plan::table2();
        let (start, path) = (plan.peg_start_pose(), waypoints(&plan));
        let mut model = Model::default();
        model.effects.speed_friction = Some(crate::effects::SpeedFriction { gain_per_mm_s: 0.5 });
        let settings = SimSettings::default();
        let new = || Simulator::new(model.clone(), Fixture::paper(), settings.clone()).unwrap();
        let fresh = follow_path(&mut new(), start, &path).unwrap();
        let mut reused = new();
        let half = &path[..path.len() / 2];
        follow_path(&mut reused, start, half).unwrap();
        reused.reset();
        let again = follow_path(&mut reused, start, &path).unwrap();
        assert!(fresh.lcp_solves > 100, "the replay pushes: {} solves", fresh.lcp_solves);
        assert_eq!(format!("{fresh:?}"), format!("{again:?}"));
    }

    #[test]
    fn a_path_starting_inside_the_peg_or_going_back_in_time_is_refused() {
        let plan = Plan::table2();
        let peg = plan.peg_start_pose();
        let inside = [ProbePoint::new(0.0, peg.position())];
        assert!(follow_path(&mut sim(), peg, &inside).is_err());
        let mut w = waypoints(&plan);
        w[3].t_s = -1.0;
        assert!(follow_path(&mut sim(), peg, &w).unwrap_err().to_string().contains("backwards"));
        assert!(follow_path(&mut sim(), peg, &[]).is_err());
    }
}
