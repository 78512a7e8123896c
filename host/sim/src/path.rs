//! Replaying a recorded probe path (what a trial log's probe.csv holds) instead of a plan:
//! the probe goes straight from waypoint to waypoint, the peg follows quasi-statically, and
//! the peg pose is reported at every waypoint's time. Identification and diagnosis compare
//! these poses with the tracked ones.

use super::advance::{SegmentEnd, advance};
use super::stepper::{SimState, Simulator};
use crate::Error;
use mesopush_core::geom::{Pose, Vec2};

/// One waypoint of a probe path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbePoint {
    /// Time since the trial started, s.
    pub t_s: f64,
    /// Probe tip centre, µm (fixture frame).
    pub probe_um: Vec2,
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
}

/// Follows `path` from the peg at `start`; the probe starts at the first waypoint, which
/// must be clear of the peg.
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
    let mut st = SimState { peg: start, probe_um: first.probe_um };
    let gap = sim.probe_gap_um(&st);
    if gap < -sim.settings().penetration_tol_um {
        return Err(Error::invalid(
            "probe path",
            format!("the probe starts {:.1} µm inside the peg", -gap),
        ));
    }
    let mut out =
        PathReplay { samples: Vec::with_capacity(path.len()), jams: 0, steps: 0, lcp_solves: 0 };
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
        let dt_s = w.t_s - prev_t_s;
        prev_t_s = w.t_s;
        if dt_s > 0.0 {
            sim.set_probe_speed_um_s(delta.norm() / dt_s);
        }
        let end = advance(sim, &mut st, delta, &mut budget, |_, info, _| {
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
        let mut out = vec![ProbePoint { t_s: 0.0, probe_um: p }];
        for [dx, dy] in &plan.moves_um {
            let d = Vec2::new(*dx, *dy);
            let n = (d.norm() / 2.0).ceil() as usize;
            for _ in 0..n {
                p += d / n as f64;
                t += d.norm() / n as f64 / plan.speed_um_s;
                out.push(ProbePoint { t_s: t, probe_um: p });
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

    #[test]
    fn a_path_starting_inside_the_peg_or_going_back_in_time_is_refused() {
        let plan = Plan::table2();
        let peg = plan.peg_start_pose();
        let inside = [ProbePoint { t_s: 0.0, probe_um: peg.position() }];
        assert!(follow_path(&mut sim(), peg, &inside).is_err());
        let mut w = waypoints(&plan);
        w[3].t_s = -1.0;
        assert!(follow_path(&mut sim(), peg, &w).unwrap_err().to_string().contains("backwards"));
        assert!(follow_path(&mut sim(), peg, &[]).is_err());
    }
}
