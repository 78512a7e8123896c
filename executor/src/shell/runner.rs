//! The shell's loop: reader threads, the endpoint, writers, the recorder channel.

use super::port::{ByteRead, ByteWrite, CHUNK_BYTES, Chunk};
use super::rt;
use super::rt_queue::{self, Bell, Receiver, Sender, TryRecvError, TrySendError};
use super::timing::SendTiming;
use crate::adapter::ControllerAdapter;
use crate::camera::CameraFrame;
use crate::clock::Clock;
use crate::endpoint::Endpoint;
use crate::io::LogEvent;
use crate::store::PlanStore;
use mesopush_protocol::FRAME_BUF_LEN;
use std::io;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;
use std::vec;
use std::vec::Vec;

/// Chunks buffered between a reader thread and the loop.
const READ_QUEUE_CHUNKS: usize = 256;
/// Log records buffered between the loop and the thread that hands them to the recorder.
const LOG_QUEUE: usize = 4096;
/// Longest wait of the loop, so a stop request is seen promptly.
const MAX_WAIT_US: u64 = 10_000;

/// Settings of the loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShellOptions {
    /// Before a segment's send deadline the loop sleeps until this long before it and spins
    /// on the clock for the rest, µs (0: sleep only). Default 300: a sleeping thread wakes up
    /// to a few hundred µs late on a normal kernel, a spin costs this much CPU per segment.
    pub spin_us: u64,
}

impl ShellOptions {
    /// The documented defaults.
    pub const DEFAULT: Self = Self { spin_us: 300 };
}

impl Default for ShellOptions {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Counters of a shell run.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct ShellStats {
    /// Loop iterations.
    pub iterations: u64,
    /// Log records handed to the recorder.
    pub logged: u64,
    /// Log records lost because the recorder's channel was full.
    pub log_dropped: u64,
    /// Largest lateness of a loop wake-up past the core's deadline, µs: only deadlines that
    /// were still ahead when the loop went to wait count (a deadline already past — the
    /// first pass after start-up, whose clock started before the set-up — is no wake-up).
    pub max_late_us: u64,
    /// Setpoint segment writes against their send schedule.
    pub sends: SendTiming,
}

/// Why the loop ended.
#[derive(Debug)]
pub enum ShellEnd {
    /// A stop was requested.
    Stopped,
    /// The host's line closed or failed.
    HostLine(io::Error),
    /// The controller's line closed or failed.
    CtrlLine(io::Error),
}

impl core::fmt::Display for ShellEnd {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Stopped => f.write_str("stop requested"),
            Self::HostLine(e) => write!(f, "the host line closed or failed ({e})"),
            Self::CtrlLine(e) => write!(f, "the controller line closed or failed ({e})"),
        }
    }
}

/// The loop and its threads.
#[derive(Debug)]
pub struct Shell {
    stop: Arc<AtomicBool>,
    readers: Vec<JoinHandle<io::Result<()>>>,
}

fn spawn_reader(
    mut link: impl ByteRead + 'static,
    tx: Sender<Chunk>,
    stop: Arc<AtomicBool>,
) -> JoinHandle<io::Result<()>> {
    std::thread::spawn(move || {
        let mut buf = [0u8; CHUNK_BYTES];
        while !stop.load(Ordering::Relaxed) {
            let n = link.read_bytes(&mut buf)?;
            if n > 0 && tx.send(Chunk::new(&buf[..n])).is_err() {
                break; // the loop is gone
            }
        }
        Ok(())
    })
}

/// Hands the loop's log records to the recorder's channel from a normal-priority thread, so
/// the real-time loop never waits on the recorder's side of a lock-free channel
/// ([`rt_queue`]'s note). Returns the records the recorder's full channel refused.
fn spawn_log_forwarder(
    rx: Receiver<LogEvent>,
    log: crossbeam_channel::Sender<LogEvent>,
) -> JoinHandle<u64> {
    std::thread::spawn(move || {
        rt::leave_real_time();
        let mut refused = 0u64;
        while let Some(e) = rx.recv() {
            if log.try_send(e).is_err() {
                refused += 1;
            }
        }
        refused
    })
}

impl Shell {
    /// Runs `endpoint` on the two lines until `stop_rx` fires (or its sender goes) or a line
    /// fails; camera frames arrive on `frames`, log records go to `log` (never blocking).
    /// Default [`ShellOptions`].
    #[allow(clippy::too_many_arguments)]
    pub fn run<
        S: PlanStore,
        const CAP: usize,
        const LA: usize,
        const W: usize,
        A: ControllerAdapter,
    >(
        endpoint: &mut Endpoint<S, CAP, LA, W, A>,
        clock: &impl Clock,
        host: (impl ByteRead + 'static, impl ByteWrite),
        ctrl: (impl ByteRead + 'static, impl ByteWrite),
        frames: Option<Receiver<CameraFrame>>,
        log: crossbeam_channel::Sender<LogEvent>,
        stop_rx: Receiver<()>,
        stats: &mut ShellStats,
    ) -> ShellEnd {
        let lines = (host, ctrl, frames);
        Self::run_with(endpoint, clock, lines, log, stop_rx, ShellOptions::DEFAULT, stats)
    }

    /// [`Self::run`] with `opts`; `lines` are the host line, the controller line and the
    /// camera frames.
    #[allow(clippy::type_complexity)]
    pub fn run_with<
        S: PlanStore,
        const CAP: usize,
        const LA: usize,
        const W: usize,
        A: ControllerAdapter,
    >(
        endpoint: &mut Endpoint<S, CAP, LA, W, A>,
        clock: &impl Clock,
        lines: (
            (impl ByteRead + 'static, impl ByteWrite),
            (impl ByteRead + 'static, impl ByteWrite),
            Option<Receiver<CameraFrame>>,
        ),
        log: crossbeam_channel::Sender<LogEvent>,
        stop_rx: Receiver<()>,
        opts: ShellOptions,
        stats: &mut ShellStats,
    ) -> ShellEnd {
        let (host, ctrl, frames) = lines;
        let stop = Arc::new(AtomicBool::new(false));
        let (host_tx, host_rx) = rt_queue::bounded(READ_QUEUE_CHUNKS);
        let (ctrl_tx, ctrl_rx) = rt_queue::bounded(READ_QUEUE_CHUNKS);
        let (log_tx, log_rx) = rt_queue::bounded(LOG_QUEUE);
        let forwarder = spawn_log_forwarder(log_rx, log);
        let mut shell = Shell {
            stop: stop.clone(),
            readers: vec![
                spawn_reader(host.0, host_tx, stop.clone()),
                spawn_reader(ctrl.0, ctrl_tx, stop),
            ],
        };
        let inputs = Inputs::new(host_rx, ctrl_rx, frames, stop_rx);
        let (mut host_w, mut ctrl_w) = (host.1, ctrl.1);
        let end = loop {
            let sent_before = endpoint.core().segments_sent();
            let due = endpoint.core().next_send_due_us();
            if let Some(end) = Self::iterate(endpoint, clock, &inputs, &log_tx, opts, due, stats) {
                break end;
            }
            if let Err(end) = Self::transmit(endpoint, clock.now_us(), &mut host_w, &mut ctrl_w) {
                break end;
            }
            let sent = endpoint.core().segments_sent() - sent_before;
            if sent > 0 {
                stats.sends.record(due, clock.now_us(), sent);
            }
        };
        // The receivers go first: a reader blocked on a full queue then returns.
        drop(inputs);
        shell.join();
        drop(log_tx);
        let refused = forwarder.join().unwrap_or(0);
        stats.logged -= refused.min(stats.logged);
        stats.log_dropped += refused;
        end
    }

    /// One pass: wait for input or the deadline (sleep, then spin when the deadline is a
    /// send due at `due`), feed what came, poll the core.
    #[allow(clippy::too_many_arguments)]
    fn iterate<
        S: PlanStore,
        const CAP: usize,
        const LA: usize,
        const W: usize,
        A: ControllerAdapter,
    >(
        endpoint: &mut Endpoint<S, CAP, LA, W, A>,
        clock: &impl Clock,
        inputs: &Inputs,
        log: &Sender<LogEvent>,
        opts: ShellOptions,
        due: Option<u64>,
        stats: &mut ShellStats,
    ) -> Option<ShellEnd> {
        stats.iterations += 1;
        let deadline = endpoint.next_deadline_us();
        let waited_from_us = clock.now_us();
        let spin_us = if due.is_some_and(|d| d <= deadline) { opts.spin_us } else { 0 };
        let wait_us = deadline.saturating_sub(spin_us).saturating_sub(waited_from_us);
        let wait_until_us = waited_from_us + wait_us.min(MAX_WAIT_US);
        let mut record = |e: &LogEvent| match log.try_send(*e) {
            Ok(()) => stats.logged += 1,
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => stats.log_dropped += 1,
        };
        let fed = match inputs.wait(clock, wait_until_us, stats.iterations) {
            Some(Input::Host(c)) => endpoint.on_host_bytes(clock.now_us(), c.bytes(), &mut record),
            Some(Input::Ctrl(c)) => endpoint.on_ctrl_bytes(clock.now_us(), c.bytes(), &mut record),
            Some(Input::Frame(f)) => endpoint.on_frame(clock.now_us(), f, &mut record),
            Some(Input::Stop) => return Some(ShellEnd::Stopped),
            Some(Input::HostGone) => {
                return Some(ShellEnd::HostLine(io::Error::other("host reader ended")));
            }
            Some(Input::CtrlGone) => {
                return Some(ShellEnd::CtrlLine(io::Error::other("controller reader ended")));
            }
            None => {
                spin_until(clock, deadline, spin_us);
                Ok(())
            }
        };
        let now = clock.now_us();
        if deadline > waited_from_us && now > deadline {
            stats.max_late_us = stats.max_late_us.max(now - deadline);
        }
        // The core only fails on a too-small output buffer, which Endpoint rules out.
        let polled = fed.and_then(|()| endpoint.poll(now, &mut record));
        debug_assert!(polled.is_ok(), "endpoint output buffer too small");
        None
    }

    fn transmit<
        S: PlanStore,
        const CAP: usize,
        const LA: usize,
        const W: usize,
        A: ControllerAdapter,
    >(
        endpoint: &mut Endpoint<S, CAP, LA, W, A>,
        now: u64,
        host_w: &mut impl ByteWrite,
        ctrl_w: &mut impl ByteWrite,
    ) -> Result<(), ShellEnd> {
        let mut buf = [0u8; FRAME_BUF_LEN];
        while let Some(frame) = endpoint.transmit_ctrl(now, &mut buf) {
            ctrl_w.write_bytes(frame).map_err(ShellEnd::CtrlLine)?;
        }
        while let Some(frame) = endpoint.transmit_host(now, &mut buf) {
            host_w.write_bytes(frame).map_err(ShellEnd::HostLine)?;
        }
        Ok(())
    }

    fn join(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for reader in self.readers.drain(..) {
            let _ = reader.join();
        }
    }
}

/// One input to the loop.
enum Input {
    Host(Chunk),
    Ctrl(Chunk),
    Frame(CameraFrame),
    Stop,
    HostGone,
    CtrlGone,
}

/// The loop's input queues and the bell they all ring.
struct Inputs {
    host_rx: Receiver<Chunk>,
    ctrl_rx: Receiver<Chunk>,
    frames: Option<Receiver<CameraFrame>>,
    stop_rx: Receiver<()>,
    bell: Arc<Bell>,
}

impl Inputs {
    fn new(
        host_rx: Receiver<Chunk>,
        ctrl_rx: Receiver<Chunk>,
        frames: Option<Receiver<CameraFrame>>,
        stop_rx: Receiver<()>,
    ) -> Self {
        let bell = Bell::new();
        host_rx.attach(&bell);
        ctrl_rx.attach(&bell);
        stop_rx.attach(&bell);
        if let Some(f) = &frames {
            f.attach(&bell);
        }
        Self { host_rx, ctrl_rx, frames, stop_rx, bell }
    }

    /// The next input, the stop first, then the three sources in turns starting at `turn`
    /// (so none starves the others); `None` when nothing is queued.
    fn next(&self, turn: u64) -> Option<Input> {
        if !matches!(self.stop_rx.try_recv(), Err(TryRecvError::Empty)) {
            return Some(Input::Stop);
        }
        for k in 0..3 {
            let input = match (turn + k) % 3 {
                0 => match self.host_rx.try_recv() {
                    Ok(c) => Some(Input::Host(c)),
                    Err(TryRecvError::Disconnected) => Some(Input::HostGone),
                    Err(TryRecvError::Empty) => None,
                },
                1 => match self.ctrl_rx.try_recv() {
                    Ok(c) => Some(Input::Ctrl(c)),
                    Err(TryRecvError::Disconnected) => Some(Input::CtrlGone),
                    Err(TryRecvError::Empty) => None,
                },
                // A camera that goes away leaves the loop running without frames.
                _ => self.frames.as_ref().and_then(|f| f.try_recv().ok()).map(Input::Frame),
            };
            if input.is_some() {
                return input;
            }
        }
        None
    }

    /// The next input, waiting (asleep) until `until_us` for one.
    fn wait(&self, clock: &impl Clock, until_us: u64, turn: u64) -> Option<Input> {
        loop {
            let seen = self.bell.rings();
            if let Some(input) = self.next(turn) {
                return Some(input);
            }
            let now = clock.now_us();
            if now >= until_us {
                return None;
            }
            self.bell.wait_past(seen, Duration::from_micros(until_us - now));
        }
    }
}

/// Busy-waits until `deadline_us`, at most `max_us` (the sleep before it woke up to then).
fn spin_until(clock: &impl Clock, deadline_us: u64, max_us: u64) {
    if max_us == 0 {
        return;
    }
    let give_up = clock.now_us().saturating_add(max_us);
    loop {
        let now = clock.now_us();
        if now >= deadline_us || now >= give_up {
            return;
        }
        std::hint::spin_loop();
    }
}
