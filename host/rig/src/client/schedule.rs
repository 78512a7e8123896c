//! The setpoint schedule the executor runs, rebuilt on the host from the flashed plan steps
//! and the stage's start with the executor's own `path_position_nm`: the commanded probe
//! position of every setpoint row of probe.csv. The in-process recorder (in the drive
//! module) and the completion of a recorded trial (`complete_trial`) both write probe.csv
//! from it.

use mesopush_core::geom::Vec2;
use mesopush_executor::plan::{StepGeometry, path_position_nm};
use mesopush_protocol::flash::PlanStep;
use mesopush_protocol::units::nm_i64_to_um;

/// How the commanded path is rebuilt.
#[derive(Debug, Clone)]
pub struct Schedule {
    /// The flashed steps.
    pub steps: Vec<PlanStep>,
    /// Probe start, stage nm.
    pub start_nm: (i64, i64),
    /// Fixture origin in stage coordinates, µm.
    pub offset_um: Vec2,
    /// Setpoint period, µs.
    pub period_us: u64,
    /// Lead from the `Started` event to the first segment, µs.
    pub lead_us: u64,
}

impl Schedule {
    /// The setpoint period, µs, at least 1.
    pub fn period(&self) -> u64 {
        self.period_us.max(1)
    }

    /// The plan's length, µs.
    pub fn total_us(&self) -> u64 {
        self.steps.iter().map(|s| StepGeometry::of(s).duration_us).sum()
    }

    /// Setpoint rows: one per period of the plan, and one at its end.
    pub fn rows(&self) -> u64 {
        self.total_us().div_ceil(self.period()) + 1
    }

    /// The commanded position `rel_us` into the plan, fixture µm.
    pub fn cmd_um(&self, rel_us: u64) -> Vec2 {
        let (x, y) = path_position_nm(self.steps.iter().copied(), self.start_nm, rel_us);
        Vec2::new(nm_i64_to_um(x), nm_i64_to_um(y)) - self.offset_um
    }

    /// The commanded position of setpoint row `k` (the plan's end for the last row).
    pub fn row_cmd_um(&self, k: u64) -> Vec2 {
        self.cmd_um((k * self.period()).min(self.total_us()))
    }
}
