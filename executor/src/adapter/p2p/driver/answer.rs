//! What the controller answered (or did not): positions, ends of moves, the check of each
//! move's end against its target, and the silence of a controller that stopped answering.

use super::{Active, PointToPointAdapter};
use crate::adapter::AdapterEvent;
use crate::adapter::p2p::{MoveReply, Protocol, Reply, Request};
use mesopush_protocol::ctrl::{CtrlState, CtrlToExec, FaultCode};

impl<P: Protocol, const Q: usize> PointToPointAdapter<P, Q> {
    /// `reply` answered `request` at `now_us`.
    pub(super) fn on_reply(&mut self, now_us: u64, request: Request, reply: Reply) {
        self.alive = true;
        match (request, reply) {
            (_, Reply::Garbled) => self.stats.unreadable += 1, // asked again next poll
            (Request::Setup(_), Reply::DeviceError(_)) => {
                // Not done (an unsupported card, an unreadable scale): asked again after
                // `idle_poll_us`; until then no position is read and nothing moves.
                self.next_poll_us = now_us + self.settings.idle_poll_us;
            }
            (Request::Setup(_), _) => {
                self.setup_done += 1;
                if let Reply::Position(p) = reply {
                    self.note_position(now_us, p);
                }
            }
            (Request::Busy, Reply::Position(p)) => {
                // A device polled by position (no busy query): arrived when at the target.
                self.note_position(now_us, p);
                let tolerance_nm = u64::from(self.settings.arrive_tolerance_nm);
                if let Some(a) = self.active
                    && (self.distance_nm(p, a.target) <= tolerance_nm || now_us > a.deadline_us)
                {
                    self.set_verifying();
                }
            }
            (_, Reply::Position(p)) => {
                self.note_position(now_us, p);
                if let Some(active) = self.active.filter(|a| a.verifying) {
                    self.verify(now_us, active, p);
                }
            }
            (Request::Busy, Reply::Busy(busy)) => self.on_busy(now_us, busy),
            (Request::MoveTo { .. }, Reply::Arrived) => self.set_verifying(),
            (Request::MoveTo { .. }, Reply::Accepted) => {}
            (Request::MoveTo { .. }, Reply::DeviceError(_)) => {
                let id = self.active.map(|a| a.segment.segment_id);
                self.fault(now_us, FaultCode::BadSegment, id);
            }
            (Request::Stop, Reply::Accepted | Reply::Arrived) => {
                self.stop_wanted = false;
                // Where it stopped is read again (also where idle polls are unsafe).
                self.measured = None;
                if self.state == CtrlState::Moving {
                    self.state = CtrlState::Stopped;
                }
            }
            _ => self.stats.unreadable += 1,
        }
    }

    /// `request` was not answered in time.
    pub(super) fn on_timeout(&mut self, now_us: u64, request: Request) {
        self.proto.reset_receiver();
        if matches!(request, Request::MoveTo { .. }) && self.active.is_some() {
            // A move that never ended (or was ignored without an answer): read where it is.
            return self.set_verifying();
        }
        if self.alive {
            self.alive = false;
            self.stats.link_downs += 1;
            self.event(AdapterEvent::LinkDown);
        }
        // Nothing it was doing can be trusted: start again from a fresh position.
        self.queue.clear();
        self.active = None;
        self.commanded = None;
        self.measured = None;
        self.next_poll_us = now_us + self.settings.idle_poll_us;
    }

    /// A notification the device pushed.
    pub(super) fn on_unsolicited(&mut self, now_us: u64, reply: Reply) {
        match reply {
            Reply::Position(p) => self.note_position(now_us, p),
            Reply::Busy(false) => self.set_verifying(),
            _ => self.stats.unreadable += 1,
        }
    }

    fn note_position(&mut self, now_us: u64, p: [i32; 3]) {
        self.measured = Some((now_us, p));
        if self.active.is_none() && self.commanded.is_none() {
            self.commanded = Some(p);
        }
    }

    fn set_verifying(&mut self) {
        if let Some(a) = self.active.as_mut() {
            a.verifying = true;
        }
    }

    fn on_busy(&mut self, now_us: u64, busy: bool) {
        let Some(active) = self.active else { return };
        if !busy || now_us > active.deadline_us {
            self.set_verifying();
        }
    }

    /// The move ended (or should have) at `p`: done, ignored or stalled.
    fn verify(&mut self, now_us: u64, active: Active, p: [i32; 3]) {
        let tolerance_nm = u64::from(self.settings.arrive_tolerance_nm);
        let id = active.segment.segment_id;
        if self.distance_nm(p, active.target) <= tolerance_nm {
            self.active = None;
            self.last_done = Some(id);
            self.stats.moves_done += 1;
            if self.queue.is_empty() && self.state == CtrlState::Moving {
                self.state = CtrlState::Idle;
            }
            let status = CtrlToExec::Status(self.status(now_us));
            return self.event(AdapterEvent::Ctrl(status));
        }
        if now_us <= active.deadline_us && self.proto.move_reply() == MoveReply::AtOnce {
            // Said "not busy" while still settling (Scientifica): poll on until the deadline.
            if let Some(a) = self.active.as_mut() {
                a.verifying = false;
            }
            return;
        }
        let code = if self.distance_nm(p, active.before) <= tolerance_nm {
            FaultCode::MoveIgnored
        } else {
            FaultCode::Stall
        };
        self.fault(now_us, code, Some(id));
    }
}
