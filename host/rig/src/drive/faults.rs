//! Faults injected and detected, by class, so a batch can compare the two per class (see
//! docs/batch.md, "Faults injected and detected"). A fault counts as *detected* when a part
//! of the system (not the test harness) noticed it and said so:
//!
//! - `camera`: dropped and black frames. Detected when the recorder finds a frame missing
//!   from the executor's frame counter, or the executor stamps a frame black (and, before
//!   the trial, when the pre-trial frame's period passes without it or its mean level is
//!   black).
//! - `controller`: injected stalls, limit switches and reboots mid-move. Detected when the
//!   executor raises a trial fault.
//! - `exec_ctrl_link`: frames dropped, corrupted, duplicated or delayed on the two lines
//!   between executor and controller. Detected are the executor's controller-link events:
//!   frames rejected as corrupt, duplicates and out-of-order frames dropped, frames
//!   retransmitted. These are events, not faults: a lost frame is typically seen both as a
//!   gap by the receiver and as a retransmission by the sender, and a retransmission can
//!   itself arrive as a duplicate, so `detected` exceeds `injected` here; a class with
//!   `detected` < `injected` would mean faults passed unseen.
//! - `host_exec_link`: the same on the two lines between host and executor, detected by
//!   both ends (the executor's host link and the host session's link), since both are
//!   ours: link events again, not faults.
//!
//! It lives with the loop drivers: the counts are a driven trial's report — the simulated
//! loop sees both what the plant injected and what the executor and the client detected,
//! which neither of those modules sees alone.

use serde::{Deserialize, Serialize};

/// Injected and detected counts of one class.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FaultCount {
    /// Faults the world (or the batch's camera) injected.
    pub injected: u64,
    /// Detections by the system.
    pub detected: u64,
}

impl FaultCount {
    fn add(&mut self, o: &FaultCount) {
        self.injected += o.injected;
        self.detected += o.detected;
    }
}

/// Faults by class (see the module's header for what each counts).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct FaultClasses {
    /// Dropped and black frames.
    pub camera: FaultCount,
    /// Stalls, limit switches, reboots.
    pub controller: FaultCount,
    /// Link faults between executor and controller.
    pub exec_ctrl_link: FaultCount,
    /// Link faults between host and executor.
    pub host_exec_link: FaultCount,
}

impl FaultClasses {
    /// Adds `o` class by class.
    pub fn add(&mut self, o: &FaultClasses) {
        self.camera.add(&o.camera);
        self.controller.add(&o.controller);
        self.exec_ctrl_link.add(&o.exec_ctrl_link);
        self.host_exec_link.add(&o.host_exec_link);
    }

    /// All classes together.
    pub fn total(&self) -> FaultCount {
        let mut t = FaultCount::default();
        for c in [&self.camera, &self.controller, &self.exec_ctrl_link, &self.host_exec_link] {
            t.add(c);
        }
        t
    }
}
