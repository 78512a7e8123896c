//! The project's own streaming controller (the firmware simulator, or firmware speaking the
//! same protocol): the core's messages go out unchanged over the reliable link
//! ([`mesopush_protocol::Link`], COBS frames with checksums, go-back-N), and what comes back
//! is handed to the core as it is. Messages wait in a bounded outbox while the link's window
//! is full; a link that gives up is reported ([`AdapterEvent::LinkDown`]) and restarted
//! under a new session so the core's `Stop` still goes out.

use super::{AdapterEvent, AdapterStats, ControllerAdapter};
use heapless::Deque;
use mesopush_protocol::ctrl::CtrlToExec;
use mesopush_protocol::{ExecToCtrl, FRAME_BUF_LEN, FrameReader, Link, LinkConfig, encode_frame};

/// Core messages waiting for room in the link's window.
pub const OUTBOX: usize = 64;
/// Events waiting for the core (a link-down and a message at most, in practice).
const EVENTS: usize = 4;

/// The native controller link; `W` is the link's window.
#[derive(Debug)]
pub struct NativeAdapter<const W: usize> {
    link: Link<ExecToCtrl, CtrlToExec, W>,
    reader: FrameReader<FRAME_BUF_LEN>,
    outbox: Deque<ExecToCtrl, OUTBOX>,
    events: Deque<AdapterEvent, EVENTS>,
    session: u16,
    stats: AdapterStats,
}

impl<const W: usize> NativeAdapter<W> {
    /// A link with `config`; `session` is this boot's link session (differs from the last
    /// boot's).
    pub fn new(config: LinkConfig, session: u16) -> Self {
        Self {
            link: Link::new(config, session),
            reader: FrameReader::new(),
            outbox: Deque::new(),
            events: Deque::new(),
            session,
            stats: AdapterStats::default(),
        }
    }

    /// The link (its statistics).
    pub fn link(&self) -> &Link<ExecToCtrl, CtrlToExec, W> {
        &self.link
    }

    fn flush(&mut self) {
        while let Some(msg) = self.outbox.pop_front() {
            if let Err(msg) = self.link.send(msg) {
                let _ = self.outbox.push_front(msg); // the slot just freed
                return;
            }
        }
    }

    fn event(&mut self, event: AdapterEvent) {
        if self.events.push_back(event).is_err() {
            // Cannot happen: receive stops at the first event and poll adds one.
            debug_assert!(false, "native adapter: event queue full");
        }
    }
}

impl<const W: usize> ControllerAdapter for NativeAdapter<W> {
    fn command(&mut self, _now_us: u64, msg: &ExecToCtrl) {
        if self.outbox.push_back(*msg).is_err() {
            self.stats.dropped_commands += 1;
        }
        self.flush();
    }

    fn receive(&mut self, now_us: u64, bytes: &[u8]) -> usize {
        for (i, &byte) in bytes.iter().enumerate() {
            let Some(frame) = self.reader.push_byte(byte) else { continue };
            match frame {
                Err(_) => self.stats.unreadable += 1,
                Ok(frame) => {
                    if let Some(msg) = self.link.on_bytes(now_us, frame) {
                        self.event(AdapterEvent::Ctrl(msg));
                        return i + 1;
                    }
                }
            }
        }
        bytes.len()
    }

    fn poll(&mut self, now_us: u64) {
        if self.link.poll(now_us).is_err() {
            self.stats.link_downs += 1;
            self.session = self.session.wrapping_add(1);
            self.link.reset(self.session);
            self.event(AdapterEvent::LinkDown);
        }
    }

    fn next_event(&mut self) -> Option<AdapterEvent> {
        self.events.pop_front()
    }

    fn transmit<'b>(&mut self, now_us: u64, buf: &'b mut [u8]) -> Option<&'b [u8]> {
        self.flush();
        let frame = self.link.poll_transmit(now_us)?;
        encode_frame(&frame, buf).ok()
    }

    fn next_deadline_us(&self) -> Option<u64> {
        self.link.next_timeout_us()
    }

    fn stats(&self) -> AdapterStats {
        self.stats
    }
}
