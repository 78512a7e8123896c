//! A plan skeleton: the shape of the paper's intuitive plan (Table II — rotate the standing
//! peg by pushing its upper end, come round and slide it in along −x) with its numbers left
//! free, so an optimiser can tune them for robustness.
//!
//! The skeleton adds three optional steps the optimiser may use or switch off: a second
//! rotation stage (the probe dips and pushes on, like Table II's 50 µm dip), a press down
//! on the top edge to a fixed probe height (it leaves the touched point at that height
//! whatever height it had, removing y uncertainty), and a staging push that brings the peg
//! to the channel mouth before the probe re-aims for the final push.

use crate::sim::Plan;
use crate::sim::plan::PegStart;

/// Number of parameters.
pub const N_PARAMS: usize = 11;

/// Names of the skeleton's parameters, in order (all µm, fixture frame).
pub const NAMES: [&str; N_PARAMS] = [
    "rotate_y_um",
    "rotate_end_x_um",
    "rotate2_dy_um",
    "rotate2_dx_um",
    "press_x_um",
    "press_y_um",
    "stage_y_um",
    "stage_end_x_um",
    "insert_y_um",
    "insert_end_x_um",
    "probe_start_y_um",
];

/// Search box of each parameter, µm: (low, high).
pub const BOUNDS: [(f64, f64); N_PARAMS] = [
    (450.0, 1000.0),
    (900.0, 2300.0),
    (-100.0, 400.0),
    (0.0, 800.0),
    (1000.0, 3000.0),
    (700.0, 1250.0),
    (1200.0, 1800.0),
    (900.0, 2400.0),
    (1250.0, 1750.0),
    (350.0, 1200.0),
    (1000.0, 1600.0),
];

/// Probe x while coming round the peg's right end, µm (Table II's 3100).
const CLEAR_X_UM: f64 = 3100.0;
/// Probe x at the start, µm (Table II's 3050).
const START_X_UM: f64 = 3050.0;
/// How far the probe lifts off after the press and backs off after the staging push, µm.
const LIFT_UM: f64 = 150.0;

/// A skeleton instance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Skeleton {
    /// Parameters in the order of [`NAMES`].
    pub params: [f64; N_PARAMS],
}

impl Skeleton {
    /// Table II's numbers (its 50 µm probe dip as the second rotation stage, no extra
    /// travel), the press at the rotated peg's middle to the height that centres it on the
    /// channel, and the staging push stopping before the mouth.
    pub fn table2_like() -> Self {
        Self {
            params: [
                640.0, 1550.0, 50.0, 0.0, 2000.0, 990.0, 1415.0, 1800.0, 1415.0, 550.0, 1240.0,
            ],
        }
    }

    /// Parameters clamped into [`BOUNDS`].
    pub fn clamped(mut self) -> Self {
        for (p, (lo, hi)) in self.params.iter_mut().zip(BOUNDS) {
            *p = p.clamp(lo, hi);
        }
        self
    }

    /// The plan for a peg starting at `peg_start` (Table II's start in the paper).
    pub fn to_plan(&self, name: &str, peg_start: PegStart) -> Plan {
        let [ry, rx, ry2, rx2, px, py, gy, gx, iy, ix, sy] = self.params;
        let (ry2, rx2) = (ry + ry2, rx - rx2);
        let up = ry.min(ry2).min(py) - 60.0;
        // Probe waypoints; consecutive ones differ in one coordinate only.
        let path = [
            [START_X_UM, sy],
            [START_X_UM, ry],
            [rx, ry],
            [rx, ry2],
            [rx2, ry2],
            [rx2, up],
            [px, up],
            [px, py],
            [px, py - LIFT_UM],
            [CLEAR_X_UM, py - LIFT_UM],
            [CLEAR_X_UM, gy],
            [gx, gy],
            [gx + LIFT_UM, gy],
            [gx + LIFT_UM, iy],
            [ix, iy],
        ];
        let moves = path
            .windows(2)
            .map(|w| [w[1][0] - w[0][0], w[1][1] - w[0][1]])
            .filter(|m| m[0] != 0.0 || m[1] != 0.0)
            .collect();
        Plan {
            name: name.into(),
            speed_um_s: 140.0,
            peg_start,
            probe_start_um: path[0],
            moves_um: moves,
        }
    }
}
