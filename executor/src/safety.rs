//! Safety before motion: a plan is checked against the workspace box and the speed and
//! acceleration limits of [`ExecutorConfig`] before it is accepted or armed.
//!
//! Two checks: at flash time the start position may be unknown, so [`check_plan`] checks
//! speeds, accelerations and that the plan's extent fits the workspace at all; at arm time
//! [`check_from_start`] walks the path from the probe's reported position and requires
//! every vertex inside the box (the box is convex, so straight segments between inside
//! vertices stay inside).

use crate::config::ExecutorConfig;
use crate::plan::{FlashedPlan, StepGeometry, hypot_nm};
use mesopush_protocol::flash::PlanStep;

/// Why a plan is unsafe to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SafetyViolation {
    /// A step has speed 0 (it would never end).
    ZeroSpeed {
        /// Offending step.
        step_index: u32,
    },
    /// A step moves by less than 1 nm (a pause the controller cannot express).
    ZeroLength {
        /// Offending step.
        step_index: u32,
    },
    /// A step is faster than `max_speed_nm_s`.
    SpeedTooHigh {
        /// Offending step.
        step_index: u32,
        /// Its speed, nm/s.
        speed_nm_s: u32,
        /// The limit, nm/s.
        limit_nm_s: u32,
    },
    /// The velocity change entering step `step_index` (`step_count` = the final stop) needs
    /// more than `max_accel_nm_s2` when realised over one setpoint period.
    AccelTooHigh {
        /// Step entered (or `step_count` for the final stop).
        step_index: u32,
        /// Demanded acceleration, nm/s².
        accel_nm_s2: u64,
        /// The limit, nm/s².
        limit_nm_s2: u64,
    },
    /// The plan's extent is larger than the workspace, wherever it starts.
    TooWide {
        /// Extent along x, nm.
        extent_x_nm: u64,
        /// Extent along y, nm.
        extent_y_nm: u64,
    },
    /// Starting from the probe's position, the end of step `step_index` (or the start, for
    /// `None`) lies outside the workspace.
    LeavesWorkspace {
        /// Step whose end is outside, `None` for the start position itself.
        step_index: Option<u32>,
        /// The point outside, nm.
        x_nm: i64,
        /// The point outside, nm.
        y_nm: i64,
    },
}

/// Speeds, accelerations and extent of `plan`, start position unknown.
pub fn check_plan<const CAP: usize>(
    plan: &FlashedPlan<CAP>,
    config: &ExecutorConfig,
) -> Result<(), SafetyViolation> {
    let rate_hz = u64::from(config.setpoint_rate_hz.clamp(1, 1000));
    let mut prev_v = (0i64, 0i64);
    let (mut pos, mut lo, mut hi) = ((0i64, 0i64), (0i64, 0i64), (0i64, 0i64));
    for (i, step) in plan.steps().enumerate() {
        let step_index = i as u32;
        let g = check_step(step_index, &step, config)?;
        check_accel(step_index, prev_v, (g.vx_nm_s, g.vy_nm_s), rate_hz, config)?;
        prev_v = (g.vx_nm_s, g.vy_nm_s);
        pos = (pos.0 + i64::from(step.dx_nm), pos.1 + i64::from(step.dy_nm));
        lo = (lo.0.min(pos.0), lo.1.min(pos.1));
        hi = (hi.0.max(pos.0), hi.1.max(pos.1));
    }
    check_accel(plan.step_count(), prev_v, (0, 0), rate_hz, config)?;
    let w = &config.workspace;
    let width = |min: i32, max: i32| (i64::from(max) - i64::from(min)) as u64;
    let extent = ((hi.0 - lo.0) as u64, (hi.1 - lo.1) as u64);
    if extent.0 > width(w.min_x_nm, w.max_x_nm) || extent.1 > width(w.min_y_nm, w.max_y_nm) {
        return Err(SafetyViolation::TooWide { extent_x_nm: extent.0, extent_y_nm: extent.1 });
    }
    Ok(())
}

/// Every vertex of the path from `start_nm` inside the workspace.
pub fn check_from_start<const CAP: usize>(
    plan: &FlashedPlan<CAP>,
    config: &ExecutorConfig,
    start_nm: (i32, i32),
) -> Result<(), SafetyViolation> {
    let mut pos = (i64::from(start_nm.0), i64::from(start_nm.1));
    if !config.workspace.contains(pos.0, pos.1) {
        return Err(SafetyViolation::LeavesWorkspace {
            step_index: None,
            x_nm: pos.0,
            y_nm: pos.1,
        });
    }
    for (i, step) in plan.steps().enumerate() {
        pos = (pos.0 + i64::from(step.dx_nm), pos.1 + i64::from(step.dy_nm));
        if !config.workspace.contains(pos.0, pos.1) {
            let step_index = Some(i as u32);
            return Err(SafetyViolation::LeavesWorkspace { step_index, x_nm: pos.0, y_nm: pos.1 });
        }
    }
    Ok(())
}

fn check_step(
    step_index: u32,
    step: &PlanStep,
    config: &ExecutorConfig,
) -> Result<StepGeometry, SafetyViolation> {
    if step.speed_nm_s == 0 {
        return Err(SafetyViolation::ZeroSpeed { step_index });
    }
    if step.speed_nm_s > config.max_speed_nm_s {
        let limit_nm_s = config.max_speed_nm_s;
        return Err(SafetyViolation::SpeedTooHigh {
            step_index,
            speed_nm_s: step.speed_nm_s,
            limit_nm_s,
        });
    }
    let g = StepGeometry::of(step);
    if g.len_nm == 0 {
        return Err(SafetyViolation::ZeroLength { step_index });
    }
    Ok(g)
}

fn check_accel(
    step_index: u32,
    from: (i64, i64),
    to: (i64, i64),
    rate_hz: u64,
    config: &ExecutorConfig,
) -> Result<(), SafetyViolation> {
    let dv_nm_s = hypot_nm(to.0 - from.0, to.1 - from.1);
    let accel_nm_s2 = dv_nm_s.saturating_mul(rate_hz);
    if accel_nm_s2 > config.max_accel_nm_s2 {
        let limit_nm_s2 = config.max_accel_nm_s2;
        return Err(SafetyViolation::AccelTooHigh { step_index, accel_nm_s2, limit_nm_s2 });
    }
    Ok(())
}

impl core::fmt::Display for SafetyViolation {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        use mesopush_protocol::describe::Um;
        match *self {
            Self::ZeroSpeed { step_index } => write!(f, "step {step_index} has speed 0"),
            Self::ZeroLength { step_index } => {
                write!(f, "step {step_index} moves by less than 1 nm")
            }
            Self::SpeedTooHigh { step_index, speed_nm_s, limit_nm_s } => write!(
                f,
                "step {step_index} moves at {}/s, above the limit {}/s",
                Um(i64::from(speed_nm_s)),
                Um(i64::from(limit_nm_s))
            ),
            Self::AccelTooHigh { step_index, accel_nm_s2, limit_nm_s2 } => write!(
                f,
                "entering step {step_index} needs {}/s², above the limit {}/s²",
                Um(i64::try_from(accel_nm_s2).unwrap_or(i64::MAX)),
                Um(i64::try_from(limit_nm_s2).unwrap_or(i64::MAX))
            ),
            Self::TooWide { extent_x_nm, extent_y_nm } => write!(
                f,
                "the plan spans {} × {}, more than the workspace",
                Um(i64::try_from(extent_x_nm).unwrap_or(i64::MAX)),
                Um(i64::try_from(extent_y_nm).unwrap_or(i64::MAX))
            ),
            Self::LeavesWorkspace { step_index: None, x_nm, y_nm } => write!(
                f,
                "the probe at stage ({}, {}) is outside the workspace",
                Um(x_nm),
                Um(y_nm)
            ),
            Self::LeavesWorkspace { step_index: Some(i), x_nm, y_nm } => write!(
                f,
                "step {i} ends at stage ({}, {}), outside the workspace",
                Um(x_nm),
                Um(y_nm)
            ),
        }
    }
}
