//! The controller's serial line as a real pseudo-terminal, driven in lock-step for
//! simulated time.
//!
//! The firmware simulator holds the pty's master end; the executor opens the slave by its
//! path like any serial device (`serialport`, raw mode). In simulated time one thread runs
//! both sides: bytes one side writes into its end are read back from the other end (a
//! blocking read of exactly that many bytes, with a timeout that is a typed error) before
//! the caller delivers them at their simulated arrival time. So every byte really crosses
//! the kernel's tty layer, and the run stays deterministic.

use crate::Error;
use serialport::{SerialPort, TTYPort};
use std::io::{ErrorKind, Read, Write};
use std::path::PathBuf;
use std::time::Duration;

/// Longest wait for bytes written into one end to come out of the other.
const READ_BACK_TIMEOUT: Duration = Duration::from_secs(2);

/// A pty pair: the simulator's master end and the executor's end opened by path.
#[derive(Debug)]
pub struct PtyLine {
    master: TTYPort,
    exec_port: TTYPort,
    _slave: TTYPort,
    path: String,
}

fn io_err(path: &str, cause: std::io::Error) -> Error {
    Error::io(PathBuf::from(path), cause)
}

impl PtyLine {
    /// Creates a pty pair and opens its slave by path, as the executor opens a serial port.
    pub fn open() -> Result<Self, Error> {
        let (mut master, slave) =
            TTYPort::pair().map_err(|e| io_err("pty", std::io::Error::other(e.to_string())))?;
        let path = slave
            .name()
            .ok_or_else(|| io_err("pty", std::io::Error::other("the pty slave has no path")))?;
        let mut exec_port = serialport::new(&path, 1_000_000)
            .open_native()
            .map_err(|e| io_err(&path, std::io::Error::other(e.to_string())))?;
        let timeout = |e: serialport::Error| io_err(&path, std::io::Error::other(e.to_string()));
        master.set_timeout(READ_BACK_TIMEOUT).map_err(timeout)?;
        exec_port.set_timeout(READ_BACK_TIMEOUT).map_err(timeout)?;
        Ok(Self { master, exec_port, _slave: slave, path })
    }

    /// The slave's path (what the executor opened).
    pub fn path(&self) -> &str {
        &self.path
    }

    /// Splits into the simulator's (master) end, the executor's end (opened by path) and
    /// the pair's own slave handle (keep it alive while the line is in use).
    pub fn into_parts(self) -> (TTYPort, TTYPort, TTYPort) {
        (self.master, self.exec_port, self._slave)
    }

    /// The executor writes `bytes`; returns them as read from the simulator's end.
    pub fn exec_to_sim(&mut self, bytes: &[u8], out: &mut Vec<u8>) -> Result<(), Error> {
        transfer(&mut self.exec_port, &mut self.master, bytes, out, &self.path)
    }

    /// The simulator writes `bytes`; returns them as read from the executor's end.
    pub fn sim_to_exec(&mut self, bytes: &[u8], out: &mut Vec<u8>) -> Result<(), Error> {
        transfer(&mut self.master, &mut self.exec_port, bytes, out, &self.path)
    }
}

fn transfer(
    from: &mut TTYPort,
    to: &mut TTYPort,
    bytes: &[u8],
    out: &mut Vec<u8>,
    path: &str,
) -> Result<(), Error> {
    from.write_all(bytes).map_err(|e| io_err(path, e))?;
    out.clear();
    out.resize(bytes.len(), 0);
    let mut got = 0;
    while got < bytes.len() {
        match to.read(&mut out[got..]) {
            Ok(0) => return Err(io_err(path, ErrorKind::UnexpectedEof.into())),
            Ok(n) => got += n,
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::WouldBlock) => {
                let msg = format!(
                    "{} of {} bytes came through the pseudo-terminal within {:?}",
                    got,
                    bytes.len(),
                    READ_BACK_TIMEOUT
                );
                return Err(io_err(path, std::io::Error::new(ErrorKind::TimedOut, msg)));
            }
            Err(e) => return Err(io_err(path, e)),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_cross_the_pty_unchanged_both_ways() {
        let mut line = PtyLine::open().unwrap();
        let all: Vec<u8> = (0..=255u8).chain([0, 0x0a, 0x0d, 0x03, 0x11, 0x13]).collect();
        let mut out = Vec::new();
        line.exec_to_sim(&all, &mut out).unwrap();
        assert_eq!(out, all);
        line.sim_to_exec(&all, &mut out).unwrap();
        assert_eq!(out, all);
        assert!(line.path().starts_with("/dev/"));
    }
}
