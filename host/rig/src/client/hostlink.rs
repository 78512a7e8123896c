//! The host's line to a running `mesopush-executor` (another process): a Unix socket
//! (`unix:PATH`, what `mesopush-executor run --host-port unix:PATH` listens on) or a serial
//! device, driven by the sans-IO [`HostSession`] in real time with a deadline on every wait.
//! What `mesopush flash` and `mesopush run` use.

use super::session::{HostSession, SessionEnd};
use crate::Error;
use mesopush_executor::clock::{Clock, MonotonicClock};
use mesopush_protocol::{ExecToHost, FRAME_BUF_LEN};
use serialport::{SerialPort, TTYPort};
use std::io::{ErrorKind, Read, Write};
use std::os::unix::net::UnixStream;
use std::time::Duration;

/// Wait for the executor's first answer (the handshake).
pub const FIRST_ANSWER_TIMEOUT: Duration = Duration::from_secs(5);

/// An open host line.
#[derive(Debug)]
pub enum HostPort {
    /// A Unix socket.
    Unix(UnixStream),
    /// A serial device.
    Serial(TTYPort),
}

impl HostPort {
    /// Opens `addr`: `unix:PATH` or a serial device path.
    pub fn open(addr: &str) -> Result<Self, Error> {
        let hint = "is `mesopush-executor run --host-port` listening there?";
        if let Some(path) = addr.strip_prefix("unix:") {
            let s = UnixStream::connect(path).map_err(|e| {
                Error::io(path, std::io::Error::new(e.kind(), format!("{e} ({hint})")))
            })?;
            s.set_read_timeout(Some(Duration::from_millis(5))).map_err(|e| Error::io(path, e))?;
            return Ok(Self::Unix(s));
        }
        let mut p = serialport::new(addr, 1_000_000)
            .open_native()
            .map_err(|e| Error::io(addr, std::io::Error::other(format!("{e} ({hint})"))))?;
        p.set_timeout(Duration::from_millis(5))
            .map_err(|e| Error::io(addr, std::io::Error::other(e.to_string())))?;
        Ok(Self::Serial(p))
    }

    fn read_some(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let r = match self {
            Self::Unix(s) => s.read(buf),
            Self::Serial(p) => p.read(buf),
        };
        match r {
            Ok(0) if matches!(self, Self::Unix(_)) => {
                Err(std::io::Error::new(ErrorKind::UnexpectedEof, "the executor closed the line"))
            }
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                ) =>
            {
                Ok(0)
            }
            other => other,
        }
    }

    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        match self {
            Self::Unix(s) => s.write_all(bytes),
            Self::Serial(p) => p.write_all(bytes),
        }
    }
}

/// A link session id unlikely to repeat the previous process's (the executor resynchronises
/// on a new one).
pub fn fresh_session_id() -> u16 {
    let t = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_micros());
    let id = (std::process::id() ^ t.rotate_left(7)) as u16;
    id.max(1)
}

/// Drives `session` over `port` until it ends or `timeout` passes; every received message
/// goes to `on_msg` (with the host clock's time) as it arrives. Errors name what did not
/// happen: no answer at all within [`FIRST_ANSWER_TIMEOUT`], the session's end not within
/// `timeout`, a closed line, a link that gave up.
pub fn drive(
    session: &mut HostSession,
    port: &mut HostPort,
    addr: &str,
    timeout: Duration,
    on_msg: &mut dyn FnMut(u64, &ExecToHost),
) -> Result<SessionEnd, Error> {
    let clock = MonotonicClock::new();
    let (mut buf, mut out) = ([0u8; 512], [0u8; FRAME_BUF_LEN]);
    let deadline_us = timeout.as_micros() as u64;
    let first_us = FIRST_ANSWER_TIMEOUT.as_micros() as u64;
    let mut answered = false;
    loop {
        let now = clock.now_us();
        let n = port.read_some(&mut buf).map_err(|e| Error::io(addr, e))?;
        session.on_bytes(now, &buf[..n]);
        for (t, msg) in session.inbox.drain(..) {
            answered = true;
            on_msg(t, &msg);
        }
        session.poll(now)?;
        while let Some(f) = session.transmit(now, &mut out) {
            port.write_all(f).map_err(|e| Error::io(addr, e))?;
        }
        if let Some(end) = session.end() {
            return Ok(end.clone());
        }
        if !answered && now > first_us {
            return Err(Error::invalid(
                "host line",
                format!("no answer from an executor on {addr} within {FIRST_ANSWER_TIMEOUT:?}"),
            ));
        }
        if now > deadline_us {
            return Err(Error::invalid(
                "host line",
                format!("the executor on {addr} did not finish within {timeout:?}"),
            ));
        }
    }
}
