//! The search tree of the RRT: peg poses joined by simulated probe moves, and the plan read
//! off a branch.

use super::route::merge_moves;
use mesopush_core::geom::{Pose, Vec2};
use mesopush_sim::Plan;
use mesopush_sim::plan::PegStart;
use std::f64::consts::PI;

/// Weight of orientation in the pose metric, µm per rad (about the peg's half length).
pub const ROT_UM_PER_RAD: f64 = 600.0;

/// Angle difference folded into (−π/2, π/2]: the rectangular peg looks the same turned by π.
pub fn angle_diff_mod_pi(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(PI);
    if d > PI / 2.0 { d - PI } else { d }
}

/// Distance between poses: COM distance plus weighted orientation difference (mod π).
pub fn pose_distance(a: &Pose, b: &Pose) -> f64 {
    (a.position() - b.position()).norm()
        + ROT_UM_PER_RAD * angle_diff_mod_pi(a.theta_rad, b.theta_rad).abs()
}

/// One node: a peg pose reached by the moves from its parent.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// Peg pose.
    pub pose: Pose,
    /// Parent index (`None` for the root).
    pub parent: Option<usize>,
    /// Probe moves from the parent's state (retract, reposition, push), µm.
    pub moves: Vec<[f64; 2]>,
    /// Where the probe starts these moves (the parent's probe end, or the push start for the
    /// root's children), µm.
    pub probe_from_um: Vec2,
    /// Probe tip after the push, µm (`None` at the root: the probe may start anywhere).
    pub probe_um: Option<Vec2>,
    /// Direction of the push that made this node (index into `DIRECTIONS`).
    pub direction: usize,
    /// Boundary location of that push (index into the planner's locations).
    pub location: usize,
    /// Probe travel of that push after touching the peg, µm (0 at the root).
    pub length_um: f64,
    /// Pushes from the root.
    pub depth: usize,
}

/// The tree.
#[derive(Debug, Clone, Default)]
pub struct Tree {
    /// Nodes; index 0 is the root.
    pub nodes: Vec<Node>,
}

impl Tree {
    /// A tree holding only the start pose.
    pub fn new(start: Pose) -> Self {
        let root = Node {
            pose: start,
            parent: None,
            moves: Vec::new(),
            probe_from_um: Vec2::zeros(),
            probe_um: None,
            direction: 0,
            location: 0,
            length_um: 0.0,
            depth: 0,
        };
        Self { nodes: vec![root] }
    }

    /// Index of the node nearest `target` in [`pose_distance`].
    pub fn nearest(&self, target: &Pose) -> usize {
        let mut best = (0, f64::INFINITY);
        for (i, n) in self.nodes.iter().enumerate() {
            let d = pose_distance(&n.pose, target);
            if d < best.1 {
                best = (i, d);
            }
        }
        best.0
    }

    /// Node indices from the root to `leaf`.
    pub fn branch(&self, leaf: usize) -> Vec<usize> {
        let mut out = vec![leaf];
        let mut i = leaf;
        while let Some(p) = self.nodes[i].parent {
            out.push(p);
            i = p;
        }
        out.reverse();
        out
    }

    /// The plan that drives the peg from the root to `leaf`.
    pub fn plan_to(&self, leaf: usize, name: &str, speed_um_s: f64) -> Plan {
        let branch = self.branch(leaf);
        let root = &self.nodes[0].pose;
        let probe_start = branch.get(1).map_or(Vec2::zeros(), |&i| self.nodes[i].probe_from_um);
        let moves = merge_moves(branch.iter().flat_map(|&i| self.nodes[i].moves.iter().copied()));
        Plan {
            name: name.into(),
            speed_um_s,
            peg_start: PegStart {
                x_um: root.x_um,
                y_um: root.y_um,
                theta_deg: root.theta_rad.to_degrees(),
            },
            probe_start_um: [probe_start.x, probe_start.y],
            moves_um: moves,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orientation_distance_folds_half_turns() {
        let a = Pose::new(0.0, 0.0, 0.1);
        let b = Pose::new(0.0, 0.0, 0.1 + PI);
        assert!(pose_distance(&a, &b) < 1e-9);
        assert!((angle_diff_mod_pi(PI / 2.0 - 0.1, -PI / 2.0 + 0.1) + 0.2).abs() < 1e-9);
    }
}
