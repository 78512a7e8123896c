//! A trial log turned into what identification needs: the part, the probe radius, the
//! fixture (an open plate when the trial had none), the commanded probe path from the first
//! tracked pose on, and the tracked poses to score against. Only the trial-log format is read
//! (`docs/trial-log.md`); nothing here knows who produced the log.

use crate::Error;
use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};
use mesopush_sim::{Fixture, Part, ProbePoint, Pusher};
use mesopush_trial::{PoseRow, Trial};

/// One trial, ready to be simulated and scored.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentTrial {
    /// The trial's id (from `trial.json`).
    pub id: String,
    /// The pushed part.
    pub part: Part,
    /// The pusher (its discs; the paper's probe is one 12.5 µm disc).
    pub pusher: Pusher,
    /// Walls the peg may touch (none for unconstrained pushing).
    pub fixture: Fixture,
    /// Where the simulation starts: the tracked pose at rest before the probe touches (the
    /// mean of the poses tracked before contact; the first pose when it touches at once).
    pub start: Pose,
    /// The commanded probe path from the first tracked pose's time on (its first point is
    /// the probe interpolated at that time).
    pub path: Vec<ProbePoint>,
    /// Tracked poses after the first, as (time s, pose), within the path's time span (the
    /// poses inside a gap of the recording left out).
    pub measured: Vec<(f64, Pose)>,
    /// Where the recording says the pusher's path is unknown (`log_gap` events,
    /// docs/trial-log.md), the simulation starts again: each gap's last recorded command
    /// before it and the first tracked pose after it, in time order.
    pub restarts: Vec<Restart>,
    /// How far the recorded pusher may start inside the part, µm (`trial.json`'s
    /// `registration_tol_um`; None: the simulator's default fraction of the part's size).
    pub registration_tol_um: Option<f64>,
}

/// A restart of the simulation after a gap in the recording (as `mesopush replay` does).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Restart {
    /// The last recorded command before the gap, s: the segment before ends there.
    pub before_s: f64,
    /// The first tracked pose after the gap: the time the next segment starts from, s.
    pub t_s: f64,
    /// That pose.
    pub pose: Pose,
}

/// The restarts of a trial with tracked `poses` and commands `path` at its `log_gap` times.
fn restarts_at(gaps_s: &[f64], poses: &[PoseRow], path: &[ProbePoint]) -> Vec<Restart> {
    let t = |p: &PoseRow| p.t_us as f64 * 1e-6;
    let mut out: Vec<Restart> = gaps_s
        .iter()
        .filter_map(|&g| {
            let k = poses.partition_point(|p| t(p) < g);
            let p = poses.get(k).filter(|_| k > 0)?;
            let before_s =
                path.iter().map(|q| q.t_s).filter(|&q| q < g).fold(t(&poses[0]), f64::max);
            Some(Restart { before_s, t_s: t(p), pose: Pose::new(p.x_um, p.y_um, p.theta_rad) })
        })
        .collect();
    out.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
    out.dedup_by(|a, b| a.t_s == b.t_s);
    out
}

/// A fixture with no walls (open plate); its goal is a token square far away, never reached.
pub fn open_plate() -> Fixture {
    let (far, side) = (1.0e6, 1000.0);
    let goal = ConvexPolygon::new(vec![
        Vec2::new(far, far),
        Vec2::new(far + side, far),
        Vec2::new(far + side, far + side),
        Vec2::new(far, far + side),
    ])
    .expect("constant square");
    Fixture { walls: Vec::new(), goal, insert_depth_um: 0.0, goal_whole_part: false }
}

/// The probe position on `path` at `t_s` (linear between waypoints, clamped at the ends).
pub fn probe_at(path: &[ProbePoint], t_s: f64) -> Vec2 {
    pusher_at(path, t_s).probe_um
}

/// The pusher's waypoint on `path` at `t_s` (position and angle linear between waypoints,
/// clamped at the ends).
pub fn pusher_at(path: &[ProbePoint], t_s: f64) -> ProbePoint {
    let i = path.partition_point(|p| p.t_s <= t_s);
    if i == 0 {
        return ProbePoint { t_s, ..path[0] };
    }
    if i == path.len() {
        return ProbePoint { t_s, ..path[i - 1] };
    }
    let (a, b) = (&path[i - 1], &path[i]);
    let dt = b.t_s - a.t_s;
    let f = if dt > 0.0 { (t_s - a.t_s) / dt } else { 1.0 };
    ProbePoint {
        t_s,
        probe_um: a.probe_um + (b.probe_um - a.probe_um) * f,
        probe_theta_rad: a.probe_theta_rad + (b.probe_theta_rad - a.probe_theta_rad) * f,
    }
}

/// The commands between `t0_s` and `t1_s`: the pusher interpolated at `t0_s`, then every
/// waypoint after it up to and including `t1_s` (a replay's segment between restarts).
pub fn sub_path(path: &[ProbePoint], t0_s: f64, t1_s: f64) -> Vec<ProbePoint> {
    let mut out = vec![pusher_at(path, t0_s)];
    out.extend(path.iter().filter(|p| p.t_s > t0_s && p.t_s <= t1_s).copied());
    out
}

/// Distance the pusher must keep from the peg for a tracked pose to count as at rest, µm,
/// for the paper's peg; scaled with the part's size for any other part.
const REST_GAP_PEG_UM: f64 = 5.0;

/// The peg's start pose: the mean of the tracked poses before the probe first comes within
/// [`REST_GAP_UM`] of the peg (the peg cannot move before it is touched), so tracking noise
/// on the first frame does not bias every later prediction. Geometry only, no model.
fn resting_pose(part: &Part, pusher: &Pusher, poses: &[PoseRow], path: &[ProbePoint]) -> Pose {
    let first = Pose::new(poses[0].x_um, poses[0].y_um, poses[0].theta_rad);
    let peg = part.polygon().transformed(&first);
    let scale = part.char_length_um() / Part::default_peg().char_length_um();
    let rest_gap_um = REST_GAP_PEG_UM * scale;
    let (mut sum, mut n) = ([0.0; 3], 0usize);
    for p in poses {
        let w = pusher_at(path, p.t_us as f64 * 1e-6);
        let at = Pose::new(w.probe_um.x, w.probe_um.y, w.probe_theta_rad);
        let gap = pusher
            .discs_at(&at)
            .map(|(c, r)| peg.signed_distance(&c) - r)
            .fold(f64::INFINITY, f64::min);
        if n > 0 && gap < rest_gap_um {
            break;
        }
        sum = [sum[0] + p.x_um, sum[1] + p.y_um, sum[2] + p.theta_rad];
        n += 1;
    }
    let n = n as f64;
    Pose::new(sum[0] / n, sum[1] / n, sum[2] / n)
}

impl IdentTrial {
    /// Prepares a loaded trial; errors name the trial directory and what is missing.
    pub fn from_trial(trial: &Trial) -> Result<Self, Error> {
        let name = trial.dir.display().to_string();
        let poses = trial.poses()?;
        let path = trial.commanded_path();
        if path.len() < 2 {
            return Err(Error::invalid(
                "trial",
                format!("{name}: probe.csv has {} rows; at least 2 are needed", path.len()),
            ));
        }
        for (i, p) in poses.iter().enumerate() {
            if !(p.x_um.is_finite() && p.y_um.is_finite() && p.theta_rad.is_finite()) {
                return Err(Error::invalid(
                    "trial",
                    format!("{name}: pose.csv row {} is not finite", i + 1),
                ));
            }
        }
        let first = poses[0];
        let t0_s = first.t_us as f64 * 1e-6;
        let t_end_s = path[path.len() - 1].t_s;
        if t0_s >= t_end_s {
            return Err(Error::invalid(
                "trial",
                format!("{name}: the first tracked pose is after the probe path's end"),
            ));
        }
        let mut trimmed = vec![pusher_at(&path, t0_s)];
        trimmed.extend(path.iter().filter(|p| p.t_s > t0_s).copied());
        let gaps_s: Vec<f64> = trial
            .events
            .iter()
            .filter(|e| e.kind == "log_gap")
            .map(|e| e.t_us as f64 * 1e-6)
            .collect();
        let restarts = restarts_at(&gaps_s, poses, &path);
        let in_gap = |t: f64| restarts.iter().any(|r| t > r.before_s && t < r.t_s);
        let measured: Vec<(f64, Pose)> = poses[1..]
            .iter()
            .map(|p| (p.t_us as f64 * 1e-6, Pose::new(p.x_um, p.y_um, p.theta_rad)))
            .filter(|(t, _)| *t <= t_end_s && !in_gap(*t))
            .collect();
        if measured.is_empty() {
            return Err(Error::invalid(
                "trial",
                format!("{name}: no tracked pose after the first lies within the probe path"),
            ));
        }
        let part = trial.meta.part.clone();
        let pusher = trial.meta.pusher();
        let start = resting_pose(&part, &pusher, poses, &path);
        Ok(Self {
            id: trial.meta.trial_id.clone(),
            part,
            pusher,
            fixture: trial.meta.fixture.clone().unwrap_or_else(open_plate),
            start,
            path: trimmed,
            measured,
            restarts,
            registration_tol_um: trial.meta.registration_tol_um,
        })
    }

    /// Loads and prepares a trial directory.
    pub fn load(dir: &std::path::Path) -> Result<Self, Error> {
        Self::from_trial(&Trial::load(dir)?)
    }

    /// Probe travel along the path, µm.
    pub fn travel_um(&self) -> f64 {
        self.path.windows(2).map(|w| (w[1].probe_um - w[0].probe_um).norm()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn open_plate_has_no_walls() {
        assert!(open_plate().walls.is_empty());
    }

    #[test]
    fn probe_is_interpolated_and_clamped() {
        let path =
            [ProbePoint::new(0.0, Vec2::new(0.0, 0.0)), ProbePoint::new(1.0, Vec2::new(10.0, 0.0))];
        assert_eq!(probe_at(&path, 0.5), Vec2::new(5.0, 0.0));
        assert_eq!(probe_at(&path, -1.0), Vec2::new(0.0, 0.0));
        assert_eq!(probe_at(&path, 2.0), Vec2::new(10.0, 0.0));
    }
}
