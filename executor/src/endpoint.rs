//! The executor core on the wire: the host's reliable link and its framing, and the
//! controller behind its [`ControllerAdapter`], around [`Executor`].
//!
//! Still sans-IO: bytes in ([`Endpoint::on_host_bytes`], [`Endpoint::on_ctrl_bytes`]), bytes
//! out ([`Endpoint::transmit_host`], [`Endpoint::transmit_ctrl`]), time passed in. The std
//! shell reads serial ports into it; simulations feed it simulated lines. Messages the core
//! emits for the host wait in a bounded outbox while the link's window is full (the core's
//! flow control keeps moves within the window); an outbox that overflows counts the loss in
//! [`EndpointStats`] (it cannot with `W ≥ LA + MIN_FREE_OUTPUTS`, checked at compile time).
//! A link that goes down is reported to the core (which stops the trial) and restarted
//! under a new session so the `Stop` still goes out. The controller's side is the adapter's:
//! the project's own controller by default ([`NativeAdapter`]), a point-to-point controller
//! with [`Endpoint::with_adapter`].

use crate::adapter::native::NativeAdapter;
use crate::adapter::{AdapterEvent, ControllerAdapter};
use crate::io::{Input, LogEvent, MIN_FREE_OUTPUTS, Output, Outputs};
use crate::machine::Executor;
use crate::store::PlanStore;
use crate::{CameraFrame, ExecError};
use heapless::Deque;
use mesopush_protocol::{
    ExecToHost, FRAME_BUF_LEN, FrameReader, HostToExec, Link, LinkConfig, encode_frame,
};
use serde::de::DeserializeOwned;

/// Room for outputs of one core call.
const OUT: usize = 64;

/// Counters of the endpoint.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct EndpointStats {
    /// Messages for the host lost to a full outbox.
    pub host_dropped: u64,
    /// Messages for the controller lost to a full outbox.
    pub ctrl_dropped: u64,
    /// Times the host link went down.
    pub host_link_downs: u64,
    /// Times the controller link went down.
    pub ctrl_link_downs: u64,
    /// Frames too long for the reader.
    pub overlong_frames: u64,
}

/// Executor core plus the host link and the controller's adapter `A`; `W` is the host
/// link's window (and the native controller link's).
#[derive(Debug)]
pub struct Endpoint<S, const CAP: usize, const LA: usize, const W: usize, A = NativeAdapter<W>> {
    core: Executor<S, CAP, LA>,
    host_link: Link<ExecToHost, HostToExec, W>,
    ctrl: A,
    host_reader: FrameReader<FRAME_BUF_LEN>,
    host_outbox: Deque<ExecToHost, OUT>,
    out: Outputs<OUT>,
    session: u16,
    stats: EndpointStats,
}

/// One byte of a line through its frame reader and link: the message it completes, if that
/// is the next one in order. An overlong frame is counted and skipped.
fn receive<Tx, Rx: DeserializeOwned, const W: usize>(
    reader: &mut FrameReader<FRAME_BUF_LEN>,
    link: &mut Link<Tx, Rx, W>,
    stats: &mut EndpointStats,
    now_us: u64,
    byte: u8,
) -> Option<Rx> {
    match reader.push_byte(byte)? {
        Err(_) => {
            stats.overlong_frames += 1;
            None
        }
        Ok(frame) => link.on_bytes(now_us, frame),
    }
}

impl<S: PlanStore, const CAP: usize, const LA: usize, const W: usize> Endpoint<S, CAP, LA, W> {
    /// Wraps `core` with the project's own controller link; `session` is this boot's link
    /// session (differs from the last boot's).
    pub fn new(core: Executor<S, CAP, LA>, link: LinkConfig, session: u16) -> Self {
        Self::with_adapter(core, link, session, NativeAdapter::new(link, session))
    }

    /// The controller link (statistics).
    pub fn ctrl_link(
        &self,
    ) -> &Link<mesopush_protocol::ExecToCtrl, mesopush_protocol::CtrlToExec, W> {
        self.ctrl.link()
    }
}

impl<S: PlanStore, const CAP: usize, const LA: usize, const W: usize, A: ControllerAdapter>
    Endpoint<S, CAP, LA, W, A>
{
    const SIZES_OK: () = assert!(W >= LA + MIN_FREE_OUTPUTS && OUT >= LA + MIN_FREE_OUTPUTS);

    /// Wraps `core` with the controller behind `ctrl`; `link` and `session` are the host
    /// link's.
    pub fn with_adapter(
        core: Executor<S, CAP, LA>,
        link: LinkConfig,
        session: u16,
        ctrl: A,
    ) -> Self {
        let () = Self::SIZES_OK;
        Self {
            core,
            host_link: Link::new(link, session),
            ctrl,
            host_reader: FrameReader::new(),
            host_outbox: Deque::new(),
            out: Outputs::new(),
            session,
            stats: EndpointStats::default(),
        }
    }

    /// The core.
    pub fn core(&self) -> &Executor<S, CAP, LA> {
        &self.core
    }

    /// The controller's adapter.
    pub fn adapter(&self) -> &A {
        &self.ctrl
    }

    /// The controller adapter's counters.
    pub fn adapter_stats(&self) -> crate::adapter::AdapterStats {
        self.ctrl.stats()
    }

    /// Counters (the host link's and the controller adapter's).
    pub fn stats(&self) -> EndpointStats {
        let a = self.ctrl.stats();
        EndpointStats {
            ctrl_dropped: a.dropped_commands,
            ctrl_link_downs: a.link_downs,
            overlong_frames: self.stats.overlong_frames + a.unreadable,
            ..self.stats
        }
    }

    /// The host link (statistics).
    pub fn host_link(&self) -> &Link<ExecToHost, HostToExec, W> {
        &self.host_link
    }

    /// Bytes from the host line.
    pub fn on_host_bytes(
        &mut self,
        now_us: u64,
        bytes: &[u8],
        log: &mut impl FnMut(&LogEvent),
    ) -> Result<(), ExecError> {
        for &byte in bytes {
            let (reader, link) = (&mut self.host_reader, &mut self.host_link);
            if let Some(msg) = receive(reader, link, &mut self.stats, now_us, byte) {
                self.feed(now_us, Input::Host(&msg), log)?;
            }
        }
        Ok(())
    }

    /// Bytes from the controller (a chunk of its line, or one datagram).
    pub fn on_ctrl_bytes(
        &mut self,
        now_us: u64,
        mut bytes: &[u8],
        log: &mut impl FnMut(&LogEvent),
    ) -> Result<(), ExecError> {
        loop {
            let used = self.ctrl.receive(now_us, bytes).min(bytes.len());
            bytes = &bytes[used..];
            self.drain_ctrl_events(now_us, log)?;
            if bytes.is_empty() || used == 0 {
                return Ok(());
            }
        }
    }

    fn drain_ctrl_events(
        &mut self,
        now_us: u64,
        log: &mut impl FnMut(&LogEvent),
    ) -> Result<(), ExecError> {
        while let Some(event) = self.ctrl.next_event() {
            match event {
                AdapterEvent::Ctrl(msg) => self.feed(now_us, Input::Ctrl(&msg), log)?,
                AdapterEvent::LinkDown => self.feed(now_us, Input::CtrlLinkDown, log)?,
            }
        }
        Ok(())
    }

    /// A camera frame arrived.
    pub fn on_frame(
        &mut self,
        now_us: u64,
        frame: CameraFrame,
        log: &mut impl FnMut(&LogEvent),
    ) -> Result<(), ExecError> {
        self.feed(now_us, Input::Frame(frame), log)
    }

    /// Drives timeouts (links, core timers); call at least at [`Self::next_deadline_us`].
    pub fn poll(&mut self, now_us: u64, log: &mut impl FnMut(&LogEvent)) -> Result<(), ExecError> {
        if self.host_link.poll(now_us).is_err() {
            self.stats.host_link_downs += 1;
            self.session = self.session.wrapping_add(1);
            self.host_link.reset(self.session);
            self.feed(now_us, Input::HostLinkDown, log)?;
        }
        self.ctrl.poll(now_us);
        self.drain_ctrl_events(now_us, log)?;
        self.feed(now_us, Input::Tick, log)
    }

    /// When to call [`Self::poll`] next, µs in the executor's clock.
    pub fn next_deadline_us(&self) -> u64 {
        let links = [self.host_link.next_timeout_us(), self.ctrl.next_deadline_us()];
        links.into_iter().flatten().fold(self.core.next_deadline_us(), u64::min)
    }

    /// The next frame for the host, encoded into `buf`.
    pub fn transmit_host<'b>(&mut self, now_us: u64, buf: &'b mut [u8]) -> Option<&'b [u8]> {
        self.flush_host();
        let frame = self.host_link.poll_transmit(now_us)?;
        encode_frame(&frame, buf).ok()
    }

    /// The next bytes for the controller (a frame, a command or a datagram), encoded into
    /// `buf`.
    pub fn transmit_ctrl<'b>(&mut self, now_us: u64, buf: &'b mut [u8]) -> Option<&'b [u8]> {
        self.ctrl.transmit(now_us, buf)
    }

    fn flush_host(&mut self) {
        while let Some(msg) = self.host_outbox.pop_front() {
            if let Err(msg) = self.host_link.send(msg) {
                let _ = self.host_outbox.push_front(msg); // the slot just freed
                return;
            }
        }
    }

    fn feed(
        &mut self,
        now_us: u64,
        input: Input<'_>,
        log: &mut impl FnMut(&LogEvent),
    ) -> Result<(), ExecError> {
        self.core.handle(now_us, input, &mut self.out)?;
        for output in self.out.iter() {
            match output {
                Output::Host(m) => {
                    if self.host_outbox.push_back(m.clone()).is_err() {
                        self.stats.host_dropped += 1;
                    }
                }
                Output::Ctrl(m) => self.ctrl.command(now_us, m),
                Output::Log(e) => log(e),
            }
        }
        self.out.clear();
        self.flush_host();
        Ok(())
    }
}
