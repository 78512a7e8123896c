//! Host commands: handshake, flashing, arm, start, abort, status.

use super::{Executor, push};
use crate::io::{LogEvent, Output, Outputs, Refusal};
use crate::safety::{SafetyViolation, check_from_start, check_plan};
use crate::store::PlanStore;
use crate::stream::Streamer;
use mesopush_protocol::flash::{FlashChunk, FlashHeader, FlashRejectReason, SafetyLimit};
use mesopush_protocol::host::{CommandRejectReason, ExecState, Hello, StagePoint, TrialEventKind};
use mesopush_protocol::{ExecToCtrl, ExecToHost, HostToExec};

/// The wire summary of a safety violation.
pub(crate) fn limit_of(v: &SafetyViolation) -> (Option<u32>, SafetyLimit) {
    match *v {
        SafetyViolation::ZeroSpeed { step_index } => (Some(step_index), SafetyLimit::ZeroSpeed),
        SafetyViolation::ZeroLength { step_index } => (Some(step_index), SafetyLimit::ZeroLength),
        SafetyViolation::SpeedTooHigh { step_index, .. } => (Some(step_index), SafetyLimit::Speed),
        SafetyViolation::AccelTooHigh { step_index, .. } => {
            (Some(step_index), SafetyLimit::Acceleration)
        }
        SafetyViolation::TooWide { .. } => (None, SafetyLimit::Workspace),
        SafetyViolation::LeavesWorkspace { step_index, .. } => (step_index, SafetyLimit::Workspace),
    }
}

impl<S: PlanStore, const CAP: usize, const LA: usize> Executor<S, CAP, LA> {
    pub(super) fn on_host<const N: usize>(
        &mut self,
        now_us: u64,
        msg: &HostToExec,
        out: &mut Outputs<N>,
    ) {
        self.host_last_heard_us = Some(now_us);
        match msg {
            HostToExec::Hello(hello) => {
                self.hello_ok = hello.is_compatible();
                let reply =
                    ExecToHost::HelloReply { hello: Hello::CURRENT, accepted: self.hello_ok };
                push(out, Output::Host(reply));
            }
            HostToExec::Heartbeat { .. } => {}
            _ if !self.hello_ok => reject(out, CommandRejectReason::Incompatible),
            HostToExec::FlashBegin(header) => self.flash_begin(header, out),
            HostToExec::FlashChunk(chunk) => self.flash_chunk(chunk, out),
            HostToExec::FlashCommit { plan_id } => self.flash_commit(*plan_id, out),
            HostToExec::Arm { plan_id, start } => self.arm(now_us, *plan_id, *start, out),
            HostToExec::Start { plan_id } => self.start(now_us, *plan_id, out),
            HostToExec::Abort if self.state == ExecState::Moving => self.stop_now(now_us, out),
            HostToExec::Abort => self.abort(now_us, out),
            HostToExec::Goto { target } => self.goto(now_us, *target, out),
            HostToExec::Home => {
                let (x_nm, y_nm) = self.config.home_nm;
                self.goto(now_us, StagePoint { x_nm, y_nm }, out)
            }
            HostToExec::Stop => self.stop_now(now_us, out),
            HostToExec::StatusQuery => {
                push(out, Output::Host(ExecToHost::Status(self.status(now_us))))
            }
        }
    }

    fn flash_begin<const N: usize>(&mut self, header: &FlashHeader, out: &mut Outputs<N>) {
        match self.state {
            ExecState::Armed | ExecState::Running | ExecState::Moving => {
                return self.wrong_state(out);
            }
            ExecState::Flashing => {}
            state => self.state_before_flash = state,
        }
        match self.flash.begin(*header) {
            Ok(()) => {
                self.state = ExecState::Flashing;
                let progress =
                    ExecToHost::FlashProgress { plan_id: header.plan_id, received_bytes: 0 };
                push(out, Output::Host(progress));
            }
            Err(reason) => self.refuse_upload(header.plan_id, Refusal::Image(reason), out),
        }
    }

    fn flash_chunk<const N: usize>(&mut self, chunk: &FlashChunk, out: &mut Outputs<N>) {
        match self.state {
            ExecState::Armed | ExecState::Running | ExecState::Moving => {
                return self.wrong_state(out);
            }
            ExecState::Flashing => {}
            _ => {
                let refusal = Refusal::Image(FlashRejectReason::NoFlashInProgress);
                return self.refuse_upload(chunk.plan_id, refusal, out);
            }
        }
        match self.flash.chunk(chunk) {
            Ok(received_bytes) => {
                let progress = ExecToHost::FlashProgress { plan_id: chunk.plan_id, received_bytes };
                push(out, Output::Host(progress));
            }
            Err(reason) => self.refuse_upload(chunk.plan_id, Refusal::Image(reason), out),
        }
    }

    // Never inlined: the committed plan (CAP bytes) is a stack temporary here; inlined, it
    // made every `handle` call reserve and probe ~100 KB of stack, not only commits.
    #[inline(never)]
    fn flash_commit<const N: usize>(&mut self, plan_id: u32, out: &mut Outputs<N>) {
        match self.state {
            ExecState::Armed | ExecState::Running | ExecState::Moving => {
                return self.wrong_state(out);
            }
            ExecState::Flashing => {}
            _ => {
                let refusal = Refusal::Image(FlashRejectReason::NoFlashInProgress);
                return self.refuse_upload(plan_id, refusal, out);
            }
        }
        let plan = match self.flash.commit(plan_id) {
            Ok(plan) => plan,
            Err(reason) => return self.refuse_upload(plan_id, Refusal::Image(reason), out),
        };
        let step_count = plan.step_count();
        if let Err(violation) = check_plan(&plan, &self.config) {
            return self.refuse_upload_of(plan_id, Refusal::Safety(violation), step_count, out);
        }
        if let Err(e) = self.store.save(plan.header(), plan.image()) {
            return self.refuse_upload_of(plan_id, Refusal::Store(e), step_count, out);
        }
        self.plan = Some(plan);
        self.state = ExecState::PlanFlashed;
        self.last_fault = None;
        push(out, Output::Host(ExecToHost::FlashAccepted { plan_id, step_count }));
        push(out, Output::Log(LogEvent::PlanAccepted { plan_id, step_count }));
    }

    /// Ends the upload: back to the state before it, previous plan untouched.
    fn refuse_upload<const N: usize>(
        &mut self,
        plan_id: u32,
        refusal: Refusal,
        out: &mut Outputs<N>,
    ) {
        let step_count = self.flash.header().map_or(0, |h| h.step_count);
        self.refuse_upload_of(plan_id, refusal, step_count, out);
    }

    /// [`Self::refuse_upload`] for an upload of `step_count` steps (the step index the wire
    /// gives for violations of the plan as a whole).
    fn refuse_upload_of<const N: usize>(
        &mut self,
        plan_id: u32,
        refusal: Refusal,
        step_count: u32,
        out: &mut Outputs<N>,
    ) {
        self.flash.cancel();
        if self.state == ExecState::Flashing {
            self.state = self.state_before_flash;
        }
        let reason = match refusal {
            Refusal::Image(reason) => reason,
            Refusal::Safety(v) => {
                let (step, limit) = limit_of(&v);
                FlashRejectReason::Unsafe { step_index: step.unwrap_or(step_count), limit }
            }
            Refusal::Store(_) => FlashRejectReason::NotStored,
        };
        push(out, Output::Host(ExecToHost::FlashRejected { plan_id, reason }));
        push(out, Output::Log(LogEvent::PlanRefused { plan_id, refusal }));
    }

    fn arm<const N: usize>(
        &mut self,
        now_us: u64,
        plan_id: u32,
        start: StagePoint,
        out: &mut Outputs<N>,
    ) {
        if !matches!(
            self.state,
            ExecState::PlanFlashed | ExecState::Done | ExecState::Aborted | ExecState::Faulted
        ) {
            return self.wrong_state(out);
        }
        if self.plan.as_ref().is_none_or(|p| p.plan_id() != plan_id) {
            return self.plan_mismatch(out);
        }
        // A stated start outside the workspace can never be reached: refused before the
        // start-mismatch check, whose advice (`rig goto` there) would be wrong.
        let w = self.config.workspace;
        if !w.contains(i64::from(start.x_nm), i64::from(start.y_nm)) {
            let min = StagePoint { x_nm: w.min_x_nm, y_nm: w.min_y_nm };
            let max = StagePoint { x_nm: w.max_x_nm, y_nm: w.max_y_nm };
            return reject(out, CommandRejectReason::OutsideWorkspace { target: start, min, max });
        }
        let Some(report) = self.ready_position(now_us, out) else { return };
        let probe = StagePoint { x_nm: report.x_nm, y_nm: report.y_nm };
        let tolerance_nm = self.config.start_tolerance_nm;
        let (dx, dy) = (
            i64::from(probe.x_nm) - i64::from(start.x_nm),
            i64::from(probe.y_nm) - i64::from(start.y_nm),
        );
        if crate::plan::hypot_nm(dx, dy) > u64::from(tolerance_nm) {
            return reject(out, CommandRejectReason::StartMismatch { probe, start, tolerance_nm });
        }
        let Some(plan) = self.plan.as_ref() else { return };
        if let Err(violation) = check_from_start(plan, &self.config, (report.x_nm, report.y_nm)) {
            let (step_index, limit) = limit_of(&violation);
            reject(out, CommandRejectReason::Unsafe { step_index, limit });
            return push(out, Output::Log(LogEvent::ArmRefused { plan_id, violation }));
        }
        self.state = ExecState::Armed;
        self.last_fault = None;
        push(out, Output::Host(ExecToHost::Status(self.status(now_us))));
    }

    /// The probe's latest report when the executor can command motion now: clock synced,
    /// position known, controller not faulted (else it is asked to clear the fault and the
    /// command is refused `NotReady`; the host retries).
    pub(super) fn ready_position<const N: usize>(
        &mut self,
        now_us: u64,
        out: &mut Outputs<N>,
    ) -> Option<mesopush_protocol::ctrl::PositionReport> {
        let clock_synced = self.sync.is_synced(now_us, &self.config);
        let position = self.latest_position();
        let ctrl_ready = self
            .ctrl_status
            .is_some_and(|s| !matches!(s.state, mesopush_protocol::ctrl::CtrlState::Faulted));
        if !ctrl_ready && self.ctrl_status.is_some() {
            push(out, Output::Ctrl(ExecToCtrl::ClearFault));
        }
        if let (Some(report), true, true) = (position, clock_synced, ctrl_ready) {
            return Some(report);
        }
        let position_known = position.is_some();
        reject(out, CommandRejectReason::NotReady { clock_synced, position_known, ctrl_ready });
        None
    }

    fn start<const N: usize>(&mut self, now_us: u64, plan_id: u32, out: &mut Outputs<N>) {
        if self.state != ExecState::Armed {
            return self.wrong_state(out);
        }
        let Some(plan) = self.plan.as_ref().filter(|p| p.plan_id() == plan_id) else {
            return self.plan_mismatch(out);
        };
        let (Some(report), Some(now_ctrl_us), Some(status)) =
            (self.latest_position(), self.sync.to_ctrl_us(now_us), self.ctrl_status)
        else {
            let reason = CommandRejectReason::NotReady {
                clock_synced: self.sync.is_synced(now_us, &self.config),
                position_known: self.latest_position().is_some(),
                ctrl_ready: self.ctrl_status.is_some(),
            };
            return reject(out, reason);
        };
        let capacity = status.queue_free_slots.saturating_add(status.queue_len);
        let stream = Streamer::new(
            plan,
            &self.config,
            (report.x_nm, report.y_nm),
            now_ctrl_us + self.config.start_lead_us,
            self.next_segment_id,
            capacity,
        );
        self.next_segment_id = self.next_segment_id.wrapping_add(stream.segment_count() as u32);
        self.stream = Some(stream);
        self.trial_plan_id = plan_id;
        self.state = ExecState::Running;
        self.trial_event(now_us, TrialEventKind::Started, out);
    }

    fn abort<const N: usize>(&mut self, now_us: u64, out: &mut Outputs<N>) {
        match self.state {
            ExecState::Armed | ExecState::Running => {
                push(out, Output::Ctrl(ExecToCtrl::Stop));
                self.state = ExecState::Aborted;
                self.trial_event(now_us, TrialEventKind::Aborted, out);
                self.stream = None;
            }
            ExecState::Flashing => {
                self.flash.cancel();
                self.state = self.state_before_flash;
                push(out, Output::Host(ExecToHost::Status(self.status(now_us))));
            }
            _ => self.wrong_state(out),
        }
    }

    pub(super) fn wrong_state<const N: usize>(&self, out: &mut Outputs<N>) {
        reject(out, CommandRejectReason::WrongState { state: self.state });
    }

    fn plan_mismatch<const N: usize>(&self, out: &mut Outputs<N>) {
        let stored_plan_id = self.plan.as_ref().map(|p| p.plan_id());
        reject(out, CommandRejectReason::PlanIdMismatch { stored_plan_id });
    }
}

pub(super) fn reject<const N: usize>(out: &mut Outputs<N>, reason: CommandRejectReason) {
    push(out, Output::Host(ExecToHost::CommandRejected(reason)));
}
