//! Operator-facing text of the wire's refusals, faults and states.
//!
//! A rig operator reads these in `mesopush` output and in events.csv: each says what
//! happened, in µm and words rather than Rust debug text, and — for refusals and faults —
//! what to try. One place, so the CLI, the recorder and the executor's log all say the same
//! thing. `no_std`: positions are printed from nm with integer arithmetic (0.1 µm).

use crate::ctrl::{CtrlState, FaultCode, FaultReport};
use crate::flash::{FlashRejectReason, SafetyLimit};
use crate::host::{CommandRejectReason, ExecState, MotionEventKind, StagePoint, TrialFault};
use core::fmt;

/// A length in nm printed as µm with one decimal (`-49000.0 µm`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Um(pub i64);

/// `nm` as µm with one decimal, no unit.
fn write_um_number(f: &mut fmt::Formatter<'_>, nm: i64) -> fmt::Result {
    let tenths = (nm.unsigned_abs() + 50) / 100;
    let sign = if nm < 0 && tenths != 0 { "-" } else { "" };
    write!(f, "{sign}{}.{}", tenths / 10, tenths % 10)
}

/// An executor time in µs printed as seconds with three decimals.
struct Secs(u64);

impl fmt::Display for Secs {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ms = self.0 / 1000;
        write!(f, "{}.{:03} s", ms / 1000, ms % 1000)
    }
}

impl fmt::Display for Um {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_um_number(f, self.0)?;
        f.write_str(" µm")
    }
}

impl fmt::Display for StagePoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("(")?;
        write_um_number(f, i64::from(self.x_nm))?;
        f.write_str(", ")?;
        write_um_number(f, i64::from(self.y_nm))?;
        f.write_str(") µm")
    }
}

impl fmt::Display for ExecState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Idle => "idle (no plan)",
            Self::Flashing => "flashing a plan",
            Self::PlanFlashed => "plan flashed",
            Self::Armed => "armed",
            Self::Running => "running a trial",
            Self::Done => "trial done",
            Self::Aborted => "trial aborted",
            Self::Faulted => "faulted",
            Self::Moving => "moving (goto/home)",
        })
    }
}

impl fmt::Display for CtrlState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Idle => "idle",
            Self::Moving => "moving",
            Self::Stopped => "stopped",
            Self::Faulted => "faulted",
        })
    }
}

impl fmt::Display for FaultCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Stall => f.write_str(
                "the stage stalled (it fell too far behind the command: an obstruction, a \
                 jammed needle or a motor fault); check the needle and the fixture, then \
                 `rig home` or `rig goto` and re-run",
            ),
            Self::LimitSwitch => f.write_str(
                "a limit switch tripped (the stage reached the end of its travel); check the \
                 workspace limits and the stage registration, then `rig goto` back inside",
            ),
            Self::Reboot => f.write_str(
                "the controller rebooted (power or firmware reset); its queue and clock were \
                 lost — check its supply and cable, then `rig status` and re-run",
            ),
            Self::QueueOverflow => f.write_str(
                "the controller's move queue overflowed (the executor sent more than it \
                 could hold); report this as a bug with the trial directory",
            ),
            Self::QueueUnderrun => f.write_str(
                "the controller's move queue ran dry mid-motion (moves arrived late: the \
                 executor or the line was delayed); run the executor with --rt-priority and \
                 less load on the machine, then re-run",
            ),
            Self::BadSegment => f.write_str(
                "the controller refused a move (target outside its travel or speed out of \
                 range); check the plan and the stage registration",
            ),
            Self::SegmentLate => f.write_str(
                "a move reached the controller after its start time (the line or the \
                 executor was delayed); run with --rt-priority and less load, then re-run",
            ),
            Self::ExecutorSilent => f.write_str(
                "the controller stopped because the executor's heartbeats ceased; check the \
                 executor process and the controller line",
            ),
            Self::NeedleOverload => f.write_str(
                "the needle bent beyond its limit (the model's probe_deflection_limit_um): the \
                 peg is wedged or the plan pushes too hard; back the probe off with `rig goto`, \
                 look at the needle for damage, and check the plan with `mesopush sim` (it \
                 reports the peak deflection) before running it again",
            ),
            Self::Other(code) => write!(
                f,
                "the controller reported fault code {code}, which this software does not \
                 know; see the controller's manual"
            ),
            Self::MoveIgnored => f.write_str(
                "the controller did not execute a move it was sent (the stage stayed where it \
                 was); check that the manipulator is not in manual mode and that its cable is \
                 seated, then `rig status` and re-run",
            ),
        }
    }
}

impl fmt::Display for FaultReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let at = StagePoint { x_nm: self.x_nm, y_nm: self.y_nm };
        write!(f, "controller fault at stage {at}")?;
        if let Some(id) = self.segment_id {
            write!(f, " (move {id})")?;
        }
        write!(f, ": {}", self.code)
    }
}

impl fmt::Display for TrialFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Controller(report) => write!(f, "{report}"),
            Self::ControllerSilent { last_heard_exec_time_us } => write!(
                f,
                "the controller went silent (nothing heard since executor time {}, \
                 longer than the executor's watchdog); the probe was stopped — check the \
                 controller's power and cable, or the load on the machine running the \
                 controller (use --rt-priority), then `rig status` and re-run",
                Secs(*last_heard_exec_time_us)
            ),
            Self::HostLinkLost { last_heard_exec_time_us } => write!(
                f,
                "the host went silent (nothing heard since executor time {}); the probe \
                 was stopped — keep `mesopush run` connected until the trial ends, then \
                 re-run",
                Secs(*last_heard_exec_time_us)
            ),
            Self::ClockSyncLost => f.write_str(
                "clock sync with the controller was lost (its replies came too late); the \
                 probe was stopped — reduce the load on the machine or use --rt-priority, \
                 then re-run",
            ),
            Self::StreamUnderrun { step_index } => write!(
                f,
                "the executor could not send the moves of plan step {step_index} in time \
                 (its loop was delayed); the probe was stopped — use --rt-priority and \
                 --pin-cpu, or a lower --setpoint-rate-hz, then re-run"
            ),
        }
    }
}

impl fmt::Display for SafetyLimit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::ZeroSpeed => "a step has speed 0",
            Self::ZeroLength => "a step moves by less than 1 nm",
            Self::Speed => "a step is faster than the executor's speed limit",
            Self::Acceleration => "a speed change needs more than the acceleration limit",
            Self::Workspace => "the path leaves the workspace box",
        })
    }
}

impl fmt::Display for CommandRejectReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::WrongState { state } => write!(
                f,
                "the executor cannot do that while {state}; check `rig status` (`rig stop` \
                 ends a trial or move)"
            ),
            Self::PlanIdMismatch { stored_plan_id: Some(id) } => write!(
                f,
                "the executor holds another plan (id {id:08x}); flash this plan first \
                 (`mesopush flash`) or pass the flashed one with --plan"
            ),
            Self::PlanIdMismatch { stored_plan_id: None } => {
                f.write_str("the executor holds no plan; flash one first (`mesopush flash`)")
            }
            Self::Incompatible => f.write_str(
                "no compatible handshake: the host and the executor are different versions; \
                 install matching builds",
            ),
            Self::Unsafe { step_index: Some(i), limit } => write!(
                f,
                "unsafe from the probe's position: at plan step {i} {limit}; move the probe \
                 to the plan's start (`rig goto`) or fix the plan"
            ),
            Self::Unsafe { step_index: None, limit } => write!(
                f,
                "unsafe: the probe itself is outside the workspace ({limit}); move it inside \
                 with `rig goto`"
            ),
            Self::NotReady { clock_synced, position_known, ctrl_ready } => {
                f.write_str("the executor is not ready:")?;
                if !clock_synced {
                    f.write_str(" no clock sync with the controller yet;")?;
                }
                if !position_known {
                    f.write_str(" no position report from the controller yet;")?;
                }
                if !ctrl_ready {
                    f.write_str(" the controller is faulted and did not clear;")?;
                }
                f.write_str(
                    " check the controller's power and line and `rig status` (its last fault)",
                )
            }
            Self::StartMismatch { probe, start, tolerance_nm } => write!(
                f,
                "the probe is at stage {probe} but the plan starts at stage {start}, more \
                 than the tolerance {} apart; move it there first with `rig goto` (then \
                 re-run)",
                Um(i64::from(*tolerance_nm))
            ),
            Self::OutsideWorkspace { target, min, max } => write!(
                f,
                "the target {target} is outside the workspace box {min} .. {max}; choose a \
                 target inside it"
            ),
        }
    }
}

impl fmt::Display for FlashRejectReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::UnsupportedFormatVersion { got } => write!(
                f,
                "flash image format {got} is not supported; install matching host and \
                 executor builds"
            ),
            Self::StepCountMismatch { step_count, image_len_bytes } => write!(
                f,
                "corrupt upload header ({step_count} steps but {image_len_bytes} bytes); \
                 flash again"
            ),
            Self::PartialStep { image_len_bytes } => {
                write!(f, "the image ({image_len_bytes} bytes) holds a partial step; flash again")
            }
            Self::TooLarge { image_len_bytes, capacity_bytes } => write!(
                f,
                "the plan ({image_len_bytes} bytes) exceeds the executor's plan memory \
                 ({capacity_bytes} bytes); shorten the plan"
            ),
            Self::PlanIdMismatch { expected_plan_id, got_plan_id } => write!(
                f,
                "upload of plan {got_plan_id:08x} interleaved with plan \
                 {expected_plan_id:08x}; flash one plan at a time"
            ),
            Self::OutOfOrderChunk { expected_offset_bytes, got_offset_bytes } => write!(
                f,
                "upload chunk at byte {got_offset_bytes}, expected {expected_offset_bytes}; \
                 flash again"
            ),
            Self::LengthMismatch { expected_len_bytes, received_len_bytes } => write!(
                f,
                "upload truncated ({received_len_bytes} of {expected_len_bytes} bytes); \
                 flash again"
            ),
            Self::CrcMismatch { .. } => f.write_str("upload damaged (CRC mismatch); flash again"),
            Self::NoFlashInProgress => f.write_str("no upload in progress; flash again"),
            Self::Unsafe { step_index, limit } => write!(
                f,
                "the plan is unsafe: at step {step_index} {limit}; fix the plan (the \
                 executor's log has the numbers)"
            ),
            Self::NotStored => f.write_str(
                "the executor could not store the plan (its disk); the previous plan stays — \
                 check the executor's --plan-store path",
            ),
        }
    }
}

impl fmt::Display for MotionEventKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Started { target } => write!(f, "moving to stage {target}"),
            Self::Arrived { at } => write!(f, "arrived at stage {at}"),
            Self::Stopped => f.write_str("stopped on request"),
            Self::Faulted(fault) => write!(f, "the move faulted: {fault}"),
        }
    }
}

impl fmt::Display for crate::camera::CameraHeaderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use crate::camera::{CAMERA_FORMAT_VERSION, CAMERA_MAX_PIXELS, CameraHeaderError as E};
        match self {
            E::BadMagic => write!(f, "not a camera frame (the header does not start with MPCF)"),
            E::UnsupportedVersion { got } => write!(
                f,
                "camera frame format version {got}; this build reads version \
                 {CAMERA_FORMAT_VERSION}: update the camera source or the executor"
            ),
            E::TooLarge { width_px, height_px } => write!(
                f,
                "a {width_px} × {height_px} px frame is larger than the {CAMERA_MAX_PIXELS} pixels \
                 allowed"
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::ToString;

    #[test]
    fn positions_print_in_um_with_one_decimal() {
        assert_eq!(Um(3_050_000).to_string(), "3050.0 µm");
        assert_eq!(Um(-49_000_040).to_string(), "-49000.0 µm");
        assert_eq!(Um(-40).to_string(), "0.0 µm");
        assert_eq!(Um(1_250).to_string(), "1.3 µm");
        let p = StagePoint { x_nm: -1_500, y_nm: 2_000_000 };
        assert_eq!(p.to_string(), "(-1.5, 2000.0) µm");
    }

    #[test]
    fn a_start_mismatch_names_both_positions_the_tolerance_and_goto() {
        let r = CommandRejectReason::StartMismatch {
            probe: StagePoint { x_nm: 3_050_000, y_nm: 3_050_000 },
            start: StagePoint { x_nm: -49_000_000, y_nm: -49_000_000 },
            tolerance_nm: 5_000,
        };
        let text = r.to_string();
        for part in ["(3050.0, 3050.0) µm", "(-49000.0, -49000.0) µm", "5.0 µm", "rig goto"] {
            assert!(text.contains(part), "{text}");
        }
    }
}
