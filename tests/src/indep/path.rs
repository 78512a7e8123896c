//! A commanded probe path: piecewise-linear in time, built from straight moves at a speed
//! and dwells, every vertex on the controller's setpoint grid ([`SETPOINT_PERIOD_S`]), so
//! that probe.csv's rows (one per setpoint) reproduce it exactly under the format's linear
//! interpolation.

use crate::coulomb::V2;
use std::ops::{Add, Sub};

/// The controller's setpoint period, s (50 Hz).
pub const SETPOINT_PERIOD_S: f64 = 0.02;

/// A vertex of the path: the commanded probe centre at a setpoint index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vertex {
    /// Setpoint index (time = index × [`SETPOINT_PERIOD_S`]).
    pub tick: u64,
    /// Commanded probe centre, µm.
    pub at: V2,
}

/// A path starting at tick 0.
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    vertices: Vec<Vertex>,
}

impl Path {
    /// A path standing at `at` at time 0.
    pub fn start(at: V2) -> Self {
        Self { vertices: vec![Vertex { tick: 0, at }] }
    }

    /// The vertices in time order.
    pub fn vertices(&self) -> &[Vertex] {
        &self.vertices
    }

    /// The last commanded point.
    pub fn end(&self) -> V2 {
        self.last().at
    }

    fn last(&self) -> Vertex {
        *self.vertices.last().expect("a path has its start")
    }

    /// The last tick.
    pub fn end_tick(&self) -> u64 {
        self.last().tick
    }

    /// A straight move to `to` at no more than `speed_um_s` (the duration is rounded up to
    /// whole setpoints).
    pub fn line_to(&mut self, to: V2, speed_um_s: f64) {
        let last = self.last();
        let len = to.sub(last.at).len();
        let ticks = (len / (speed_um_s * SETPOINT_PERIOD_S)).ceil().max(1.0) as u64;
        self.vertices.push(Vertex { tick: last.tick + ticks, at: to });
    }

    /// Standing still for `s` seconds (rounded to whole setpoints).
    pub fn dwell(&mut self, s: f64) {
        let last = self.last();
        let ticks = (s / SETPOINT_PERIOD_S).round().max(1.0) as u64;
        self.vertices.push(Vertex { tick: last.tick + ticks, at: last.at });
    }

    /// The commanded point at (fractional) setpoint time `tick`: linear between vertices,
    /// the first before the start and the last after the end.
    pub fn at_tick(&self, tick: f64) -> V2 {
        let v = &self.vertices;
        let i = v.partition_point(|p| (p.tick as f64) <= tick);
        if i == 0 {
            return v[0].at;
        }
        if i == v.len() {
            return v[i - 1].at;
        }
        let (a, b) = (v[i - 1], v[i]);
        let w = (tick - a.tick as f64) / (b.tick - a.tick) as f64;
        a.at.add(b.at.sub(a.at).scale(w))
    }

    /// Total length of the path, µm.
    pub fn length_um(&self) -> f64 {
        self.vertices.windows(2).map(|w| w[1].at.sub(w[0].at).len()).sum()
    }

    /// Number of direction reversals (consecutive moves more than 150° apart).
    pub fn reversals(&self) -> usize {
        let moves: Vec<V2> = self
            .vertices
            .windows(2)
            .map(|w| w[1].at.sub(w[0].at))
            .filter(|d| d.len() > 1e-9)
            .collect();
        let cos150 = (150f64).to_radians().cos();
        moves.windows(2).filter(|m| m[0].dot(m[1]) < cos150 * m[0].len() * m[1].len()).count()
    }
}
