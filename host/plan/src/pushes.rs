//! The planner's control inputs (section III-B of the paper): probe pushes along ±x or ±y
//! from discretised pushing locations on the peg boundary, and their simulation.
//!
//! The boundary is cut into `n_locations` points equally spaced by arc length. A push at a
//! location is usable in direction d when the edge faces the probe (outward normal n with
//! n·d ≤ −`min_alignment`) and the probe's start point — `approach_um` beyond its radius in
//! front of the edge, along −d — is clear of walls and inside the workspace.

use super::clearance::Obstacles;
use crate::Error;
use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};
use mesopush_sim::plan::PegStart;
use mesopush_sim::{Plan, Replay, Simulator, replay};

/// Push directions: the probe moves along one axis only.
pub const DIRECTIONS: [[f64; 2]; 4] = [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]];

/// Discretisation of the pushes (plain data; defaults documented per field).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PushSettings {
    /// Pushing locations on the peg boundary. Default 100 (the paper's).
    pub n_locations: usize,
    /// Gap between the probe disc and the edge at the push start, µm. Default 45 (beyond
    /// the simulator's 30 µm contact margin, so the approach is free travel).
    pub approach_um: f64,
    /// Smallest |n·d| of a usable push. Default 0.5 (at most 60° off the edge normal).
    pub min_alignment: f64,
    /// Shortest and longest probe travel after touching the edge, µm. Default 20 and 2000.
    pub length_range_um: (f64, f64),
    /// Clearance the probe keeps from the peg while repositioning, µm. Default 45.
    pub peg_clearance_um: f64,
}

impl Default for PushSettings {
    fn default() -> Self {
        Self {
            n_locations: 100,
            approach_um: 45.0,
            min_alignment: 0.5,
            length_range_um: (20.0, 2000.0),
            peg_clearance_um: 45.0,
        }
    }
}

/// A pushing location in the body frame: the boundary point and the edge's outward normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Location {
    /// Point on the boundary, body frame, µm.
    pub point_um: Vec2,
    /// Outward unit normal there, body frame.
    pub normal: Vec2,
}

/// `n` locations equally spaced by arc length around `part` (half a spacing from vertex 0).
pub fn boundary_locations(part: &ConvexPolygon, n: usize) -> Vec<Location> {
    let perimeter: f64 = (0..part.len()).map(|i| (part.edge(i).1 - part.edge(i).0).norm()).sum();
    let spacing = perimeter / n.max(1) as f64;
    let mut out = Vec::with_capacity(n);
    let mut s = spacing / 2.0;
    for i in 0..part.len() {
        let (a, b) = part.edge(i);
        let len = (b - a).norm();
        while s < len && out.len() < n {
            out.push(Location { point_um: a + (b - a) * (s / len), normal: part.edge_normal(i) });
            s += spacing;
        }
        s -= len;
    }
    out
}

/// One usable push at a given peg pose: where the probe starts and which way it moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PushStart {
    /// Location index (0..n_locations).
    pub location: usize,
    /// Index into [`DIRECTIONS`].
    pub direction: usize,
    /// Probe start, fixture frame, µm.
    pub start_um: Vec2,
    /// Probe travel from the start until it touches the edge, µm.
    pub reach_um: f64,
}

impl PushStart {
    /// The push's probe move for `length_um` of travel after touching.
    pub fn movement(&self, length_um: f64) -> [f64; 2] {
        let d = DIRECTIONS[self.direction];
        let l = self.reach_um + length_um;
        [d[0] * l, d[1] * l]
    }
}

/// The push from location `li` in direction `di` at `pose`, when the edge faces the probe
/// and the probe's start point is free.
pub fn push_start(
    locations: &[Location],
    li: usize,
    di: usize,
    pose: &Pose,
    obstacles: &Obstacles<'_>,
    settings: &PushSettings,
) -> Option<PushStart> {
    let r = obstacles.probe_radius_um;
    let loc = locations[li];
    let p = pose.transform_point(&loc.point_um);
    let n = pose.rotate(&loc.normal);
    let d = Vec2::new(DIRECTIONS[di][0], DIRECTIONS[di][1]);
    let along = -n.dot(&d);
    if along < settings.min_alignment {
        return None;
    }
    // Disc centre at distance r + approach from the edge line, on the ray through p.
    let reach = (r + settings.approach_um) / along;
    let start = p - d * reach;
    obstacles.point_free(&start).then_some(PushStart {
        location: li,
        direction: di,
        start_um: start,
        reach_um: reach - r / along,
    })
}

/// Every usable push at `pose`.
pub fn usable_pushes(
    locations: &[Location],
    pose: &Pose,
    obstacles: &Obstacles<'_>,
    settings: &PushSettings,
) -> Vec<PushStart> {
    (0..locations.len())
        .flat_map(|li| (0..DIRECTIONS.len()).map(move |di| (li, di)))
        .filter_map(|(li, di)| push_start(locations, li, di, pose, obstacles, settings))
        .collect()
}

/// What a simulated sequence of probe moves did.
#[derive(Debug, Clone, PartialEq)]
pub struct PushOutcome {
    /// Peg pose afterwards.
    pub pose: Pose,
    /// Probe tip afterwards, µm.
    pub probe_um: Vec2,
    /// Whether the probe jammed (the simulator stopped it for the rest of a move).
    pub jammed: bool,
    /// Whether the needle was bent beyond the model's limit ([`mesopush_sim::needle`]).
    pub overloaded: bool,
    /// Whether the peg ended inserted (in the goal, the needle within its limit).
    pub inserted: bool,
}

/// Simulates `moves` from probe position `probe_um` with the peg at `pose`, through the same
/// [`replay()`] the `sim` command and the Monte Carlo use.
pub fn simulate(
    sim: &mut Simulator,
    pose: Pose,
    probe_um: Vec2,
    moves: &[[f64; 2]],
) -> Result<(PushOutcome, Replay), Error> {
    let plan = Plan {
        name: String::new(),
        speed_um_s: 140.0,
        peg_start: PegStart {
            x_um: pose.x_um,
            y_um: pose.y_um,
            theta_deg: pose.theta_rad.to_degrees(),
        },
        probe_start_um: [probe_um.x, probe_um.y],
        moves_um: moves.to_vec(),
    };
    let r = replay(sim, &plan, Some(pose))?;
    let last = r.samples.last().map_or([probe_um.x, probe_um.y], |s| s.probe_um);
    let outcome = PushOutcome {
        pose: r.final_pose,
        probe_um: Vec2::new(last[0], last[1]),
        jammed: !r.events.is_empty(),
        overloaded: r.overload.is_some(),
        inserted: r.inserted,
    };
    Ok((outcome, r))
}

/// Moves of a replayed plan during which the probe pushed the peg (a probe force above
/// 10⁻⁹ part weights at some step): the plan's pushes, as opposed to its repositioning.
pub fn pushing_moves(replay: &Replay) -> usize {
    let mut moves: Vec<usize> =
        replay.samples.iter().filter(|s| s.probe_force > 1e-9).map(|s| s.move_index).collect();
    moves.dedup();
    moves.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locations_are_equally_spaced_on_the_boundary() {
        let part = ConvexPolygon::rectangle(1600.0, 1000.0).unwrap();
        let locs = boundary_locations(&part, 104);
        assert_eq!(locs.len(), 104);
        for l in &locs {
            assert!(part.signed_distance(&l.point_um).abs() < 1e-9);
        }
        let gap = (locs[1].point_um - locs[0].point_um).norm();
        assert!((gap - 50.0).abs() < 1e-9, "{gap}");
    }
}
