//! Sans-IO reliable link: ordered, exactly-once delivery over a lossy byte stream.
//!
//! Both ends of every serial line (host ↔ executor, executor ↔ controller) run this same
//! state machine. It never reads a clock or touches I/O: the caller feeds received frames
//! with [`Link::on_frame`], asks for frames to send with [`Link::poll_transmit`] and drives
//! timeouts with [`Link::poll`], passing its own `now_us`. The protocol is go-back-N:
//! data frames carry a sequence number and a cumulative ack; the receiver delivers only the
//! next expected frame, re-acks duplicates and nacks gaps and damaged frames; the sender
//! keeps at most `WINDOW` unacknowledged messages, resends all of them when the oldest times
//! out or is nacked, and declares the link down after a bounded number of timeouts without
//! progress.
//!
//! Restarts: every link instance has a session id chosen by its owner (a boot counter is
//! enough: it only has to differ from the previous life's). Frames name the sender's session
//! and the receiver's as last heard. A frame addressed to an earlier session of ours is stale:
//! it is dropped and answered with a nack that announces our session. When the peer's
//! session changes the peer has restarted: we restart our receive numbering, renumber our
//! unacknowledged messages from 0 and resend them, and count it in [`LinkStats`]. Messages
//! the old peer received but had not acknowledged are therefore delivered again to the new
//! one; nothing is lost on our side of a peer restart.

use crate::error::WireError;
use crate::frame::{Frame, FrameKind, decode_frame};
use heapless::Deque;
use serde::de::DeserializeOwned;

/// Timing and retry settings of a [`Link`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkConfig {
    /// Time after a timeout-driven (or first) transmission of the oldest unacked frame
    /// before the window is resent, µs. Nack-driven resends do not move this deadline, so a
    /// peer that keeps nacking without acking still times out. Default 20 ms: several round
    /// trips of a 1 Mbaud line with a full window.
    pub retransmit_timeout_us: u64,
    /// Minimum time between a transmission and a nack-triggered resend of the same window,
    /// µs, so a burst of nacks triggers one resend. Default 5 ms.
    pub nack_holdoff_us: u64,
    /// Consecutive retransmission timeouts of the oldest unacked frame before the link is
    /// declared down: the link goes down `max_timeouts × retransmit_timeout_us` after the
    /// first send of a frame that is never acknowledged. Default 8 (160 ms).
    pub max_timeouts: u8,
}

impl LinkConfig {
    /// The documented defaults.
    pub const DEFAULT: Self =
        Self { retransmit_timeout_us: 20_000, nack_holdoff_us: 5_000, max_timeouts: 8 };
}

impl Default for LinkConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The link gave up: a frame went unacknowledged through `max_timeouts` timeouts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkDown {
    /// Sequence number of the frame that was never acknowledged.
    pub seq: u16,
    /// Timeouts it went through.
    pub timeouts: u8,
    /// Times it was sent (timeout- and nack-driven resends included).
    pub transmissions: u8,
}

/// Counters for diagnostics and tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Messages delivered in order.
    pub delivered: u64,
    /// Data frames dropped as already delivered.
    pub duplicates: u64,
    /// Data frames dropped because an earlier one was missing.
    pub out_of_order: u64,
    /// Frames that failed to decode.
    pub corrupt: u64,
    /// Data frames sent again.
    pub retransmissions: u64,
    /// Frames addressed to an earlier session of this link, or from an earlier session of
    /// the peer, dropped.
    pub stale: u64,
    /// Times the peer's session changed (the peer restarted).
    pub peer_restarts: u64,
}

#[derive(Debug)]
struct Pending<Tx> {
    seq: u16,
    msg: Tx,
    last_sent_us: Option<u64>,
    deadline_us: Option<u64>,
    timeouts: u8,
    transmissions: u8,
    due: bool,
}

/// A reliable link sending `Tx`, receiving `Rx`, with at most `WINDOW` unacked messages.
#[derive(Debug)]
pub struct Link<Tx, Rx, const WINDOW: usize> {
    config: LinkConfig,
    session: u16,
    peer_session: Option<u16>,
    prev_peer_session: Option<u16>,
    window: Deque<Pending<Tx>, WINDOW>,
    next_tx_seq: u16,
    rx_next_seq: u16,
    ack_due: bool,
    nack_due: bool,
    nacked_at_seq: Option<u16>,
    down: Option<LinkDown>,
    last_heard_us: Option<u64>,
    stats: LinkStats,
    _rx: core::marker::PhantomData<fn() -> Rx>,
}

/// `a` comes before `b` in wrapping sequence order.
fn seq_before(a: u16, b: u16) -> bool {
    (b.wrapping_sub(a) as i16) > 0
}

impl<Tx, Rx: DeserializeOwned, const WINDOW: usize> Link<Tx, Rx, WINDOW> {
    const WINDOW_OK: () = assert!(WINDOW > 0 && WINDOW <= 1 << 14, "WINDOW must be 1..=16384");

    /// A fresh link with session id `session`, which must differ from the session of this
    /// endpoint's previous life (a boot counter will do).
    pub const fn new(config: LinkConfig, session: u16) -> Self {
        let () = Self::WINDOW_OK;
        Self {
            config,
            session,
            peer_session: None,
            prev_peer_session: None,
            window: Deque::new(),
            next_tx_seq: 0,
            rx_next_seq: 0,
            ack_due: false,
            nack_due: false,
            nacked_at_seq: None,
            down: None,
            last_heard_us: None,
            stats: LinkStats {
                delivered: 0,
                duplicates: 0,
                out_of_order: 0,
                corrupt: 0,
                retransmissions: 0,
                stale: 0,
                peer_restarts: 0,
            },
            _rx: core::marker::PhantomData,
        }
    }

    /// Queues `msg`. A full window or a down link hands it back.
    pub fn send(&mut self, msg: Tx) -> Result<(), Tx> {
        if self.down.is_some() {
            return Err(msg);
        }
        let pending = Pending {
            seq: self.next_tx_seq,
            msg,
            last_sent_us: None,
            deadline_us: None,
            timeouts: 0,
            transmissions: 0,
            due: true,
        };
        match self.window.push_back(pending) {
            Ok(()) => {
                self.next_tx_seq = self.next_tx_seq.wrapping_add(1);
                Ok(())
            }
            Err(pending) => Err(pending.msg),
        }
    }

    /// Room left in the send window.
    pub fn free_slots(&self) -> usize {
        WINDOW - self.window.len()
    }

    /// Whether every sent message has been acknowledged.
    pub fn is_idle(&self) -> bool {
        self.window.is_empty()
    }

    /// Why the link is down, if it is.
    pub fn down(&self) -> Option<LinkDown> {
        self.down
    }

    /// When a valid frame was last received, µs in the caller's clock.
    pub fn last_heard_us(&self) -> Option<u64> {
        self.last_heard_us
    }

    /// Counters since creation or the last reset.
    pub fn stats(&self) -> LinkStats {
        self.stats
    }

    /// This link's session id.
    pub fn session(&self) -> u16 {
        self.session
    }

    /// Starts a new life under `new_session` (which must differ from the current one):
    /// unsent and unacknowledged messages are dropped and numbering restarts. The peer sees
    /// the new session in the next frame (an ack is sent to announce it) and follows.
    pub fn reset(&mut self, new_session: u16) {
        let (peer_session, prev_peer_session) = (self.peer_session, self.prev_peer_session);
        *self = Self::new(self.config, new_session);
        self.peer_session = peer_session;
        self.prev_peer_session = prev_peer_session;
        self.ack_due = true;
    }

    /// Decodes `bytes` (one stuffed frame) and handles it as [`Self::on_frame`] does.
    pub fn on_bytes(&mut self, now_us: u64, bytes: &mut [u8]) -> Option<Rx> {
        let frame = decode_frame(bytes);
        self.on_frame(now_us, frame)
    }

    /// Handles a received frame, or a decode failure (answered with a nack). Returns the
    /// message to deliver, if this frame carried the next one in order.
    pub fn on_frame(&mut self, now_us: u64, frame: Result<Frame<Rx>, WireError>) -> Option<Rx> {
        let Ok(frame) = frame else {
            self.stats.corrupt += 1;
            self.request_nack();
            return None;
        };
        if frame.receiver_session.is_some_and(|s| s != self.session) {
            // Addressed to an earlier life of ours: announce the current session.
            self.stats.stale += 1;
            self.nack_due = true;
            return None;
        }
        if self.prev_peer_session == Some(frame.sender_session) {
            self.stats.stale += 1; // from the peer's previous life, delayed on the line
            return None;
        }
        match self.peer_session {
            None => self.peer_session = Some(frame.sender_session),
            Some(peer) if peer != frame.sender_session => {
                self.on_peer_restart(frame.sender_session)
            }
            Some(_) => {}
        }
        self.last_heard_us = Some(now_us);
        self.on_ack(frame.ack);
        match frame.kind {
            FrameKind::Data { seq, msg } => self.on_data(seq, msg),
            FrameKind::Ack => None,
            FrameKind::Nack => {
                self.on_nack(now_us, frame.ack);
                None
            }
        }
    }

    /// The peer restarted: restart receive numbering and resend the unacknowledged window
    /// renumbered from 0.
    fn on_peer_restart(&mut self, new_peer_session: u16) {
        self.prev_peer_session = self.peer_session;
        self.peer_session = Some(new_peer_session);
        self.stats.peer_restarts += 1;
        self.rx_next_seq = 0;
        self.nacked_at_seq = None;
        let mut seq: u16 = 0;
        for pending in self.window.iter_mut() {
            pending.seq = seq;
            pending.due = true;
            pending.transmissions = 0;
            pending.timeouts = 0;
            pending.last_sent_us = None;
            pending.deadline_us = None;
            seq = seq.wrapping_add(1);
        }
        self.next_tx_seq = seq;
    }

    fn on_data(&mut self, seq: u16, msg: Rx) -> Option<Rx> {
        if seq == self.rx_next_seq {
            self.rx_next_seq = self.rx_next_seq.wrapping_add(1);
            self.ack_due = true;
            self.stats.delivered += 1;
            Some(msg)
        } else if seq_before(seq, self.rx_next_seq) {
            self.ack_due = true;
            self.stats.duplicates += 1;
            None
        } else {
            self.stats.out_of_order += 1;
            self.request_nack();
            None
        }
    }

    /// Nacks at most once per missing sequence number; timeouts cover a lost nack.
    fn request_nack(&mut self) {
        if self.nacked_at_seq != Some(self.rx_next_seq) {
            self.nack_due = true;
        }
    }

    fn on_ack(&mut self, ack: u16) {
        if seq_before(self.next_tx_seq, ack) {
            return; // acknowledges frames never sent: stale or from another session
        }
        while self.window.front().is_some_and(|p| seq_before(p.seq, ack)) {
            self.window.pop_front();
        }
    }

    fn on_nack(&mut self, now_us: u64, ack: u16) {
        let holdoff_us = self.config.nack_holdoff_us;
        let resend = self.window.front().is_some_and(|p| {
            p.seq == ack && p.last_sent_us.is_some_and(|t| now_us.saturating_sub(t) >= holdoff_us)
        });
        if resend {
            self.mark_window_due();
        }
    }

    fn mark_window_due(&mut self) {
        for pending in self.window.iter_mut() {
            pending.due = true;
        }
    }

    /// Drives timeouts: resends the window when the oldest frame's deadline passes, and
    /// reports the link down once it has gone through `max_timeouts` timeouts.
    pub fn poll(&mut self, now_us: u64) -> Result<(), LinkDown> {
        if let Some(down) = self.down {
            return Err(down);
        }
        let max_timeouts = self.config.max_timeouts;
        let Some(oldest) = self.window.front_mut() else { return Ok(()) };
        if oldest.deadline_us.is_none_or(|deadline_us| now_us < deadline_us) {
            return Ok(());
        }
        oldest.timeouts = oldest.timeouts.saturating_add(1);
        if oldest.timeouts >= max_timeouts {
            let down = LinkDown {
                seq: oldest.seq,
                timeouts: oldest.timeouts,
                transmissions: oldest.transmissions,
            };
            self.down = Some(down);
            return Err(down);
        }
        for pending in self.window.iter_mut() {
            pending.due = true;
            pending.deadline_us = None; // re-armed when resent
        }
        Ok(())
    }

    /// When [`Self::poll`] next needs calling for a timeout, µs in the caller's clock.
    pub fn next_timeout_us(&self) -> Option<u64> {
        self.window.front()?.deadline_us
    }

    /// The next frame to put on the wire, if any: a nack, then due data frames in order
    /// (each carrying the current ack), then a bare ack. Encode it with
    /// [`crate::encode_frame`] and send it before calling again.
    pub fn poll_transmit(&mut self, now_us: u64) -> Option<Frame<&Tx>> {
        if self.down.is_some() {
            return None;
        }
        let kind = if self.nack_due {
            self.nack_due = false;
            self.nacked_at_seq = Some(self.rx_next_seq);
            FrameKind::Nack
        } else if let Some(pending) = self.window.iter_mut().find(|p| p.due) {
            if pending.transmissions > 0 {
                self.stats.retransmissions += 1;
            }
            pending.due = false;
            pending.last_sent_us = Some(now_us);
            if pending.deadline_us.is_none() {
                pending.deadline_us =
                    Some(now_us.saturating_add(self.config.retransmit_timeout_us));
            }
            pending.transmissions = pending.transmissions.saturating_add(1);
            FrameKind::Data { seq: pending.seq, msg: &pending.msg }
        } else if self.ack_due {
            FrameKind::Ack
        } else {
            return None;
        };
        self.ack_due = false;
        Some(Frame {
            sender_session: self.session,
            receiver_session: self.peer_session,
            ack: self.rx_next_seq,
            kind,
        })
    }
}
