//! The executor's state machine: `(now_us, input)` in, messages and log records out.
//!
//! ```text
//!            FlashBegin             FlashCommit ok              Arm                 Start
//!   Idle ───────────────▶ Flashing ───────────────▶ PlanFlashed ─────▶ Armed ─────────────▶ Running
//!     ▲   (refused/abandoned upload: back to the state before, old plan intact)   │  Abort / fault
//!     │                                                                              ▼
//!     └─ Done | Aborted | Faulted ◀── all segments done / Abort / fault ─────────────┘
//!        (plan kept: Arm again, or FlashBegin a new one)
//! ```
//!
//! Every command not valid in the current state is answered with
//! `CommandRejected(WrongState { state })`; commands before a compatible `Hello` with
//! `Incompatible`. Host commands are handled in `machine/host.rs`, controller messages and camera
//! frames in `machine/ctrl.rs`; this module holds the state, the timers (heartbeats, clock-sync
//! queries, watchdogs, streaming) and the fault path. Watchdog bound: a silent controller or
//! host is detected at the first call after `ctrl_silence_us` / `host_silence_us`;
//! [`Executor::next_deadline_us`] says when that is, so a shell that wakes then commands the
//! stop within the bound plus its own wake-up latency.

mod ctrl;
mod host;
mod motion;

use crate::camera::FrameStamper;
use crate::config::ExecutorConfig;
use crate::error::ExecError;
use crate::io::{Input, LogEvent, MIN_FREE_OUTPUTS, Output, Outputs};
use crate::plan::FlashedPlan;
use crate::store::{PlanStore, load_plan};
use crate::stream::{StreamPoll, Streamer};
use crate::sync::ClockSync;
use mesopush_protocol::ctrl::{CtrlStatus, PositionReport};
use mesopush_protocol::host::{
    ExecState, ExecStatus, MotionEvent, MotionEventKind, StagePoint, TrialEvent, TrialEventKind,
    TrialFault,
};
use mesopush_protocol::{ExecToCtrl, ExecToHost};

/// Position reports kept for stamping frames (at the controller's 100 Hz, 160 ms: a frame
/// may arrive that long after its exposure and still be interpolated).
pub const POSITION_HISTORY: usize = 16;

/// The executor core: plan memory `CAP` bytes (×2: the stored plan and an upload's staging
/// buffer), look-ahead queue `LA` segments, plan store `S`.
#[derive(Debug)]
pub struct Executor<S, const CAP: usize, const LA: usize> {
    config: ExecutorConfig,
    store: S,
    state: ExecState,
    state_before_flash: ExecState,
    hello_ok: bool,
    plan: Option<FlashedPlan<CAP>>,
    /// The one-step plan of a goto or home in progress (state `Moving`).
    goto: Option<FlashedPlan<{ motion::GOTO_IMAGE_LEN }>>,
    flash: crate::flash::FlashSession<CAP>,
    sync: ClockSync,
    stream: Option<Streamer<LA>>,
    segments_sent: u64,
    stamper: FrameStamper,
    last_fault: Option<TrialFault>,
    trial_plan_id: u32,
    ctrl_last_heard_us: Option<u64>,
    host_last_heard_us: Option<u64>,
    ctrl_status: Option<CtrlStatus>,
    positions: heapless::Deque<PositionReport, POSITION_HISTORY>,
    next_heartbeat_us: u64,
    next_segment_id: u32,
    last_now_us: u64,
    startup_issue: Option<crate::io::Refusal>,
}

impl<S: PlanStore, const CAP: usize, const LA: usize> Executor<S, CAP, LA> {
    /// Start-up: validates `config` and loads the stored plan, if any (state `PlanFlashed`).
    /// A stored plan that cannot be read, no longer verifies or fails the safety check of
    /// this configuration is not used; [`Self::startup_issue`] says why.
    pub fn new(config: ExecutorConfig, mut store: S) -> Result<Self, ExecError> {
        config.validate()?;
        let (plan, startup_issue) = match load_plan::<CAP>(&mut store) {
            Ok(Some(plan)) => match crate::safety::check_plan(&plan, &config) {
                Ok(()) => (Some(plan), None),
                Err(v) => (None, Some(crate::io::Refusal::Safety(v))),
            },
            Ok(None) => (None, None),
            Err(e) => (None, Some(crate::io::Refusal::Store(e))),
        };
        let state = if plan.is_some() { ExecState::PlanFlashed } else { ExecState::Idle };
        Ok(Self {
            config,
            store,
            state,
            state_before_flash: state,
            hello_ok: false,
            plan,
            goto: None,
            flash: crate::flash::FlashSession::new(),
            sync: ClockSync::new(),
            stream: None,
            segments_sent: 0,
            stamper: FrameStamper::new(),
            last_fault: None,
            trial_plan_id: 0,
            ctrl_last_heard_us: None,
            host_last_heard_us: None,
            ctrl_status: None,
            positions: heapless::Deque::new(),
            next_heartbeat_us: 0,
            next_segment_id: 1,
            last_now_us: 0,
            startup_issue,
        })
    }

    /// Why the stored plan was not loaded at start-up, if it was not.
    pub fn startup_issue(&self) -> Option<crate::io::Refusal> {
        self.startup_issue
    }

    /// Life-cycle state.
    pub fn state(&self) -> ExecState {
        self.state
    }

    /// The stored plan.
    pub fn plan(&self) -> Option<&FlashedPlan<CAP>> {
        self.plan.as_ref()
    }

    /// The configuration.
    pub fn config(&self) -> &ExecutorConfig {
        &self.config
    }

    /// The plan store.
    pub fn store(&self) -> &S {
        &self.store
    }

    /// The plan store, mutably (for a shell's maintenance, and tests).
    pub fn store_mut(&mut self) -> &mut S {
        &mut self.store
    }

    /// The latest controller position report.
    pub fn latest_position(&self) -> Option<PositionReport> {
        self.positions.back().copied()
    }

    /// Clock sync with the controller.
    pub fn clock_sync(&self) -> &ClockSync {
        &self.sync
    }

    /// Frame counters (stamped, dropped, black).
    pub fn frames(&self) -> &FrameStamper {
        &self.stamper
    }

    /// Status snapshot at `now_us`.
    pub fn status(&self, now_us: u64) -> ExecStatus {
        let step_count = self.plan.as_ref().map_or(0, |p| p.step_count());
        let step_index = match (&self.stream, self.state) {
            (_, ExecState::Moving) => 0,
            (Some(s), _) => s.step_index(),
            (None, ExecState::Done) => step_count,
            _ => 0,
        };
        ExecStatus {
            exec_time_us: now_us,
            state: self.state,
            plan_id: self.plan.as_ref().map(|p| p.plan_id()),
            step_count,
            step_index,
            last_fault: self.last_fault,
            probe: self.latest_position().map(|p| StagePoint { x_nm: p.x_nm, y_nm: p.y_nm }),
            ctrl_state: self.ctrl_status.map(|s| s.state),
        }
    }

    /// Whether the probe is being moved (a trial armed or running, or a goto).
    fn in_motion(&self) -> bool {
        matches!(self.state, ExecState::Armed | ExecState::Running | ExecState::Moving)
    }

    /// Whether moves are streaming (a trial running or a goto).
    fn streaming(&self) -> bool {
        matches!(self.state, ExecState::Running | ExecState::Moving)
    }

    /// When [`Self::handle`] must next be called (with [`Input::Tick`]) if nothing arrives,
    /// µs in the executor's clock.
    pub fn next_deadline_us(&self) -> u64 {
        let mut t = self.next_heartbeat_us.min(self.sync_deadline_us());
        if self.in_motion() {
            let heard = self.ctrl_last_heard_us.unwrap_or(self.last_now_us);
            t = t.min(heard + self.config.ctrl_silence_us + 1);
        }
        if self.streaming() {
            let heard = self.host_last_heard_us.unwrap_or(self.last_now_us);
            t = t.min(heard + self.config.host_silence_us + 1);
            t = t.min(self.last_now_us + self.config.setpoint_period_us() / 4);
            if let Some(due) = self.next_send_due_us() {
                t = t.min(due);
            }
        }
        t
    }

    /// When the next segment is due to go out, µs in the executor's clock (its send schedule,
    /// [`Streamer::send_due_ctrl_us`] converted with the clock-sync offset); `None` when not
    /// running, nothing is waiting or flow control holds it. Already past when the shell is
    /// behind.
    pub fn next_send_due_us(&self) -> Option<u64> {
        let due_ctrl_us = self.stream.as_ref()?.send_due_ctrl_us(&self.config)?;
        self.sync.to_exec_us(due_ctrl_us)
    }

    /// Segments handed to the controller link since start-up (all trials).
    pub fn segments_sent(&self) -> u64 {
        self.segments_sent
    }

    fn sync_deadline_us(&self) -> u64 {
        // Queries are at most every quarter interval; waking then is enough.
        self.last_now_us + self.config.sync_interval_us / 4
    }

    /// Handles one input at `now_us` (executor clock, never decreasing), appending outputs
    /// to `out`, which needs [`MIN_FREE_OUTPUTS`] free slots (more let more segments out
    /// per call).
    pub fn handle<const N: usize>(
        &mut self,
        now_us: u64,
        input: Input<'_>,
        out: &mut Outputs<N>,
    ) -> Result<(), ExecError> {
        if N - out.len() < MIN_FREE_OUTPUTS {
            return Err(ExecError::OutputFull);
        }
        debug_assert!(now_us >= self.last_now_us, "executor time went backwards");
        self.last_now_us = self.last_now_us.max(now_us);
        match input {
            Input::Host(msg) => self.on_host(now_us, msg, out),
            Input::Ctrl(msg) => self.on_ctrl(now_us, msg, out),
            Input::Frame(frame) => self.on_frame(now_us, &frame, out),
            Input::HostLinkDown => {
                let last_heard_exec_time_us = self.host_last_heard_us.unwrap_or(0);
                if self.streaming() {
                    self.fault(now_us, TrialFault::HostLinkLost { last_heard_exec_time_us }, out);
                }
            }
            Input::CtrlLinkDown => {
                let last_heard_exec_time_us = self.ctrl_last_heard_us.unwrap_or(0);
                if self.in_motion() {
                    let fault = TrialFault::ControllerSilent { last_heard_exec_time_us };
                    self.fault(now_us, fault, out);
                }
            }
            Input::Tick => {}
        }
        self.poll_timers(now_us, out);
        Ok(())
    }

    fn poll_timers<const N: usize>(&mut self, now_us: u64, out: &mut Outputs<N>) {
        if now_us >= self.next_heartbeat_us {
            push(out, Output::Ctrl(ExecToCtrl::Heartbeat { exec_time_us: now_us }));
            self.next_heartbeat_us = now_us + self.config.heartbeat_interval_us;
        }
        if let Some(query_id) = self.sync.poll_query(now_us, &self.config) {
            push(out, Output::Ctrl(ExecToCtrl::ClockSyncQuery { query_id }));
        }
        self.watchdog(now_us, out);
        if self.streaming() {
            self.stream(now_us, out);
        }
    }

    fn watchdog<const N: usize>(&mut self, now_us: u64, out: &mut Outputs<N>) {
        if !self.in_motion() {
            return;
        }
        let ctrl_heard = self.ctrl_last_heard_us.unwrap_or(0);
        if now_us.saturating_sub(ctrl_heard) > self.config.ctrl_silence_us {
            let fault = TrialFault::ControllerSilent { last_heard_exec_time_us: ctrl_heard };
            return self.fault(now_us, fault, out);
        }
        if !self.streaming() {
            return;
        }
        let host_heard = self.host_last_heard_us.unwrap_or(0);
        if now_us.saturating_sub(host_heard) > self.config.host_silence_us {
            let fault = TrialFault::HostLinkLost { last_heard_exec_time_us: host_heard };
            return self.fault(now_us, fault, out);
        }
        if !self.sync.is_synced(now_us, &self.config) {
            self.fault(now_us, TrialFault::ClockSyncLost, out);
        }
    }

    fn stream<const N: usize>(&mut self, now_us: u64, out: &mut Outputs<N>) {
        let Some(now_ctrl_us) = self.sync.to_ctrl_us(now_us) else {
            return self.fault(now_us, TrialFault::ClockSyncLost, out);
        };
        // Keep MIN_FREE_OUTPUTS - 1 slots for a fault's outputs.
        while N - out.len() >= MIN_FREE_OUTPUTS {
            let Some(stream) = self.stream.as_mut() else { return };
            let polled = match (self.state, &self.goto, &self.plan) {
                (ExecState::Moving, Some(goto), _) => stream.poll(goto, &self.config, now_ctrl_us),
                (ExecState::Running, _, Some(plan)) => stream.poll(plan, &self.config, now_ctrl_us),
                _ => return,
            };
            match polled {
                StreamPoll::Send(segment) => {
                    push(out, Output::Ctrl(ExecToCtrl::Move(segment)));
                    stream.sent();
                    self.segments_sent += 1;
                }
                StreamPoll::Wait => return,
                StreamPoll::Underrun { step_index } => {
                    let fault = TrialFault::StreamUnderrun { step_index };
                    return self.fault(now_us, fault, out);
                }
                StreamPoll::Finished if self.state == ExecState::Moving => {
                    return self.motion_arrived(now_us, out);
                }
                StreamPoll::Finished => {
                    self.stream = None;
                    self.state = ExecState::Done;
                    return self.trial_event(now_us, TrialEventKind::Done, out);
                }
            }
        }
    }

    /// Stops the trial (or goto): `Stop` to the controller, state `Faulted`, the fault
    /// recorded.
    fn fault<const N: usize>(&mut self, now_us: u64, fault: TrialFault, out: &mut Outputs<N>) {
        push(out, Output::Ctrl(ExecToCtrl::Stop));
        let moving = self.state == ExecState::Moving;
        self.state = ExecState::Faulted;
        self.last_fault = Some(fault);
        if moving {
            self.goto = None;
            self.motion_event(now_us, MotionEventKind::Faulted(fault), out);
        } else {
            self.trial_event(now_us, TrialEventKind::Faulted(fault), out);
        }
        self.stream = None;
    }

    fn motion_event<const N: usize>(
        &mut self,
        now_us: u64,
        kind: MotionEventKind,
        out: &mut Outputs<N>,
    ) {
        let event = MotionEvent { exec_time_us: now_us, kind };
        push(out, Output::Host(ExecToHost::Motion(event)));
        push(out, Output::Log(LogEvent::Motion(event)));
    }

    fn trial_event<const N: usize>(
        &mut self,
        now_us: u64,
        kind: TrialEventKind,
        out: &mut Outputs<N>,
    ) {
        let step_index = self.status(now_us).step_index;
        let event =
            TrialEvent { exec_time_us: now_us, plan_id: self.trial_plan_id, step_index, kind };
        push(out, Output::Host(ExecToHost::Trial(event)));
        push(out, Output::Log(LogEvent::Trial(event)));
    }
}

/// Appends `output`; callers keep [`MIN_FREE_OUTPUTS`] free, which bounds what one input
/// emits besides streamed segments, so this cannot overflow.
fn push<const N: usize>(out: &mut Outputs<N>, output: Output) {
    let pushed = out.push(output);
    debug_assert!(pushed.is_ok(), "output buffer overflow: MIN_FREE_OUTPUTS too small");
}
