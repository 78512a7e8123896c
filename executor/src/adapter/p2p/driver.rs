//! The point-to-point adapter: the core's segments (one per plan step, with
//! [`crate::Segmenting::PlanSteps`]) become a controller's "move to" commands, one at a time.
//!
//! - **Moves.** A segment starts at its scheduled time (the adapter answers clock-sync
//!   queries with the executor's own clock, so controller time is executor time) or when the
//!   previous move has ended, whichever is later. Its target is quantised to the device's
//!   resolution; a move shorter than the device executes is not sent (it is done at once and
//!   its distance carried into the next absolute target).
//! - **Ends.** A move that answers at its end (Sutter) ends with the answer; one that answers
//!   at once is polled ("busy?") every `move_poll_us`. Either way the position is then read
//!   and compared with the target: within `arrive_tolerance_nm` it is done; at the position it
//!   started from, the controller ignored it (`MoveIgnored`); elsewhere it stalled (`Stall`).
//!   A move not ended `move_timeout_pct` % of its duration plus `move_timeout_slack_us` after
//!   it began is checked the same way (a Sutter that ignored a move never answers).
//! - **Silence.** A non-move request unanswered within the protocol's reply timeout means the
//!   controller went silent: [`AdapterEvent::LinkDown`] (the core stops the trial), then the
//!   position is polled every `idle_poll_us` until it answers again.
//! - **Reports.** Every `report_period_us` while the controller answers: a position — the
//!   last one read, or during a move the commanded profile ([`super::estimate`]) — and the
//!   status the core's flow control reads (queue capacity `Q`).

use super::estimate::Profile;
use super::scale::{nm_to_units, units_to_nm};
use super::{MoveReply, Protocol, Request, Script};
use crate::adapter::{AdapterEvent, AdapterStats, ControllerAdapter};
use crate::plan::hypot_nm;
use heapless::Deque;
use mesopush_protocol::ExecToCtrl;
use mesopush_protocol::ctrl::{
    CtrlState, CtrlStatus, CtrlToExec, FaultCode, FaultReport, MoveSegment, PositionReport,
};

/// Events waiting for the core (periodic reports leave room for a fault and a status).
const EVENTS: usize = 8;

/// Plain-data settings of a point-to-point adapter; see [`P2pSettings::DEFAULT`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct P2pSettings {
    /// Position poll period at rest (and while the controller is silent), µs. Default 100 ms.
    pub idle_poll_us: u64,
    /// Busy/position poll period during a move that answered at once, µs. Default 30 ms
    /// (the rate of Sensapex's and acq4's drivers).
    pub move_poll_us: u64,
    /// Period of position and status reports to the core, µs. Default 10 ms (the core's
    /// camera stamping interpolates between them).
    pub report_period_us: u64,
    /// A move ending farther than this from its target has not arrived, nm. Default 500 nm
    /// (acq4's Scientifica check; Sensapex's drivers use 400 nm).
    pub arrive_tolerance_nm: u32,
    /// A move is checked this percentage of its duration after it began... Default 150 %
    /// (acq4's Sutter timeout).
    pub move_timeout_pct: u32,
    /// ...plus this, µs. Default 1 s (acq4's).
    pub move_timeout_slack_us: u64,
}

impl P2pSettings {
    /// The documented defaults.
    pub const DEFAULT: Self = Self {
        idle_poll_us: 100_000,
        move_poll_us: 30_000,
        report_period_us: 10_000,
        arrive_tolerance_nm: 500,
        move_timeout_pct: 150,
        move_timeout_slack_us: 1_000_000,
    };
}

/// A request on its way or awaiting its answer.
#[derive(Debug, Clone, Copy)]
struct InFlight {
    request: Request,
    deadline_us: u64,
}

/// The move being executed.
#[derive(Debug, Clone, Copy)]
struct Active {
    segment: MoveSegment,
    target: [i32; 3],
    before: [i32; 3],
    profile: Profile,
    deadline_us: u64,
    verifying: bool,
}

/// A point-to-point controller speaking protocol `P`, with room for `Q` queued segments.
#[derive(Debug)]
pub struct PointToPointAdapter<P, const Q: usize> {
    proto: P,
    settings: P2pSettings,
    queue: Deque<MoveSegment, Q>,
    active: Option<Active>,
    inflight: Option<InFlight>,
    script: Script,
    next_chunk: usize,
    next_chunk_us: u64,
    stop_wanted: bool,
    setup_done: u8,
    measured: Option<(u64, [i32; 3])>,
    commanded: Option<[i32; 3]>,
    alive: bool,
    state: CtrlState,
    last_done: Option<u32>,
    events: Deque<AdapterEvent, EVENTS>,
    next_report_us: u64,
    next_poll_us: u64,
    poll_position: bool,
    stats: AdapterStats,
}

mod answer;
mod next;

impl<P: Protocol, const Q: usize> PointToPointAdapter<P, Q> {
    /// An adapter speaking `proto` with `settings`.
    pub fn new(proto: P, settings: P2pSettings) -> Self {
        Self {
            proto,
            settings,
            queue: Deque::new(),
            active: None,
            inflight: None,
            script: Script::new(),
            next_chunk: 0,
            next_chunk_us: 0,
            stop_wanted: false,
            setup_done: 0,
            measured: None,
            commanded: None,
            alive: false,
            state: CtrlState::Idle,
            last_done: None,
            events: Deque::new(),
            next_report_us: 0,
            next_poll_us: 0,
            poll_position: false,
            stats: AdapterStats::default(),
        }
    }

    /// The protocol (its state).
    pub fn protocol(&self) -> &P {
        &self.proto
    }

    /// The last position read from the controller, device units (x, y, z).
    pub fn measured_units(&self) -> Option<[i32; 3]> {
        self.measured.map(|(_, p)| p)
    }

    /// Whether the controller answered its last request.
    pub fn is_alive(&self) -> bool {
        self.alive
    }

    fn event(&mut self, event: AdapterEvent) {
        if self.events.push_back(event).is_err() {
            debug_assert!(false, "p2p adapter: event queue full (drained at every call)");
        }
    }

    fn to_nm(&self, units: [i32; 3]) -> (i32, i32) {
        let per = self.proto.units_per_um();
        (units_to_nm(units[0], per), units_to_nm(units[1], per))
    }

    fn to_units(&self, x_nm: i32, y_nm: i32, z: i32) -> [i32; 3] {
        let per = self.proto.units_per_um();
        [nm_to_units(x_nm, per), nm_to_units(y_nm, per), z]
    }

    /// Distance between two device positions in the plane, nm.
    fn distance_nm(&self, a: [i32; 3], b: [i32; 3]) -> u64 {
        let (pa, pb) = (self.to_nm(a), self.to_nm(b));
        hypot_nm(i64::from(pa.0) - i64::from(pb.0), i64::from(pa.1) - i64::from(pb.1))
    }

    /// The probe's position now: the estimate along a running move, else the last read.
    fn position_now(&self, now_us: u64) -> Option<(i32, i32)> {
        match (&self.active, self.measured) {
            (Some(a), Some((t, _))) if !a.verifying && t < a.profile.began_us => {
                Some(a.profile.at(now_us))
            }
            (_, Some((_, p))) => Some(self.to_nm(p)),
            (_, None) => None,
        }
    }

    fn status(&self, now_us: u64) -> CtrlStatus {
        let busy = self.queue.len() + usize::from(self.active.is_some());
        CtrlStatus {
            ctrl_time_us: now_us,
            state: self.state,
            queue_free_slots: u16::try_from(Q.saturating_sub(busy)).unwrap_or(u16::MAX),
            queue_len: u16::try_from(busy).unwrap_or(u16::MAX),
            last_done_segment_id: self.last_done,
        }
    }

    fn report(&mut self, now_us: u64) {
        if self.events.len() + 4 > EVENTS {
            return; // not drained since: the next report says the same, newer
        }
        if let Some((x_nm, y_nm)) = self.position_now(now_us) {
            let active_segment_id = self.active.map(|a| a.segment.segment_id);
            let report = PositionReport { ctrl_time_us: now_us, x_nm, y_nm, active_segment_id };
            self.event(AdapterEvent::Ctrl(CtrlToExec::Position(report)));
        }
        self.event(AdapterEvent::Ctrl(CtrlToExec::Status(self.status(now_us))));
    }

    /// Stops on a fault: the core is told, the queue flushed, the device stopped.
    fn fault(&mut self, now_us: u64, code: FaultCode, segment_id: Option<u32>) {
        let (x_nm, y_nm) = self.position_now(now_us).unwrap_or((0, 0));
        let report = FaultReport { ctrl_time_us: now_us, code, segment_id, x_nm, y_nm };
        self.event(AdapterEvent::Ctrl(CtrlToExec::Fault(report)));
        self.queue.clear();
        self.active = None;
        self.commanded = None;
        self.state = CtrlState::Faulted;
        self.stop_wanted = true;
    }

    fn on_command(&mut self, now_us: u64, msg: &ExecToCtrl) {
        match *msg {
            ExecToCtrl::Move(segment) => {
                if self.state == CtrlState::Faulted {
                    return;
                }
                if self.queue.push_back(segment).is_err() {
                    self.fault(now_us, FaultCode::QueueOverflow, Some(segment.segment_id));
                }
            }
            ExecToCtrl::Stop => self.stop(now_us),
            ExecToCtrl::ClockSyncQuery { query_id } if self.alive => {
                let reply = CtrlToExec::ClockSyncReply { query_id, ctrl_time_us: now_us };
                self.event(AdapterEvent::Ctrl(reply));
            }
            ExecToCtrl::StatusQuery if self.alive => {
                self.event(AdapterEvent::Ctrl(CtrlToExec::Status(self.status(now_us))));
            }
            ExecToCtrl::ClearFault if self.state == CtrlState::Faulted => {
                self.state = CtrlState::Idle;
            }
            _ => {}
        }
    }

    /// `Stop`: the queue is flushed and the device stopped, interrupting a move in progress.
    fn stop(&mut self, now_us: u64) {
        self.queue.clear();
        if self.active.take().is_some() {
            self.commanded = None; // where it stops is read back
            self.stop_wanted = true;
            if matches!(self.inflight, Some(InFlight { request: Request::MoveTo { .. }, .. })) {
                self.inflight = None;
                self.proto.reset_receiver();
                self.start(now_us, Request::Stop);
            }
        }
        if self.state != CtrlState::Faulted {
            self.state = CtrlState::Stopped;
        }
    }

    /// Sends `request` now.
    fn start(&mut self, now_us: u64, request: Request) {
        self.script.clear();
        self.proto.encode(&request, &mut self.script);
        self.next_chunk = 0;
        self.next_chunk_us = now_us;
        let pauses_us: u64 = self.script.iter().map(|c| c.pause_after_us).sum();
        let deadline_us = now_us + pauses_us + self.proto.reply_timeout_us();
        self.inflight = Some(InFlight { request, deadline_us });
    }

    /// When a poll will go out with nothing in flight: a move's poll (protocols answering at
    /// once), or the idle poll where it is safe or the controller must be found again;
    /// `None` when none will (a move answering at its end, or no idle polls). A wanted stop,
    /// a set-up step or a check goes out at the next call anyway.
    fn poll_due_us(&self) -> Option<u64> {
        if self.stop_wanted {
            return Some(0);
        }
        let found = self.measured.is_some() && self.alive;
        match self.active {
            Some(a) if a.verifying => Some(0),
            Some(_) if self.proto.move_reply() == MoveReply::AtOnce => Some(self.next_poll_us),
            Some(_) => None,
            None if !found || self.proto.idle_polls_safe() => Some(self.next_poll_us),
            None => None,
        }
    }

    /// The move's deadline: `move_timeout_pct` % of its duration plus the slack after `began_us`.
    fn move_deadline_us(&self, began_us: u64, duration_us: u64) -> u64 {
        let scaled = duration_us.saturating_mul(u64::from(self.settings.move_timeout_pct)) / 100;
        began_us + scaled + self.settings.move_timeout_slack_us
    }
}

impl<P: Protocol, const Q: usize> ControllerAdapter for PointToPointAdapter<P, Q> {
    fn command(&mut self, now_us: u64, msg: &ExecToCtrl) {
        self.on_command(now_us, msg);
    }

    fn receive(&mut self, now_us: u64, bytes: &[u8]) -> usize {
        if let Some(reply) = self.proto.unsolicited(bytes) {
            self.on_unsolicited(now_us, reply);
            return bytes.len();
        }
        let Some(flight) = self.inflight else {
            self.stats.unreadable += 1; // unasked-for bytes: a stray terminator
            return bytes.len();
        };
        let decoded = self.proto.decode(&flight.request, bytes);
        if let Some(reply) = decoded.reply {
            self.inflight = None;
            self.on_reply(now_us, flight.request, reply);
        }
        decoded.consumed.max(1).min(bytes.len())
    }

    fn poll(&mut self, now_us: u64) {
        if let Some(flight) = self.inflight
            && now_us > flight.deadline_us
        {
            self.inflight = None;
            self.on_timeout(now_us, flight.request);
        }
        if self.inflight.is_none() {
            self.start_next(now_us);
        }
        if now_us >= self.next_report_us {
            if self.alive {
                self.report(now_us);
            }
            self.next_report_us = now_us + self.settings.report_period_us;
        }
    }

    fn next_event(&mut self) -> Option<AdapterEvent> {
        self.events.pop_front()
    }

    fn transmit<'b>(&mut self, now_us: u64, buf: &'b mut [u8]) -> Option<&'b [u8]> {
        let chunk = self.script.get(self.next_chunk)?;
        if now_us < self.next_chunk_us || chunk.bytes.len() > buf.len() {
            return None;
        }
        let n = chunk.bytes.len();
        buf[..n].copy_from_slice(&chunk.bytes);
        self.next_chunk_us = now_us + chunk.pause_after_us;
        self.next_chunk += 1;
        Some(&buf[..n])
    }

    fn next_deadline_us(&self) -> Option<u64> {
        let mut t = self.next_report_us;
        if self.next_chunk < self.script.len() {
            t = t.min(self.next_chunk_us);
        }
        if let Some(f) = self.inflight {
            // Waiting for an answer: nothing else goes out before it, or its deadline.
            return Some(t.min(f.deadline_us + 1));
        }
        if let Some(poll_us) = self.poll_due_us() {
            t = t.min(poll_us);
        }
        if self.active.is_none()
            && let Some(front) = self.queue.front()
        {
            t = t.min(front.start_ctrl_time_us);
        }
        Some(t)
    }

    fn stats(&self) -> AdapterStats {
        self.stats
    }
}
