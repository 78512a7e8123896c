//! The world's ground truth: where the peg and the needle's tip really were at each camera
//! exposure ([`TruthSample`]), and the jam episodes ([`JamEvent`], kept by a [`JamLog`]).
//! The world (`RigWorld`) records them; the trial's truth.csv, its `jam` events and the
//! tracking error are written from them; the host's tracker never sees them.
//!
//! Jams: when the world's simulator finds the peg wedged, the probe point stops while the
//! stage goes on and the 25 µm needle bends. When the needle's deflection (commanded tip −
//! resting tip) exceeds the limit — the world model's `probe_deflection_limit_um`, the same
//! number the host's planner and the controller's `NeedleOverload` fault use — the world logs
//! a [`JamEvent`], one per episode: the episode ends when the deflection falls below half the
//! limit.

use mesopush_core::geom::{Pose, Vec2};

/// The world at one camera exposure (ground truth).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthSample {
    /// Exposure time, µs (simulation clock).
    pub t_us: u64,
    /// The peg's true pose.
    pub peg: Pose,
    /// The probe tip's true position (after backlash, held back by the peg when the peg
    /// wedged), fixture frame µm.
    pub probe_um: Vec2,
    /// The needle's deflection: distance from the commanded tip (the stage after backlash)
    /// to the actual tip, µm (0 unless the peg wedged).
    pub deflection_um: f64,
    /// Jam episodes begun so far (see [`JamEvent`]).
    pub jams: u32,
}

/// One jam episode: the needle deflected beyond the world model's limit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JamEvent {
    /// When the deflection first exceeded the limit, µs (simulation clock).
    pub t_us: u64,
    /// Largest deflection during the episode, µm.
    pub peak_deflection_um: f64,
    /// The peg's pose when the episode began.
    pub peg: Pose,
}

/// The jam episodes so far and the largest deflection, fed the needle's deflection after
/// every move. The world (a simulator) cannot model what a real needle bent past its limit
/// does (bend for good, slip over the peg, stall the stage); it records the episode so the
/// trial's verdict says why the peg did not go in, and the controller faults on it.
#[derive(Debug, Clone)]
pub struct JamLog {
    /// The needle's deflection limit, µm.
    limit_um: f64,
    events: Vec<JamEvent>,
    /// In an episode (deflection above the limit, not yet below half of it).
    in_jam: bool,
    max_deflection_um: f64,
}

impl JamLog {
    /// An empty log for a needle whose deflection limit is `limit_um` (the world model's
    /// `probe_deflection_limit_um`).
    pub fn new(limit_um: f64) -> Self {
        Self { limit_um, events: Vec::new(), in_jam: false, max_deflection_um: 0.0 }
    }

    /// The needle's deflection limit, µm.
    pub fn limit_um(&self) -> f64 {
        self.limit_um
    }

    /// Notes the deflection `d_um` at `t_us` with the peg at `peg`.
    pub fn note(&mut self, t_us: u64, d_um: f64, peg: Pose) {
        self.max_deflection_um = self.max_deflection_um.max(d_um);
        if self.in_jam {
            if let Some(e) = self.events.last_mut() {
                e.peak_deflection_um = e.peak_deflection_um.max(d_um);
            }
            self.in_jam = d_um >= 0.5 * self.limit_um;
        } else if d_um > self.limit_um {
            self.in_jam = true;
            self.events.push(JamEvent { t_us, peak_deflection_um: d_um, peg });
        }
    }

    /// The episodes begun so far.
    pub fn events(&self) -> &[JamEvent] {
        &self.events
    }

    /// Episodes begun so far, as a [`TruthSample`] counts them.
    pub fn count(&self) -> u32 {
        u32::try_from(self.events.len()).unwrap_or(u32::MAX)
    }

    /// Largest deflection so far, µm.
    pub fn max_deflection_um(&self) -> f64 {
        self.max_deflection_um
    }
}
