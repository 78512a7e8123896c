//! The moves of `mesopush calibrate` as executor steps, and when the probe rests in them.
//!
//! From where the probe is: a backlash take-up (`takeup_um` along x, then along y, in the
//! directions of the calibration moves, so every later move goes the way each axis was last
//! driven and no lost motion shortens a measured move), a rest, the move along x, a rest, the
//! move along y, a rest (and the executor's recording tail after it). The executor has no
//! pause step (a step must move, `SafetyViolation::ZeroLength`), so each rest is a creep of
//! [`CREEP_UM`] at the speed that spans the rest, in the direction the next move (or the last
//! one) goes: the probe stays within 0.05 µm (0.01 px) of where it stopped, and its commanded
//! position at every frame is still known exactly (`Schedule::cmd_um`). Frames count as at
//! rest from [`SETTLE_US`] after a move's end (the stage's following error dies out) to the
//! rest's end.

use crate::Error;
use mesopush_core::check::{Allowed, finite_in};
use mesopush_core::geom::Vec2;
use mesopush_executor::plan::StepGeometry;
use mesopush_protocol::flash::PlanStep;
use mesopush_protocol::units::{um_s_to_nm_s, um_to_nm};

/// Length of the creep that stands for a rest, µm.
pub const CREEP_UM: f64 = 0.05;
/// Frames within this of a move's end are not taken as at rest, µs.
pub const SETTLE_US: u64 = 300_000;
/// Shortest calibration move, µm (a move of 20 px or more at the paper's 5.3 µm/px).
pub const MIN_MOVE_UM: f64 = 100.0;

/// What the operator asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationMoves {
    /// The move along x, then the one along y, µm (signed: the direction of each).
    pub move_um: Vec2,
    /// Speed of the moves, µm/s.
    pub speed_um_s: f64,
    /// How long the probe rests at each position, s.
    pub rest_s: f64,
    /// Backlash take-up before the first rest, µm per axis (0: none).
    pub takeup_um: f64,
}

/// A rest: from `from_us` to `to_us` (open-ended for the last) after the plan's first
/// segment, µs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RestWindow {
    /// Start, µs after the first segment (the settling time after the move included).
    pub from_us: u64,
    /// End, µs after the first segment; `None`: until the recording ends.
    pub to_us: Option<u64>,
}

impl RestWindow {
    /// Whether `t_us` (after the first segment) lies in the rest.
    pub fn contains(&self, t_us: i64) -> bool {
        t_us >= self.from_us as i64 && self.to_us.is_none_or(|to| t_us < to as i64)
    }
}

/// The executor steps and the three rests.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationPlan {
    /// Steps, relative to the probe's position when armed.
    pub steps: Vec<PlanStep>,
    /// The rests before the x move, between the moves and after the y move.
    pub rests: [RestWindow; 3],
}

impl CalibrationMoves {
    /// Checks every field, naming it, its value and the range allowed.
    pub fn validate(&self) -> Result<(), Error> {
        let moves = Allowed::closed(-20_000.0, 20_000.0, "µm");
        for (name, v) in [("move x", self.move_um.x), ("move y", self.move_um.y)] {
            finite_in(name, v, moves)?;
            if v.abs() < MIN_MOVE_UM {
                return Err(Error::invalid(
                    "calibration",
                    format!(
                        "{name} of {v} µm is too short: at least {MIN_MOVE_UM} µm either way (the \
                         longer, the more exact the pixel size)"
                    ),
                ));
            }
        }
        finite_in("speed_um_s", self.speed_um_s, Allowed::positive_to(2_000.0, "µm/s"))?;
        finite_in("rest_s", self.rest_s, Allowed::closed(0.6, 60.0, "s"))?;
        finite_in("takeup_um", self.takeup_um, Allowed::closed(0.0, 1_000.0, "µm"))?;
        Ok(())
    }

    /// The executor steps and the rests.
    pub fn plan(&self) -> Result<CalibrationPlan, Error> {
        self.validate()?;
        let (sx, sy) = (self.move_um.x.signum(), self.move_um.y.signum());
        let speed = um_s_to_nm_s("calibration speed", self.speed_um_s)?;
        let creep_speed = um_s_to_nm_s("creep speed", CREEP_UM / self.rest_s)?.max(1);
        let step = |dx: f64, dy: f64, speed_nm_s: u32| -> Result<PlanStep, Error> {
            Ok(PlanStep {
                dx_nm: um_to_nm("calibration move x", dx)?,
                dy_nm: um_to_nm("calibration move y", dy)?,
                speed_nm_s,
            })
        };
        let mut steps = Vec::new();
        if self.takeup_um > 0.0 {
            steps.push(step(sx * self.takeup_um, 0.0, speed)?);
            steps.push(step(0.0, sy * self.takeup_um, speed)?);
        }
        let creeps = [
            step(sx * CREEP_UM, 0.0, creep_speed)?,
            step(0.0, sy * CREEP_UM, creep_speed)?,
            step(0.0, sy * CREEP_UM, creep_speed)?,
        ];
        let moves = [step(self.move_um.x, 0.0, speed)?, step(0.0, self.move_um.y, speed)?];
        let mut t: u64 = steps.iter().map(|s| StepGeometry::of(s).duration_us).sum();
        let mut rests = [RestWindow { from_us: 0, to_us: None }; 3];
        for (k, creep) in creeps.into_iter().enumerate() {
            let d = StepGeometry::of(&creep).duration_us;
            rests[k] = RestWindow { from_us: t + SETTLE_US, to_us: (k < 2).then_some(t + d) };
            steps.push(creep);
            t += d;
            if let Some(m) = moves.get(k) {
                steps.push(*m);
                t += StepGeometry::of(m).duration_us;
            }
        }
        Ok(CalibrationPlan { steps, rests })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn moves() -> CalibrationMoves {
        CalibrationMoves {
            move_um: Vec2::new(1000.0, -800.0),
            speed_um_s: 200.0,
            rest_s: 1.5,
            takeup_um: 20.0,
        }
    }

    #[test]
    fn the_steps_take_up_backlash_then_rest_and_move_in_one_direction_per_axis() {
        let p = moves().plan().unwrap();
        let d: Vec<(i32, i32)> = p.steps.iter().map(|s| (s.dx_nm, s.dy_nm)).collect();
        assert_eq!(
            d,
            vec![
                (20_000, 0),
                (0, -20_000),
                (50, 0),
                (1_000_000, 0),
                (0, -50),
                (0, -800_000),
                (0, -50)
            ]
        );
        // takeup 2 × 0.1 s; rest 1.5 s (50 nm at 33 nm/s: 1.515 s, rounded up); move 5 s
        let creep = StepGeometry::of(&p.steps[2]).duration_us;
        assert!((1_500_000..1_600_000).contains(&creep), "{creep}");
        let r0 = 200_000 + SETTLE_US;
        assert_eq!(p.rests[0], RestWindow { from_us: r0, to_us: Some(200_000 + creep) });
        let after_x = 200_000 + creep + 5_000_000;
        assert_eq!(p.rests[1].from_us, after_x + SETTLE_US);
        assert_eq!(p.rests[2].to_us, None);
        assert!(p.rests[2].contains(i64::MAX) && !p.rests[0].contains(r0 as i64 - 1));
    }

    #[test]
    fn bad_moves_are_refused_naming_the_field() {
        let short = CalibrationMoves { move_um: Vec2::new(50.0, 500.0), ..moves() };
        assert!(short.plan().unwrap_err().to_string().contains("move x of 50 µm"));
        let fast = CalibrationMoves { speed_um_s: 5000.0, ..moves() };
        assert!(fast.plan().unwrap_err().to_string().contains("speed_um_s"));
        let brief = CalibrationMoves { rest_s: 0.1, ..moves() };
        assert!(brief.plan().unwrap_err().to_string().contains("rest_s"));
        let none = CalibrationMoves { takeup_um: 0.0, ..moves() };
        assert_eq!(none.plan().unwrap().steps.len(), 5);
    }
}
