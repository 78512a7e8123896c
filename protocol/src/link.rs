//! Sans-IO reliable link: ordered, exactly-once delivery over a lossy byte stream.
//!
//! Both ends of every serial line (host ↔ executor, executor ↔ controller) run this same
//! state machine. It never reads a clock or touches I/O: the caller feeds received frames
//! with [`Link::on_frame`], asks for frames to send with [`Link::poll_transmit`] and drives
//! timeouts with [`Link::poll`], passing its own `now_us`. The protocol is go-back-N:
//! data frames carry a sequence number and a cumulative ack; the receiver delivers only the
//! next expected frame, re-acks duplicates and nacks gaps and damaged frames; the sender
//! keeps at most `WINDOW` unacknowledged messages, resends all of them when the oldest times
//! out or is nacked, and declares the link down after a bounded number of transmissions.
//!
//! A peer that restarts begins again at sequence 0; its frames then look stale, this end
//! reports [`LinkDown`] within the retry bound, and the caller answers every `LinkDown` with
//! [`Link::reset`]. Delivery is never duplicated or reordered, but messages queued around a
//! restart may be lost, so callers treat `LinkDown` as a fault and redo their handshake.

use crate::error::WireError;
use crate::frame::{Frame, decode_frame};
use heapless::Deque;
use serde::de::DeserializeOwned;

/// Timing and retry settings of a [`Link`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkConfig {
    /// Time after the last transmission of the oldest unacked frame before the window is
    /// resent, µs. Default 20 ms: several round trips of a 1 Mbaud line with a full window.
    pub retransmit_timeout_us: u64,
    /// Minimum time between a transmission and a nack-triggered resend of the same window,
    /// µs, so a burst of nacks triggers one resend. Default 5 ms.
    pub nack_holdoff_us: u64,
    /// Transmissions of one frame (first send included) before the link is declared down.
    /// Default 8.
    pub max_transmissions: u8,
}

impl LinkConfig {
    /// The documented defaults.
    pub const DEFAULT: Self =
        Self { retransmit_timeout_us: 20_000, nack_holdoff_us: 5_000, max_transmissions: 8 };
}

impl Default for LinkConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The link gave up: a frame went unacknowledged through all its transmissions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkDown {
    /// Sequence number of the frame that was never acknowledged.
    pub seq: u16,
    /// How many times it was sent.
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
}

#[derive(Debug)]
struct Pending<Tx> {
    seq: u16,
    msg: Tx,
    last_sent_us: Option<u64>,
    transmissions: u8,
    due: bool,
}

/// A reliable link sending `Tx`, receiving `Rx`, with at most `WINDOW` unacked messages.
#[derive(Debug)]
pub struct Link<Tx, Rx, const WINDOW: usize> {
    config: LinkConfig,
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

    /// A fresh link; both peers start at sequence number 0.
    pub const fn new(config: LinkConfig) -> Self {
        let () = Self::WINDOW_OK;
        Self {
            config,
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
            },
            _rx: core::marker::PhantomData,
        }
    }

    /// Queues `msg`. A full window or a down link hands it back.
    pub fn send(&mut self, msg: Tx) -> Result<(), Tx> {
        if self.down.is_some() {
            return Err(msg);
        }
        let pending =
            Pending { seq: self.next_tx_seq, msg, last_sent_us: None, transmissions: 0, due: true };
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

    /// Forgets all state (unsent and unacked messages included); both peers must reset
    /// together, e.g. after a new handshake.
    pub fn reset(&mut self) {
        *self = Self::new(self.config);
    }

    /// Decodes `bytes` (one stuffed frame) and handles it as [`Self::on_frame`] does.
    pub fn on_bytes(&mut self, now_us: u64, bytes: &mut [u8]) -> Option<Rx> {
        let frame = decode_frame(bytes);
        self.on_frame(now_us, frame)
    }

    /// Handles a received frame, or a decode failure (answered with a nack). Returns the
    /// message to deliver, if this frame carried the next one in order.
    pub fn on_frame(&mut self, now_us: u64, frame: Result<Frame<Rx>, WireError>) -> Option<Rx> {
        let frame = match frame {
            Ok(frame) => frame,
            Err(_) => {
                self.stats.corrupt += 1;
                self.request_nack();
                return None;
            }
        };
        self.last_heard_us = Some(now_us);
        match frame {
            Frame::Data { seq, ack, msg } => {
                self.on_ack(ack);
                self.on_data(seq, msg)
            }
            Frame::Ack { ack } => {
                self.on_ack(ack);
                None
            }
            Frame::Nack { ack } => {
                self.on_ack(ack);
                self.on_nack(now_us, ack);
                None
            }
        }
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

    /// Drives timeouts: resends the window when the oldest frame has waited
    /// `retransmit_timeout_us`, and reports the link down once a frame has used all its
    /// transmissions.
    pub fn poll(&mut self, now_us: u64) -> Result<(), LinkDown> {
        if let Some(down) = self.down {
            return Err(down);
        }
        let timeout_us = self.config.retransmit_timeout_us;
        let Some(oldest) = self.window.front() else { return Ok(()) };
        let Some(sent_us) = oldest.last_sent_us else { return Ok(()) };
        if oldest.due || now_us.saturating_sub(sent_us) < timeout_us {
            return Ok(());
        }
        if oldest.transmissions >= self.config.max_transmissions {
            let down = LinkDown { seq: oldest.seq, transmissions: oldest.transmissions };
            self.down = Some(down);
            return Err(down);
        }
        self.mark_window_due();
        Ok(())
    }

    /// When [`Self::poll`] next needs calling for a timeout, µs in the caller's clock.
    pub fn next_timeout_us(&self) -> Option<u64> {
        let oldest = self.window.front()?;
        oldest.last_sent_us.map(|t| t.saturating_add(self.config.retransmit_timeout_us))
    }

    /// The next frame to put on the wire, if any: a nack, then due data frames in order
    /// (each carrying the current ack), then a bare ack. Encode it with
    /// [`crate::encode_frame`] and send it before calling again.
    pub fn poll_transmit(&mut self, now_us: u64) -> Option<Frame<&Tx>> {
        if self.down.is_some() {
            return None;
        }
        let ack = self.rx_next_seq;
        if self.nack_due {
            self.nack_due = false;
            self.ack_due = false;
            self.nacked_at_seq = Some(ack);
            return Some(Frame::Nack { ack });
        }
        if let Some(pending) = self.window.iter_mut().find(|p| p.due) {
            if pending.transmissions > 0 {
                self.stats.retransmissions += 1;
            }
            pending.due = false;
            pending.last_sent_us = Some(now_us);
            pending.transmissions = pending.transmissions.saturating_add(1);
            self.ack_due = false;
            return Some(Frame::Data { seq: pending.seq, ack, msg: &pending.msg });
        }
        if self.ack_due {
            self.ack_due = false;
            return Some(Frame::Ack { ack });
        }
        None
    }
}
