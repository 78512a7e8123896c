//! Plan families: what the robust design searches over. A family maps a point in a box of
//! parameters (µm, fixture frame) to a plan for a given peg start. Two families ship:
//!
//! - [`Skeleton`]'s Table II shape ([`Table2Family`]): six numbers of the paper's intuitive
//!   plan (rotate, come round, press, insert), the search's historic start on Table II's task.
//! - [`PathFamily`]: any plan — what the RRT found, a file, a plan with an inserted
//!   uncertainty-removing press ([`crate::wall_press`]) — with one parameter per move: the
//!   coordinate its end reaches along its axis. Moving one parameter slides one straight
//!   stretch of the probe path sideways and leaves the rest of the path where it was.
//!
//! The cross-entropy method (`cem`) and the scoring ([`crate::score`]) see only this
//! trait, so they design plans of any shape for any part and fixture.

use crate::skeleton::{BOUNDS, N_PARAMS, NAMES, Skeleton};
use mesopush_core::geom::ConvexPolygon;
use mesopush_sim::Plan;
use mesopush_sim::plan::PegStart;

/// A family of plans over a box of parameters.
pub trait PlanFamily: Sync {
    /// Names of the parameters, in order (for reports).
    fn names(&self) -> Vec<String>;
    /// Search box of every parameter: (low, high), in the order of [`PlanFamily::names`].
    fn bounds(&self) -> &[(f64, f64)];
    /// The plan for parameters `params` (within the box) and a peg starting at `start`.
    fn plan(&self, params: &[f64], start: PegStart, name: &str) -> Plan;
    /// `params` clamped into the box.
    fn clamped(&self, params: &[f64]) -> Vec<f64> {
        params.iter().zip(self.bounds()).map(|(p, (lo, hi))| p.clamp(*lo, *hi)).collect()
    }
    /// A short description for the plan's name.
    fn describe(&self) -> String;
}

/// How far a [`PathFamily`]'s move ends may move by default, as a fraction of the part's
/// diameter (its longest vertex-to-vertex distance): 0.1, 189 µm for the paper's peg —
/// about 2.5 times the paper's start uncertainty in y (±74 µm), so the search can shift a
/// push by more than a start error, yet not so far that the plan's pushes change their
/// faces.
pub const DEFAULT_RADIUS_PART_FRACTION: f64 = 0.1;

/// The default search radius of a [`PathFamily`] for `part`, µm.
pub fn default_radius_um(part: &ConvexPolygon) -> f64 {
    let v = part.vertices();
    let diameter =
        v.iter().flat_map(|a| v.iter().map(move |b| (*a - *b).norm())).fold(0.0, f64::max);
    DEFAULT_RADIUS_PART_FRACTION * diameter
}

/// The Table II skeleton as a family ([`Skeleton`]'s six numbers and box).
#[derive(Debug, Clone, Copy, Default)]
pub struct Table2Family;

impl PlanFamily for Table2Family {
    fn names(&self) -> Vec<String> {
        NAMES.iter().map(|n| (*n).to_string()).collect()
    }

    fn bounds(&self) -> &[(f64, f64)] {
        &BOUNDS
    }

    fn plan(&self, params: &[f64], start: PegStart, name: &str) -> Plan {
        let mut p = [0.0; N_PARAMS];
        p.copy_from_slice(&params[..N_PARAMS]);
        Skeleton { params: p }.to_plan(name, start)
    }

    fn describe(&self) -> String {
        "the Table II skeleton".into()
    }
}

/// Any plan as a family: parameter `k` is the coordinate the end of move `k` reaches along
/// the move's axis (x for a move along x), searched within `radius_um` of the template's.
#[derive(Debug, Clone, PartialEq)]
pub struct PathFamily {
    /// The plan the family is built on (its probe start, speed and move axes).
    template: Plan,
    /// Which axis each move runs along (0: x, 1: y).
    axes: Vec<usize>,
    /// The template's parameters.
    initial: Vec<f64>,
    /// The search box.
    bounds: Vec<(f64, f64)>,
}

impl PathFamily {
    /// The family around `template`, each move's end free within ±`radius_um` along its axis.
    /// (Plans are axis-aligned by validation; a move with two non-zero components is taken
    /// along its longer one.)
    pub fn around(template: &Plan, radius_um: f64) -> Self {
        let mut pos = template.probe_start_um;
        let (mut axes, mut initial) = (Vec::new(), Vec::new());
        for m in &template.moves_um {
            let a = usize::from(m[1].abs() > m[0].abs());
            pos[0] += m[0];
            pos[1] += m[1];
            axes.push(a);
            initial.push(pos[a]);
        }
        let bounds = initial.iter().map(|v| (v - radius_um, v + radius_um)).collect();
        Self { template: template.clone(), axes, initial, bounds }
    }

    /// The template's own parameters (the family's centre).
    pub fn initial(&self) -> &[f64] {
        &self.initial
    }
}

impl PlanFamily for PathFamily {
    fn names(&self) -> Vec<String> {
        let axis = ["x", "y"];
        self.axes.iter().enumerate().map(|(k, a)| format!("move{k}_end_{}_um", axis[*a])).collect()
    }

    fn bounds(&self) -> &[(f64, f64)] {
        &self.bounds
    }

    fn plan(&self, params: &[f64], start: PegStart, name: &str) -> Plan {
        let mut pos = self.template.probe_start_um;
        let mut moves = Vec::with_capacity(params.len());
        for (a, p) in self.axes.iter().zip(params) {
            let mut m = [0.0; 2];
            m[*a] = p - pos[*a];
            pos[*a] = *p;
            if m[*a] != 0.0 {
                moves.push(m);
            }
        }
        Plan {
            name: name.into(),
            speed_um_s: self.template.speed_um_s,
            peg_start: start,
            probe_start_um: self.template.probe_start_um,
            moves_um: moves,
        }
    }

    fn describe(&self) -> String {
        format!("the moves of a {}-move plan", self.axes.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_path_family_at_its_centre_gives_back_its_plan_and_one_parameter_slides_one_stretch() {
        let t2 = Plan::table2();
        let f = PathFamily::around(&t2, 100.0);
        assert_eq!(f.names().len(), t2.moves_um.len());
        let back = f.plan(f.initial(), t2.peg_start, &t2.name);
        assert_eq!(back, t2);
        // Table II's Δu2 = (−1500, 0) from (3050, 640) ends at x = 1550; move it to 1500:
        // Δu2 grows by 50 and Δu5 (the next move along x) shrinks by 50; nothing else moves.
        let mut p = f.initial().to_vec();
        assert_eq!(p[1], 1550.0);
        p[1] = 1500.0;
        let moved = f.plan(&p, t2.peg_start, "");
        assert_eq!(moved.moves_um[1], [-1550.0, 0.0]);
        assert_eq!(moved.moves_um[4], [1600.0, 0.0]);
        for k in [0, 2, 3, 5, 6] {
            assert_eq!(moved.moves_um[k], t2.moves_um[k], "move {k}");
        }
        assert_eq!(f.clamped(&[1e9; 7])[1], 1650.0);
    }

    #[test]
    fn the_table2_family_is_the_skeleton() {
        let s = Skeleton::table2_like();
        let start = Plan::table2().peg_start;
        assert_eq!(Table2Family.plan(&s.params, start, "n"), s.to_plan("n", start));
        assert_eq!(Table2Family.bounds().len(), Table2Family.names().len());
    }
}
