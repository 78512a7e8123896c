//! Open-loop pushing plans: a start state and a list of axis-aligned probe moves Δu_i at one
//! speed (the paper's Table II). Plans are TOML; `plans/table2.toml` ships Table II.

use crate::Error;
use mesopush_core::check::{Allowed, all_finite_in, finite_in, int_in};
use mesopush_core::geom::{Pose, Vec2};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Start pose of the peg as written in a plan (degrees for people, converted on load).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PegStart {
    /// COM x, µm.
    pub x_um: f64,
    /// COM y, µm.
    pub y_um: f64,
    /// Orientation, degrees.
    pub theta_deg: f64,
}

/// A pushing plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plan {
    /// Free-text name.
    #[serde(default)]
    pub name: String,
    /// Probe speed, µm/s (default 140, the paper's).
    #[serde(default = "default_speed")]
    pub speed_um_s: f64,
    /// Where the peg is expected at the start.
    pub peg_start: PegStart,
    /// Probe tip position at the start, µm.
    pub probe_start_um: [f64; 2],
    /// Probe moves Δu_i, µm; each has one zero component (axis-aligned).
    pub moves_um: Vec<[f64; 2]>,
}

fn default_speed() -> f64 {
    140.0
}

/// Largest accepted single move, µm (a 20 mm stage).
pub const MAX_MOVE_UM: f64 = 20_000.0;
/// Largest accepted probe speed, µm/s.
pub const MAX_SPEED_UM_S: f64 = 10_000.0;
/// Where a plan's positions may lie in the fixture frame, µm: ±20 mm about the fixture's
/// origin (what a 20 mm stage can reach from anywhere over the fixture).
pub const POSITION_UM: Allowed = Allowed::closed(-MAX_MOVE_UM, MAX_MOVE_UM, "µm");
/// Most moves a plan may have (bounded loops downstream).
pub const MAX_MOVES: usize = 4096;

impl PegStart {
    /// The start as a pose in rad.
    pub fn pose(&self) -> Pose {
        Pose::new(self.x_um, self.y_um, self.theta_deg.to_radians())
    }
}

impl Plan {
    /// Peg start as a pose in rad.
    pub fn peg_start_pose(&self) -> Pose {
        self.peg_start.pose()
    }

    /// Probe start as a vector, µm.
    pub fn probe_start(&self) -> Vec2 {
        Vec2::new(self.probe_start_um[0], self.probe_start_um[1])
    }

    /// Checks every field; errors name the field (and the move index), the value and the
    /// allowed range: speed in (0, [`MAX_SPEED_UM_S`]], positions (the peg's start, the
    /// probe's start and every probe waypoint) within [`POSITION_UM`], the start angle within
    /// ±720°, each move along x or y and at most [`MAX_MOVE_UM`] long.
    pub fn validate(&self) -> Result<(), Error> {
        finite_in(
            "plan speed_um_s",
            self.speed_um_s,
            Allowed::positive_to(MAX_SPEED_UM_S, "µm/s"),
        )?;
        let p = self.peg_start;
        finite_in("plan peg_start.x_um", p.x_um, POSITION_UM)?;
        finite_in("plan peg_start.y_um", p.y_um, POSITION_UM)?;
        finite_in("plan peg_start.theta_deg", p.theta_deg, Allowed::closed(-720.0, 720.0, "°"))?;
        all_finite_in("plan probe_start_um", &self.probe_start_um, POSITION_UM)?;
        let n = self.moves_um.len();
        int_in("plan moves_um (number of moves)", n, 1, MAX_MOVES, "")?;
        let mut at = self.probe_start();
        for (i, [dx, dy]) in self.moves_um.iter().enumerate() {
            let field = format!("plan moves_um[{i}] (move {})", i + 1);
            let step = Allowed::closed(-MAX_MOVE_UM, MAX_MOVE_UM, "µm");
            all_finite_in(&field, &[*dx, *dy], step)?;
            if *dx != 0.0 && *dy != 0.0 {
                return Err(Error::invalid(
                    "plan",
                    format!("{field} = ({dx}, {dy}) µm must be along x or y only"),
                ));
            }
            at += Vec2::new(*dx, *dy);
            all_finite_in(
                &format!("probe position after move {}", i + 1),
                &[at.x, at.y],
                POSITION_UM,
            )?;
        }
        Ok(())
    }

    /// Parses and validates a plan from TOML text (`path` only names it in errors).
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, Error> {
        let plan: Plan = toml::from_str(text)
            .map_err(|e| Error::Parse { path: path.into(), message: e.to_string() })?;
        plan.validate().map_err(|e| Error::Parse { path: path.into(), message: e.to_string() })?;
        Ok(plan)
    }

    /// Loads and validates a plan file.
    pub fn load(path: &Path) -> Result<Self, Error> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Self::from_toml(&text, path)
    }

    /// The plan as TOML text.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).expect("a plan always serialises")
    }

    /// `n` start poses drawn uniformly within ±`dx_um`, ±`dy_um`, ±`dtheta_deg` of the
    /// plan's nominal peg start (the paper's trials: 26 µm, 74 µm, 3°).
    pub fn perturbed_starts(
        &self,
        rng: &mut impl rand::Rng,
        n: usize,
        (dx_um, dy_um, dtheta_deg): (f64, f64, f64),
    ) -> Vec<Pose> {
        use rand::RngExt;
        let s = self.peg_start_pose();
        (0..n)
            .map(|_| {
                Pose::new(
                    s.x_um + rng.random_range(-dx_um..=dx_um),
                    s.y_um + rng.random_range(-dy_um..=dy_um),
                    s.theta_rad + rng.random_range(-dtheta_deg..=dtheta_deg).to_radians(),
                )
            })
            .collect()
    }

    /// Total probe travel, µm.
    pub fn travel_um(&self) -> f64 {
        self.moves_um.iter().map(|[x, y]| x.abs() + y.abs()).sum()
    }

    /// Table II of the paper.
    pub fn table2() -> Self {
        Plan {
            name: "Table II (paper): intuitive plan tuned in simulation".into(),
            speed_um_s: 140.0,
            peg_start: PegStart { x_um: 2330.0, y_um: 1210.0, theta_deg: 89.0 },
            probe_start_um: [3050.0, 1240.0],
            moves_um: vec![
                [0.0, -600.0],
                [-1500.0, 0.0],
                [0.0, 50.0],
                [0.0, -50.0],
                [1550.0, 0.0],
                [0.0, 775.0],
                [-2550.0, 0.0],
            ],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_table2_file_matches_the_paper() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../plans/table2.toml");
        let plan = Plan::load(&path).unwrap();
        assert_eq!(plan, Plan::table2());
        assert_eq!(plan.travel_um(), 7075.0);
    }

    #[test]
    fn perturbed_starts_stay_within_their_bounds_and_follow_the_seed() {
        use rand::SeedableRng;
        let plan = Plan::table2();
        let draw = |seed| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            plan.perturbed_starts(&mut rng, 200, (26.0, 74.0, 3.0))
        };
        let (a, b) = (draw(1), draw(1));
        assert_eq!(a, b);
        assert_ne!(a, draw(2));
        let s = plan.peg_start_pose();
        for p in &a {
            assert!((p.x_um - s.x_um).abs() <= 26.0 && (p.y_um - s.y_um).abs() <= 74.0);
            assert!((p.theta_rad - s.theta_rad).abs() <= 3f64.to_radians() + 1e-12);
        }
    }

    #[test]
    fn diagonal_move_is_refused_with_its_index() {
        let mut plan = Plan::table2();
        plan.moves_um[2] = [10.0, 10.0];
        let e = plan.validate().unwrap_err().to_string();
        assert!(e.contains("move 3"), "{e}");
    }

    #[test]
    fn unknown_field_and_bad_speed_are_errors_not_panics() {
        let bad = Plan::table2().to_toml().replace("speed_um_s = 140.0", "speed_um_s = -1.0");
        assert!(Plan::from_toml(&bad, Path::new("x.toml")).is_err());
        let extra = format!("{}\nfoo = 1\n", Plan::table2().to_toml());
        let e = Plan::from_toml(&extra, Path::new("x.toml")).unwrap_err().to_string();
        assert!(e.contains("x.toml"), "{e}");
    }
}
