//! Which request goes out next, and starting a move.
//!
//! Priority: a wanted stop; the protocol's set-up (a failed step is asked again after
//! `idle_poll_us`); a first position (again after a stop); the check of a move
//! that ended; the poll of a move that answered at once; the next queued move once its
//! start time has come; the idle position poll.

use super::{Active, PointToPointAdapter};
use crate::adapter::p2p::estimate::Profile;
use crate::adapter::p2p::{MoveReply, Protocol, Request};
use mesopush_protocol::ctrl::{CtrlState, CtrlToExec, FaultCode};

impl<P: Protocol, const Q: usize> PointToPointAdapter<P, Q> {
    /// Starts the next request, if one is due.
    pub(super) fn start_next(&mut self, now_us: u64) {
        if self.stop_wanted {
            return self.start(now_us, Request::Stop);
        }
        if self.setup_done < self.proto.setup_steps() {
            if now_us >= self.next_poll_us {
                self.start(now_us, Request::Setup(self.setup_done));
            }
            return;
        }
        if self.measured.is_none() || !self.alive {
            if now_us >= self.next_poll_us {
                self.next_poll_us = now_us + self.settings.idle_poll_us;
                self.start(now_us, Request::Position);
            }
            return;
        }
        if let Some(active) = self.active {
            return self.poll_move(now_us, active);
        }
        if self.queue.front().is_some_and(|s| s.start_ctrl_time_us <= now_us) {
            return self.begin_move(now_us);
        }
        if now_us >= self.next_poll_us && self.proto.idle_polls_safe() {
            self.next_poll_us = now_us + self.settings.idle_poll_us;
            self.start(now_us, Request::Position);
        }
    }

    /// A move in progress: check its end, or poll it.
    fn poll_move(&mut self, now_us: u64, active: Active) {
        if active.verifying {
            return self.start(now_us, Request::Position);
        }
        if self.proto.move_reply() == MoveReply::AtEnd || now_us < self.next_poll_us {
            return;
        }
        self.next_poll_us = now_us + self.settings.move_poll_us;
        let position = self.poll_position && self.proto.poll_while_moving();
        self.poll_position = !self.poll_position;
        self.start(now_us, if position { Request::Position } else { Request::Busy });
    }

    /// The queue's front segment becomes the active move (or is done at once when shorter
    /// than the device executes).
    fn begin_move(&mut self, now_us: u64) {
        let Some(segment) = self.queue.pop_front() else { return };
        let Some((_, measured)) = self.measured else { return };
        let from = self.commanded.unwrap_or(measured);
        let target = self.to_units(segment.target_x_nm, segment.target_y_nm, from[2]);
        let (lo, hi) = self.proto.travel_units();
        if target.iter().take(2).any(|t| !(lo..=hi).contains(t)) {
            return self.fault(now_us, FaultCode::BadSegment, Some(segment.segment_id));
        }
        let min = self.proto.min_move_units();
        if (0..3).all(|k| (i64::from(target[k]) - i64::from(from[k])).abs() < i64::from(min)) {
            self.last_done = Some(segment.segment_id);
            self.stats.moves_done += 1;
            let status = CtrlToExec::Status(self.status(now_us));
            return self.event(crate::adapter::AdapterEvent::Ctrl(status));
        }
        let speed_nm_s = self.proto.achieved_speed_nm_s(from, target, segment.speed_nm_s);
        self.start(now_us, Request::MoveTo { from, target, speed_nm_s: segment.speed_nm_s });
        // The move begins when its last byte is out (after the protocol's pauses).
        let began_us = now_us + self.script.iter().map(|c| c.pause_after_us).sum::<u64>();
        let profile =
            Profile { from_nm: self.to_nm(from), to_nm: self.to_nm(target), began_us, speed_nm_s };
        let deadline_us = self.move_deadline_us(began_us, profile.duration_us());
        if self.proto.move_reply() == MoveReply::AtEnd
            && let Some(flight) = self.inflight.as_mut()
        {
            flight.deadline_us = deadline_us; // its answer is the move's end
        }
        self.active = Some(Active {
            segment,
            target,
            before: measured,
            profile,
            deadline_us,
            verifying: false,
        });
        self.commanded = Some(target);
        self.state = CtrlState::Moving;
        self.next_poll_us = began_us + self.settings.move_poll_us;
    }
}
