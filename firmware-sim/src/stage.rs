//! The XY stage: a speed- and acceleration-limited follower of the commanded trajectory.
//!
//! Profile (documented simplification of a servo drive): each servo period the stage's
//! desired velocity is the commanded velocity plus `tracking_gain × (commanded − actual)`,
//! clamped to `max_speed`; the actual velocity moves toward it by at most `max_accel × dt`.
//! Reports are quantised to the encoder resolution (0.1 µm by default). A stalled stage does
//! not move at all, so its following error grows until the controller faults.

use crate::config::CtrlConfig;

/// Stage state in nm and nm/s (f64 internally; reported as integers).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stage {
    /// Actual position, nm.
    pub pos_nm: (f64, f64),
    /// Actual velocity, nm/s.
    pub vel_nm_s: (f64, f64),
    /// The stage is stalled (injected fault).
    pub stalled: bool,
}

fn clamp_norm(v: (f64, f64), max: f64) -> (f64, f64) {
    let n = v.0.hypot(v.1);
    if n > max && n > 0.0 { (v.0 * max / n, v.1 * max / n) } else { v }
}

impl Stage {
    /// At rest at `pos_nm`.
    pub fn at(pos_nm: (f64, f64)) -> Self {
        Self { pos_nm, vel_nm_s: (0.0, 0.0), stalled: false }
    }

    /// Advances `dt_s` toward commanded position `cmd_nm` moving at `cmd_vel_nm_s`.
    pub fn step(
        &mut self,
        cmd_nm: (f64, f64),
        cmd_vel_nm_s: (f64, f64),
        dt_s: f64,
        cfg: &CtrlConfig,
    ) {
        if self.stalled {
            self.vel_nm_s = (0.0, 0.0);
            return;
        }
        let k = cfg.tracking_gain_per_s;
        let desired = (
            cmd_vel_nm_s.0 + k * (cmd_nm.0 - self.pos_nm.0),
            cmd_vel_nm_s.1 + k * (cmd_nm.1 - self.pos_nm.1),
        );
        let desired = clamp_norm(desired, cfg.max_speed_nm_s);
        let dv = (desired.0 - self.vel_nm_s.0, desired.1 - self.vel_nm_s.1);
        let dv = clamp_norm(dv, cfg.max_accel_nm_s2 * dt_s);
        self.vel_nm_s = (self.vel_nm_s.0 + dv.0, self.vel_nm_s.1 + dv.1);
        self.pos_nm =
            (self.pos_nm.0 + self.vel_nm_s.0 * dt_s, self.pos_nm.1 + self.vel_nm_s.1 * dt_s);
    }

    /// Position as the encoder reports it: rounded to `resolution_nm`.
    pub fn reported_nm(&self, resolution_nm: i32) -> (i32, i32) {
        let r = f64::from(resolution_nm);
        let q =
            |v: f64| ((v / r).round() * r).clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32;
        (q(self.pos_nm.0), q(self.pos_nm.1))
    }

    /// Distance from `cmd_nm`, nm.
    pub fn following_error_nm(&self, cmd_nm: (f64, f64)) -> f64 {
        (cmd_nm.0 - self.pos_nm.0).hypot(cmd_nm.1 - self.pos_nm.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tracks_a_ramp_within_a_micron_and_respects_limits() {
        let cfg = CtrlConfig::DEFAULT;
        let mut stage = Stage::at((0.0, 0.0));
        let dt = 250e-6;
        let v = 140_000.0; // 140 µm/s
        let mut worst: f64 = 0.0;
        let mut prev_v = (0.0, 0.0);
        for i in 1..=4000 {
            let t = i as f64 * dt;
            stage.step((v * t, 0.0), (v, 0.0), dt, &cfg);
            let a = (stage.vel_nm_s.0 - prev_v.0).hypot(stage.vel_nm_s.1 - prev_v.1) / dt;
            assert!(a <= cfg.max_accel_nm_s2 * 1.000_001, "accel {a}");
            prev_v = stage.vel_nm_s;
            if t > 0.05 {
                worst = worst.max(stage.following_error_nm((v * t, 0.0)));
            }
        }
        assert!(worst < 1_000.0, "following error {worst} nm");
    }

    #[test]
    fn speed_limit_holds_and_reports_are_quantised() {
        let cfg = CtrlConfig::DEFAULT;
        let mut stage = Stage::at((0.0, 0.0));
        for _ in 0..10_000 {
            stage.step((5_000_000.0, 0.0), (0.0, 0.0), 250e-6, &cfg);
            assert!(stage.vel_nm_s.0.hypot(stage.vel_nm_s.1) <= cfg.max_speed_nm_s + 1e-6);
        }
        let (x, y) = stage.reported_nm(100);
        assert_eq!((x % 100, y), (0, 0));
    }

    #[test]
    fn a_stalled_stage_does_not_move() {
        let cfg = CtrlConfig::DEFAULT;
        let mut stage = Stage::at((10.0, 10.0));
        stage.stalled = true;
        stage.step((1e6, 0.0), (1e5, 0.0), 1e-3, &cfg);
        assert_eq!(stage.pos_nm, (10.0, 10.0));
    }
}
