//! Rig commands between trials: `Goto` (and `Home`, a goto to the configured park
//! position) and `Stop`.
//!
//! A goto is streamed like a trial — the same [`Streamer`], setpoint rate, look-ahead, flow
//! control and watchdogs — of a one-step plan from the probe's reported position to the
//! target at `goto_speed_nm_s`, so it needs no code path of its own in the controller. The
//! route is the straight line: the workspace box is convex, so a line between two points
//! inside stays inside (a target outside is refused; from a probe outside, the line is the
//! way back in). The executor does not know where the peg is: clearing the path is the
//! operator's part. `Stop` sends `Stop` to the controller at once, whatever the state.

use super::host::reject;
use super::{Executor, push};
use crate::io::{Output, Outputs};
use crate::plan::FlashedPlan;
use crate::store::PlanStore;
use crate::stream::Streamer;
use heapless::Vec;
use mesopush_protocol::flash::{FlashHeader, PLAN_STEP_LEN_BYTES, PlanStep};
use mesopush_protocol::host::{
    CommandRejectReason, ExecState, MotionEventKind, StagePoint, TrialEventKind,
};
use mesopush_protocol::{ExecToCtrl, ExecToHost};

/// Image bytes of a goto: one step.
pub(crate) const GOTO_IMAGE_LEN: usize = PLAN_STEP_LEN_BYTES;

impl<S: PlanStore, const CAP: usize, const LA: usize> Executor<S, CAP, LA> {
    /// Starts moving the probe to `target` (state `Moving`), or refuses.
    pub(super) fn goto<const N: usize>(
        &mut self,
        now_us: u64,
        target: StagePoint,
        out: &mut Outputs<N>,
    ) {
        if !matches!(
            self.state,
            ExecState::Idle
                | ExecState::PlanFlashed
                | ExecState::Done
                | ExecState::Aborted
                | ExecState::Faulted
        ) {
            return self.wrong_state(out);
        }
        let w = self.config.workspace;
        if !w.contains(i64::from(target.x_nm), i64::from(target.y_nm)) {
            let min = StagePoint { x_nm: w.min_x_nm, y_nm: w.min_y_nm };
            let max = StagePoint { x_nm: w.max_x_nm, y_nm: w.max_y_nm };
            return reject(out, CommandRejectReason::OutsideWorkspace { target, min, max });
        }
        let Some(report) = self.ready_position(now_us, out) else { return };
        let (Some(now_ctrl_us), Some(status)) = (self.sync.to_ctrl_us(now_us), self.ctrl_status)
        else {
            return;
        };
        let step = match (
            i32::try_from(i64::from(target.x_nm) - i64::from(report.x_nm)),
            i32::try_from(i64::from(target.y_nm) - i64::from(report.y_nm)),
        ) {
            (Ok(dx_nm), Ok(dy_nm)) => {
                PlanStep { dx_nm, dy_nm, speed_nm_s: self.config.goto_speed_nm_s }
            }
            _ => {
                let limit = mesopush_protocol::flash::SafetyLimit::Workspace;
                return reject(out, CommandRejectReason::Unsafe { step_index: None, limit });
            }
        };
        self.last_fault = None;
        if step.dx_nm == 0 && step.dy_nm == 0 {
            let at = StagePoint { x_nm: report.x_nm, y_nm: report.y_nm };
            return self.motion_event(now_us, MotionEventKind::Arrived { at }, out);
        }
        let Some(goto) = one_step_plan(&step) else { return };
        let capacity = status.queue_free_slots.saturating_add(status.queue_len);
        let stream = Streamer::new(
            &goto,
            &self.config,
            (report.x_nm, report.y_nm),
            now_ctrl_us + self.config.start_lead_us,
            self.next_segment_id,
            capacity,
        );
        self.next_segment_id = self.next_segment_id.wrapping_add(stream.segment_count() as u32);
        self.stream = Some(stream);
        self.goto = Some(goto);
        self.state = ExecState::Moving;
        self.motion_event(now_us, MotionEventKind::Started { target }, out);
    }

    /// The goto's last segment is done: back to rest, the probe's position reported.
    pub(super) fn motion_arrived<const N: usize>(&mut self, now_us: u64, out: &mut Outputs<N>) {
        self.stream = None;
        self.goto = None;
        self.state = self.rest_state();
        let at = self
            .latest_position()
            .map_or(StagePoint { x_nm: 0, y_nm: 0 }, |p| StagePoint { x_nm: p.x_nm, y_nm: p.y_nm });
        self.motion_event(now_us, MotionEventKind::Arrived { at }, out);
    }

    /// `Stop` from any state: the controller is told at once; a trial ends aborted, a goto
    /// stopped, an upload is cancelled. Answered with the status.
    pub(super) fn stop_now<const N: usize>(&mut self, now_us: u64, out: &mut Outputs<N>) {
        push(out, Output::Ctrl(ExecToCtrl::Stop));
        match self.state {
            ExecState::Armed | ExecState::Running => {
                self.state = ExecState::Aborted;
                self.trial_event(now_us, TrialEventKind::Aborted, out);
                self.stream = None;
            }
            ExecState::Moving => {
                self.stream = None;
                self.goto = None;
                self.state = self.rest_state();
                self.motion_event(now_us, MotionEventKind::Stopped, out);
            }
            ExecState::Flashing => {
                self.flash.cancel();
                self.state = self.state_before_flash;
            }
            _ => {}
        }
        push(out, Output::Host(ExecToHost::Status(self.status(now_us))));
    }

    /// The state after a goto: the plan, if any, is ready to arm again.
    fn rest_state(&self) -> ExecState {
        if self.plan.is_some() { ExecState::PlanFlashed } else { ExecState::Idle }
    }
}

/// The one-step plan of a goto (no allocation: a fixed 12-byte image).
fn one_step_plan(step: &PlanStep) -> Option<FlashedPlan<GOTO_IMAGE_LEN>> {
    let image: Vec<u8, GOTO_IMAGE_LEN> = Vec::from_slice(&step.to_image_bytes()).ok()?;
    let header = FlashHeader::for_image(0, &image).ok()?;
    FlashedPlan::from_verified(header, image).ok()
}
