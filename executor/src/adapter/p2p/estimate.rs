//! Where the probe is while a point-to-point move runs and no position can be read (a Sutter
//! answers nothing until the move ends; others are polled only every few tens of ms): the
//! commanded profile — a straight line from where the move began to its target at the speed
//! the device achieves, from the moment its last byte went out. The device's own
//! acceleration is not known (it is not in the public protocols), so the estimate leads
//! the stage by at most the acceleration phase; the measured position replaces it as soon as
//! one is read.

use crate::plan::{hypot_nm, lerp_nm};

/// A move as commanded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Profile {
    /// Where it began, nm.
    pub from_nm: (i32, i32),
    /// Its target, nm.
    pub to_nm: (i32, i32),
    /// When it began, executor µs.
    pub began_us: u64,
    /// The speed the device uses, nm/s (≥ 1).
    pub speed_nm_s: u32,
}

impl Profile {
    /// The move's duration at its speed, µs.
    pub fn duration_us(&self) -> u64 {
        let (dx, dy) = self.delta_nm();
        (hypot_nm(dx, dy) * 1_000_000).div_ceil(u64::from(self.speed_nm_s.max(1)))
    }

    /// The commanded position at `now_us`.
    pub fn at(&self, now_us: u64) -> (i32, i32) {
        let dur = self.duration_us();
        let elapsed = now_us.saturating_sub(self.began_us).min(dur);
        let from = (i64::from(self.from_nm.0), i64::from(self.from_nm.1));
        let to = (i64::from(self.to_nm.0), i64::from(self.to_nm.1));
        let (x, y) = lerp_nm(from, to, elapsed, dur);
        (x as i32, y as i32) // between two i32 points
    }

    fn delta_nm(&self) -> (i64, i64) {
        (
            i64::from(self.to_nm.0) - i64::from(self.from_nm.0),
            i64::from(self.to_nm.1) - i64::from(self.from_nm.1),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_estimate_runs_along_the_line_and_stops_at_the_target() {
        let p = Profile {
            from_nm: (0, 0),
            to_nm: (30_000, 40_000),
            began_us: 1_000,
            speed_nm_s: 100_000,
        };
        assert_eq!(p.duration_us(), 500_000); // 50 µm at 100 µm/s
        assert_eq!(p.at(0), (0, 0));
        assert_eq!(p.at(251_000), (15_000, 20_000));
        assert_eq!(p.at(10_000_000), (30_000, 40_000));
    }
}
