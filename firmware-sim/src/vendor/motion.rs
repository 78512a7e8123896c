//! Point-to-point motion of a vendor stage, in the device's own integer steps.
//!
//! The commercial controllers move point to point: a target and a speed, no trajectory.
//! This module plans such a move and evaluates it at any controller time, so the emulators
//! can answer "where is the stage now" without integrating.
//!
//! - Each axis follows a trapezoidal speed profile (a triangle when the move is too short to
//!   reach full speed): constant acceleration `accel_steps_s2` up to `speed_steps_s`, cruise,
//!   symmetric deceleration. Start and end speeds are zero.
//! - [`Path`] says how the axes are coordinated: a straight line led by the axis that needs
//!   the longest time, independent axes started together, or one axis after another.
//! - Positions are quantised to whole device steps (each axis rounds its continuous position
//!   to the nearest step), so a reading is always a position the device could report.
//! - Two stage positions are kept: the **counter** (the steps the controller commanded,
//!   what an open-loop stepper reports) and the **true** position (where the probe is). They
//!   differ only after a stall: while [`Stage::set_stalled`] is on, the true position stays
//!   frozen while the counter runs on (lost steps); the difference is kept afterwards.
//!
//! Units: steps, steps/s, steps/s², controller µs. The emulators convert steps to nm.

use mesopush_protocol::units::{s_to_us, us_to_s};

/// Speed and acceleration limits of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisLimits {
    /// Peak speed, device steps per second (must be > 0).
    pub speed_steps_s: f64,
    /// Acceleration and deceleration, device steps per second² (must be > 0).
    pub accel_steps_s2: f64,
}

/// How the axes of one move are coordinated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Path {
    /// All axes start and stop together on a straight line. The axis whose own profile
    /// takes longest leads; the others follow the leader's profile in proportion.
    Linear,
    /// All axes start together, each with its own profile; they finish at different times
    /// (a dog-leg path when distances differ).
    PerAxis,
    /// One axis after another in index order (x, then y, then z, ...).
    Sequential,
}

/// The longest move the model plans, µs (≈ 11.6 days): a guard against zero speeds.
const MAX_MOVE_US: u64 = 1_000_000_000_000;

/// A one-dimensional trapezoidal profile over `dist` steps.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Trapezoid {
    dist: f64,
    v_peak: f64,
    accel: f64,
    t_ramp_s: f64,
    t_flat_s: f64,
}

impl Trapezoid {
    fn new(dist: f64, lim: AxisLimits) -> Self {
        let v = lim.speed_steps_s.max(1e-9);
        let a = lim.accel_steps_s2.max(1e-9);
        let dist = dist.abs();
        if dist >= v * v / a {
            Self { dist, v_peak: v, accel: a, t_ramp_s: v / a, t_flat_s: (dist - v * v / a) / v }
        } else {
            let v_peak = (dist * a).sqrt();
            Self { dist, v_peak, accel: a, t_ramp_s: v_peak / a, t_flat_s: 0.0 }
        }
    }

    fn duration_s(&self) -> f64 {
        2.0 * self.t_ramp_s + self.t_flat_s
    }

    /// Distance covered `t_s` after the start.
    fn at(&self, t_s: f64) -> f64 {
        let (a, tr, tf) = (self.accel, self.t_ramp_s, self.t_flat_s);
        let total = self.duration_s();
        if t_s <= 0.0 {
            0.0
        } else if t_s < tr {
            0.5 * a * t_s * t_s
        } else if t_s < tr + tf {
            0.5 * a * tr * tr + self.v_peak * (t_s - tr)
        } else if t_s < total {
            let left = total - t_s;
            (self.dist - 0.5 * a * left * left).max(0.0)
        } else {
            self.dist
        }
    }
}

fn duration_us(s: f64) -> u64 {
    s_to_us("move duration", s).map_or(MAX_MOVE_US, |us| us.min(MAX_MOVE_US))
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Plan<const N: usize> {
    Linear { lead: Trapezoid },
    PerAxis([Trapezoid; N]),
    Sequential([Trapezoid; N]),
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Active<const N: usize> {
    start_us: u64,
    end_us: u64,
    from: [i64; N],
    to: [i64; N],
    plan: Plan<N>,
}

impl<const N: usize> Active<N> {
    /// Fraction of axis `i`'s distance covered at `t_s` (0..=1).
    fn fraction(&self, i: usize, t_s: f64) -> f64 {
        let frac = |tr: &Trapezoid, t: f64| if tr.dist > 0.0 { tr.at(t) / tr.dist } else { 1.0 };
        match &self.plan {
            Plan::Linear { lead } => frac(lead, t_s),
            Plan::PerAxis(tr) => frac(&tr[i], t_s),
            Plan::Sequential(tr) => {
                let before: f64 = tr[..i].iter().map(Trapezoid::duration_s).sum();
                frac(&tr[i], t_s - before)
            }
        }
    }

    fn position(&self, now_us: u64) -> [i64; N] {
        if now_us >= self.end_us {
            return self.to;
        }
        let t_s = us_to_s(now_us.saturating_sub(self.start_us));
        let mut out = self.from;
        for (i, o) in out.iter_mut().enumerate() {
            let d = (self.to[i] - self.from[i]) as f64;
            *o = self.from[i] + (d * self.fraction(i, t_s)).round() as i64;
        }
        out
    }
}

/// A stage of `N` axes moving point to point, in device steps.
#[derive(Debug, Clone, PartialEq)]
pub struct Stage<const N: usize> {
    rest: [i64; N],
    active: Option<Active<N>>,
    slip: [i64; N],
    frozen: Option<[i64; N]>,
}

impl<const N: usize> Stage<N> {
    /// At rest at `at` (counter and true position equal).
    pub fn new(at: [i64; N]) -> Self {
        Self { rest: at, active: None, slip: [0; N], frozen: None }
    }

    /// Starts a move from the counter position at `now_us` to `to`; a move in progress is
    /// replaced from where it is. Returns the time the move ends, µs.
    pub fn start(&mut self, now_us: u64, to: [i64; N], path: Path, lim: [AxisLimits; N]) -> u64 {
        let from = self.counter(now_us);
        self.rest = from;
        let tr: [Trapezoid; N] =
            core::array::from_fn(|i| Trapezoid::new((to[i] - from[i]) as f64, lim[i]));
        let (plan, dur_s) = match path {
            Path::Linear => {
                let lead = tr.iter().copied().fold(Trapezoid::new(0.0, lim[0]), |best, t| {
                    if t.duration_s() > best.duration_s() { t } else { best }
                });
                (Plan::Linear { lead }, lead.duration_s())
            }
            Path::PerAxis => {
                (Plan::PerAxis(tr), tr.iter().map(Trapezoid::duration_s).fold(0.0, f64::max))
            }
            Path::Sequential => (Plan::Sequential(tr), tr.iter().map(Trapezoid::duration_s).sum()),
        };
        let end_us = now_us.saturating_add(duration_us(dur_s));
        self.active = Some(Active { start_us: now_us, end_us, from, to, plan });
        end_us
    }

    /// The controller's step counter at `now_us`.
    pub fn counter(&self, now_us: u64) -> [i64; N] {
        self.active.map_or(self.rest, |a| a.position(now_us))
    }

    /// Where the stage really is at `now_us` (differs from the counter after a stall).
    pub fn true_pos(&self, now_us: u64) -> [i64; N] {
        if let Some(f) = self.frozen {
            return f;
        }
        let c = self.counter(now_us);
        core::array::from_fn(|i| c[i] + self.slip[i])
    }

    /// End of the move in progress (even if `now` is past it and [`Self::settle`] not yet
    /// called), µs.
    pub fn end_us(&self) -> Option<u64> {
        self.active.map(|a| a.end_us)
    }

    /// Target of the move in progress.
    pub fn target(&self) -> Option<[i64; N]> {
        self.active.map(|a| a.to)
    }

    /// A move is planned and not over at `now_us`.
    pub fn is_moving(&self, now_us: u64) -> bool {
        self.active.is_some_and(|a| now_us < a.end_us)
    }

    /// Which axes change position between `now_us` and the end of the move.
    pub fn moving_axes(&self, now_us: u64) -> [bool; N] {
        match self.active {
            Some(a) if now_us < a.end_us => {
                let c = a.position(now_us);
                core::array::from_fn(|i| c[i] != a.to[i])
            }
            _ => [false; N],
        }
    }

    /// Finishes the move if it is over at `now_us`; true when it just finished.
    pub fn settle(&mut self, now_us: u64) -> bool {
        match self.active {
            Some(a) if now_us >= a.end_us => {
                self.rest = a.to;
                self.active = None;
                true
            }
            _ => false,
        }
    }

    /// Stops dead at the position reached at `now_us` (steppers stop within a step at
    /// these speeds; no deceleration ramp is modelled).
    pub fn stop(&mut self, now_us: u64) {
        self.rest = self.counter(now_us);
        self.active = None;
    }

    /// Starts (`true`) or ends (`false`) a stall at `now_us`: while stalled the true position
    /// does not move; the steps lost stay lost after the stall ends.
    pub fn set_stalled(&mut self, now_us: u64, stalled: bool) {
        match (stalled, self.frozen) {
            (true, None) => self.frozen = Some(self.true_pos(now_us)),
            (false, Some(f)) => {
                let c = self.counter(now_us);
                self.slip = core::array::from_fn(|i| f[i] - c[i]);
                self.frozen = None;
            }
            _ => {}
        }
    }

    /// Whether a stall is on.
    pub fn is_stalled(&self) -> bool {
        self.frozen.is_some()
    }

    /// Sets the counter of the stage at rest to `counter` without moving it (set-origin,
    /// zero, re-calibration); the true position is unchanged. Ignored while moving.
    pub fn set_counter(&mut self, counter: [i64; N]) {
        if self.active.is_some() {
            return;
        }
        let t = self.true_pos_at_rest();
        self.rest = counter;
        if self.frozen.is_none() {
            self.slip = core::array::from_fn(|i| t[i] - counter[i]);
        }
    }

    /// Steps lost so far (true − counter), per axis, while not stalled.
    pub fn slip(&self) -> [i64; N] {
        self.slip
    }

    fn true_pos_at_rest(&self) -> [i64; N] {
        self.frozen.unwrap_or(core::array::from_fn(|i| self.rest[i] + self.slip[i]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIM: AxisLimits = AxisLimits { speed_steps_s: 1000.0, accel_steps_s2: 10_000.0 };

    #[test]
    fn trapezoid_and_triangle_durations() {
        // 1000 steps at 1000/s with 10000/s²: ramps 0.1 s each (100 steps), cruise 0.8 s.
        assert!((Trapezoid::new(1000.0, LIM).duration_s() - 1.1).abs() < 1e-12);
        // 25 steps: triangle, peak sqrt(25*10000)=500/s, 0.05 s up and down.
        assert!((Trapezoid::new(25.0, LIM).duration_s() - 0.1).abs() < 1e-12);
    }

    #[test]
    fn linear_keeps_a_straight_line_and_quantises() {
        let mut s = Stage::<2>::new([0, 0]);
        let end = s.start(0, [1000, 500], Path::Linear, [LIM; 2]);
        assert_eq!(end, 1_100_000);
        for t in (0..end).step_by(10_000) {
            let [x, y] = s.counter(t);
            assert!((2 * y - x).abs() <= 1, "off the line at {t}: {x},{y}");
        }
        assert_eq!(s.counter(end), [1000, 500]);
    }

    #[test]
    fn per_axis_and_sequential_timing() {
        let mut s = Stage::<2>::new([0, 0]);
        assert_eq!(s.start(0, [1000, 25], Path::PerAxis, [LIM; 2]), 1_100_000);
        assert_eq!(s.counter(100_000)[1], 25, "y done after 0.1 s");
        let mut s = Stage::<2>::new([0, 0]);
        assert_eq!(s.start(0, [1000, 25], Path::Sequential, [LIM; 2]), 1_200_000);
        assert_eq!(s.counter(1_100_000), [1000, 0]);
    }

    #[test]
    fn stall_freezes_the_true_position_and_keeps_the_slip() {
        let mut s = Stage::<1>::new([0]);
        s.start(0, [1000], Path::Linear, [LIM]);
        s.set_stalled(100_000, true); // 50 steps done
        assert_eq!(s.true_pos(600_000), [50]);
        assert!(s.settle(1_100_000));
        assert_eq!(s.counter(1_100_000), [1000]);
        s.set_stalled(1_200_000, false);
        assert_eq!((s.true_pos(1_300_000), s.slip()), ([50], [-950]));
    }
}
