//! The motion-controller firmware as a sans-IO state machine in controller time.
//!
//! Fed delivered messages ([`Controller::handle`]) and time ([`Controller::tick`], both with
//! `now_ctrl_us`), it emits [`CtrlOutput`]s: messages for the executor and events for the
//! simulation log. Segments wait in a bounded queue (`Q` slots, `queue_capacity` used) and
//! start at their `start_ctrl_time_us`; the commanded position moves linearly from the
//! previous target to the segment's target at the segment's speed, and the [`Stage`]
//! follows it. Faults (the stage stops, the queue is flushed, `Faulted` until `ClearFault`):
//! - `QueueOverflow`: a move arrived with the queue full;
//! - `BadSegment`: zero or excessive speed, or a target outside the travel;
//! - `QueueUnderrun`: a segment that continues the previous one without a gap was dequeued
//!   more than `late_tolerance_us` late: the queue had run dry mid-motion;
//! - `SegmentLate`: any other segment dequeued that late;
//! - `Stall`: following error above `stall_error_nm`; `LimitSwitch`: the stage left the
//!   travel (or a switch tripped, injected); `ExecutorSilent`: no message while moving for
//!   `executor_silence_us`; `Reboot`: reported by a freshly booted controller;
//! - `NeedleOverload`: the needle's sensed deflection ([`Controller::sense_needle`]) above
//!   `needle_deflection_limit_nm`. One fault per episode: the check re-arms only once the
//!   deflection has fallen to half the limit, so after `ClearFault` the probe can be backed
//!   off a wedged peg without faulting again on the way.

use crate::config::CtrlConfig;
use crate::stage::Stage;
use heapless::Deque;
use mesopush_protocol::ctrl::{
    CtrlState, CtrlStatus, CtrlToExec, ExecToCtrl, FaultCode, FaultReport, MoveSegment,
    PositionReport,
};

/// Something that happened in the controller, for the simulation log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CtrlEvent {
    /// A segment was queued.
    Queued(u32),
    /// A segment started executing.
    Started(u32),
    /// A segment finished (its target commanded).
    Applied(u32),
    /// The controller faulted.
    Faulted(FaultCode),
    /// A move arrived while faulted and was ignored.
    Ignored(u32),
    /// Stopped on request.
    Stopped,
    /// A fault was cleared.
    Cleared,
}

/// An output of the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CtrlOutput {
    /// Send to the executor.
    Msg(CtrlToExec),
    /// Log.
    Event(CtrlEvent),
}

#[derive(Debug, Clone, Copy)]
struct Active {
    seg: MoveSegment,
    from_nm: (f64, f64),
    dur_us: u64,
}

/// The controller with a `Q`-slot segment queue.
#[derive(Debug)]
pub struct Controller<const Q: usize> {
    cfg: CtrlConfig,
    state: CtrlState,
    queue: Deque<MoveSegment, Q>,
    active: Option<Active>,
    cmd_nm: (f64, f64),
    cmd_vel_nm_s: (f64, f64),
    stage: Stage,
    last_done: Option<u32>,
    prev_end_ctrl_us: Option<u64>,
    last_heard_us: u64,
    servo_us: u64,
    next_report_us: u64,
    next_status_us: u64,
    next_heartbeat_us: u64,
    limit_tripped: bool,
    /// The needle check may fault (re-armed below half the limit after a fault).
    needle_armed: bool,
}

impl<const Q: usize> Controller<Q> {
    /// Booted at `now_ctrl_us` with the probe at `pos_nm`; `rebooted` starts it faulted
    /// with a `Reboot` report (a controller that lost its state must say so).
    pub fn boot(
        cfg: CtrlConfig,
        now_ctrl_us: u64,
        pos_nm: (f64, f64),
        rebooted: bool,
        out: &mut impl FnMut(CtrlOutput),
    ) -> Self {
        let mut c = Self {
            cfg,
            state: CtrlState::Idle,
            queue: Deque::new(),
            active: None,
            cmd_nm: pos_nm,
            cmd_vel_nm_s: (0.0, 0.0),
            stage: Stage::at(pos_nm),
            last_done: None,
            prev_end_ctrl_us: None,
            last_heard_us: now_ctrl_us,
            servo_us: now_ctrl_us,
            next_report_us: now_ctrl_us,
            next_status_us: now_ctrl_us,
            next_heartbeat_us: now_ctrl_us,
            limit_tripped: false,
            needle_armed: true,
        };
        if rebooted {
            c.fault(now_ctrl_us, FaultCode::Reboot, None, out);
        }
        c
    }

    /// Motion state.
    pub fn state(&self) -> CtrlState {
        self.state
    }

    /// The stage (true position).
    pub fn stage(&self) -> &Stage {
        &self.stage
    }

    /// Segments queued or executing.
    pub fn queue_len(&self) -> u16 {
        (self.queue.len() + usize::from(self.active.is_some())) as u16
    }

    /// Injects a stall: the stage stops following.
    pub fn inject_stall(&mut self) {
        self.stage.stalled = true;
    }

    /// Injects a limit-switch trip.
    pub fn inject_limit_switch(&mut self) {
        self.limit_tripped = true;
    }

    /// The needle's deflection sensed at `now_ctrl_us`, nm: faults `NeedleOverload` when it
    /// exceeds `needle_deflection_limit_nm` (strictly) while the check is armed and the
    /// controller is not already faulted. No limit configured: nothing happens.
    pub fn sense_needle(
        &mut self,
        now_ctrl_us: u64,
        deflection_nm: i32,
        out: &mut impl FnMut(CtrlOutput),
    ) {
        let Some(limit) = self.cfg.needle_deflection_limit_nm else { return };
        if deflection_nm <= limit / 2 {
            self.needle_armed = true;
        }
        if deflection_nm > limit && self.needle_armed && self.state != CtrlState::Faulted {
            self.needle_armed = false;
            let segment_id = self.active.map(|a| a.seg.segment_id);
            self.fault(now_ctrl_us, FaultCode::NeedleOverload, segment_id, out);
        }
    }

    /// A message from the executor.
    pub fn handle(&mut self, now_ctrl_us: u64, msg: &ExecToCtrl, out: &mut impl FnMut(CtrlOutput)) {
        self.last_heard_us = now_ctrl_us;
        match *msg {
            ExecToCtrl::Move(seg) => self.on_move(now_ctrl_us, seg, out),
            ExecToCtrl::Stop => {
                self.halt();
                if self.state != CtrlState::Faulted {
                    self.state = CtrlState::Stopped;
                }
                out(CtrlOutput::Event(CtrlEvent::Stopped));
            }
            ExecToCtrl::ClockSyncQuery { query_id } => {
                let reply = CtrlToExec::ClockSyncReply { query_id, ctrl_time_us: now_ctrl_us };
                out(CtrlOutput::Msg(reply));
            }
            ExecToCtrl::StatusQuery => out(CtrlOutput::Msg(self.status(now_ctrl_us))),
            ExecToCtrl::Heartbeat { .. } => {}
            ExecToCtrl::ClearFault => {
                if self.state == CtrlState::Faulted {
                    self.state = CtrlState::Idle;
                    self.stage.stalled = false;
                    self.limit_tripped = false;
                    out(CtrlOutput::Event(CtrlEvent::Cleared));
                }
            }
        }
    }

    fn on_move(&mut self, now: u64, seg: MoveSegment, out: &mut impl FnMut(CtrlOutput)) {
        if self.state == CtrlState::Faulted {
            return out(CtrlOutput::Event(CtrlEvent::Ignored(seg.segment_id)));
        }
        let speed_ok = seg.speed_nm_s > 0 && f64::from(seg.speed_nm_s) <= self.cfg.max_speed_nm_s;
        if !speed_ok
            || !self.within_travel((f64::from(seg.target_x_nm), f64::from(seg.target_y_nm)))
        {
            return self.fault(now, FaultCode::BadSegment, Some(seg.segment_id), out);
        }
        if self.queue_len() >= self.cfg.queue_capacity || self.queue.push_back(seg).is_err() {
            return self.fault(now, FaultCode::QueueOverflow, Some(seg.segment_id), out);
        }
        if self.state != CtrlState::Moving {
            self.state = CtrlState::Moving;
        }
        out(CtrlOutput::Event(CtrlEvent::Queued(seg.segment_id)));
    }

    /// Advances to `now_ctrl_us` in servo periods, emitting reports when due.
    pub fn tick(&mut self, now_ctrl_us: u64, out: &mut impl FnMut(CtrlOutput)) {
        let period = self.cfg.servo_period_us;
        while self.servo_us + period <= now_ctrl_us {
            self.servo_us += period;
            self.servo_step(self.servo_us, out);
        }
        self.reports(now_ctrl_us, out);
    }

    fn servo_step(&mut self, t: u64, out: &mut impl FnMut(CtrlOutput)) {
        self.advance_segments(t, out);
        let dt_s = self.cfg.servo_period_us as f64 * 1e-6;
        self.stage.step(self.cmd_nm, self.cmd_vel_nm_s, dt_s, &self.cfg);
        if self.state == CtrlState::Faulted {
            return;
        }
        let segment_id = self.active.map(|a| a.seg.segment_id);
        if self.stage.following_error_nm(self.cmd_nm) > self.cfg.stall_error_nm {
            self.fault(t, FaultCode::Stall, segment_id, out);
        } else if self.limit_tripped || !self.within_travel(self.stage.pos_nm) {
            self.fault(t, FaultCode::LimitSwitch, segment_id, out);
        } else if self.state == CtrlState::Moving
            && t.saturating_sub(self.last_heard_us) > self.cfg.executor_silence_us
        {
            self.fault(t, FaultCode::ExecutorSilent, segment_id, out);
        }
    }

    /// Finishes, starts and interpolates segments at servo time `t`.
    fn advance_segments(&mut self, t: u64, out: &mut impl FnMut(CtrlOutput)) {
        loop {
            if let Some(a) = self.active {
                let end = a.seg.start_ctrl_time_us + a.dur_us;
                if t < end {
                    let f = (t - a.seg.start_ctrl_time_us) as f64 / a.dur_us as f64;
                    let target = (f64::from(a.seg.target_x_nm), f64::from(a.seg.target_y_nm));
                    let d = (target.0 - a.from_nm.0, target.1 - a.from_nm.1);
                    self.cmd_nm = (a.from_nm.0 + d.0 * f, a.from_nm.1 + d.1 * f);
                    let per_s = 1e6 / a.dur_us as f64;
                    self.cmd_vel_nm_s = (d.0 * per_s, d.1 * per_s);
                    return;
                }
                self.cmd_nm = (f64::from(a.seg.target_x_nm), f64::from(a.seg.target_y_nm));
                self.cmd_vel_nm_s = (0.0, 0.0);
                self.last_done = Some(a.seg.segment_id);
                self.prev_end_ctrl_us = Some(end);
                self.active = None;
                out(CtrlOutput::Event(CtrlEvent::Applied(a.seg.segment_id)));
            }
            let Some(&next) = self.queue.front() else {
                if self.state == CtrlState::Moving {
                    self.state = CtrlState::Idle;
                }
                return;
            };
            if t < next.start_ctrl_time_us {
                return;
            }
            self.queue.pop_front();
            if t > next.start_ctrl_time_us + self.cfg.late_tolerance_us {
                let tol = self.cfg.late_tolerance_us;
                let continues =
                    self.prev_end_ctrl_us.is_some_and(|end| next.start_ctrl_time_us <= end + tol);
                let code =
                    if continues { FaultCode::QueueUnderrun } else { FaultCode::SegmentLate };
                return self.fault(t, code, Some(next.segment_id), out);
            }
            self.start_segment(next, out);
        }
    }

    fn start_segment(&mut self, seg: MoveSegment, out: &mut impl FnMut(CtrlOutput)) {
        let target = (f64::from(seg.target_x_nm), f64::from(seg.target_y_nm));
        let len = (target.0 - self.cmd_nm.0).hypot(target.1 - self.cmd_nm.1);
        let dur_us = ((len * 1e6 / f64::from(seg.speed_nm_s)).ceil() as u64).max(1);
        self.active = Some(Active { seg, from_nm: self.cmd_nm, dur_us });
        out(CtrlOutput::Event(CtrlEvent::Started(seg.segment_id)));
    }

    fn reports(&mut self, now: u64, out: &mut impl FnMut(CtrlOutput)) {
        if now >= self.next_report_us {
            self.next_report_us = now + self.cfg.report_period_us;
            let (x_nm, y_nm) = self.stage.reported_nm(self.cfg.resolution_nm);
            let active_segment_id = self.active.map(|a| a.seg.segment_id);
            let report = PositionReport { ctrl_time_us: now, x_nm, y_nm, active_segment_id };
            out(CtrlOutput::Msg(CtrlToExec::Position(report)));
        }
        if now >= self.next_status_us {
            self.next_status_us = now + self.cfg.status_period_us;
            out(CtrlOutput::Msg(self.status(now)));
        }
        if now >= self.next_heartbeat_us {
            self.next_heartbeat_us = now + self.cfg.heartbeat_period_us;
            out(CtrlOutput::Msg(CtrlToExec::Heartbeat { ctrl_time_us: now }));
        }
    }

    fn status(&self, now: u64) -> CtrlToExec {
        let queue_len = self.queue_len();
        CtrlToExec::Status(CtrlStatus {
            ctrl_time_us: now,
            state: self.state,
            queue_free_slots: self.cfg.queue_capacity.saturating_sub(queue_len),
            queue_len,
            last_done_segment_id: self.last_done,
        })
    }

    fn within_travel(&self, p: (f64, f64)) -> bool {
        let t = self.cfg.travel_nm.map(f64::from);
        (t[0]..=t[1]).contains(&p.0) && (t[2]..=t[3]).contains(&p.1)
    }

    /// Flushes the queue and holds the stage where it is.
    fn halt(&mut self) {
        self.queue.clear();
        self.active = None;
        self.cmd_nm = self.stage.pos_nm;
        self.cmd_vel_nm_s = (0.0, 0.0);
    }

    fn fault(
        &mut self,
        now: u64,
        code: FaultCode,
        segment_id: Option<u32>,
        out: &mut impl FnMut(CtrlOutput),
    ) {
        self.halt();
        self.state = CtrlState::Faulted;
        let (x_nm, y_nm) = self.stage.reported_nm(self.cfg.resolution_nm);
        let report = FaultReport { ctrl_time_us: now, code, segment_id, x_nm, y_nm };
        out(CtrlOutput::Msg(CtrlToExec::Fault(report)));
        out(CtrlOutput::Event(CtrlEvent::Faulted(code)));
    }
}
