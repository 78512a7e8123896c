//! A network controller's line (Sensapex: SMCP1 datagrams) as a real loopback UDP socket
//! pair, driven in lock-step for simulated time like the serial controllers'
//! pseudo-terminal ([`super::pty`]): a datagram one side sends is received on the other side
//! (a blocking receive with a timeout that is a typed error) before the caller delivers it at
//! its simulated arrival time. Every datagram crosses the kernel's UDP stack whole.

use crate::Error;
use std::net::UdpSocket;
use std::path::PathBuf;
use std::time::Duration;

/// Longest wait for a datagram sent on one socket to arrive on the other.
const RECEIVE_TIMEOUT: Duration = Duration::from_secs(2);
/// Largest datagram carried (SMCP1's maximum is 1502 bytes).
const MAX_DATAGRAM: usize = 1502;

/// Two loopback sockets: the executor's and the emulated controller's.
#[derive(Debug)]
pub struct UdpLine {
    exec: UdpSocket,
    sim: UdpSocket,
}

fn io_err(cause: std::io::Error) -> Error {
    Error::io(PathBuf::from("udp:127.0.0.1"), cause)
}

impl UdpLine {
    /// Binds both sockets on 127.0.0.1 (ephemeral ports) and connects them to each other.
    pub fn open() -> Result<Self, Error> {
        let exec = UdpSocket::bind("127.0.0.1:0").map_err(io_err)?;
        let sim = UdpSocket::bind("127.0.0.1:0").map_err(io_err)?;
        exec.connect(sim.local_addr().map_err(io_err)?).map_err(io_err)?;
        sim.connect(exec.local_addr().map_err(io_err)?).map_err(io_err)?;
        for s in [&exec, &sim] {
            s.set_read_timeout(Some(RECEIVE_TIMEOUT)).map_err(io_err)?;
        }
        Ok(Self { exec, sim })
    }

    /// The executor sends `datagram`; returns it as the controller received it.
    pub fn exec_to_sim(&mut self, datagram: &[u8], out: &mut Vec<u8>) -> Result<(), Error> {
        transfer(&self.exec, &self.sim, datagram, out)
    }

    /// The controller sends `datagram`; returns it as the executor received it.
    pub fn sim_to_exec(&mut self, datagram: &[u8], out: &mut Vec<u8>) -> Result<(), Error> {
        transfer(&self.sim, &self.exec, datagram, out)
    }
}

fn transfer(from: &UdpSocket, to: &UdpSocket, d: &[u8], out: &mut Vec<u8>) -> Result<(), Error> {
    from.send(d).map_err(io_err)?;
    out.clear();
    out.resize(MAX_DATAGRAM, 0);
    let n = to.recv(out).map_err(io_err)?;
    out.truncate(n);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn datagrams_cross_whole_both_ways() {
        let mut line = UdpLine::open().unwrap();
        let mut out = Vec::new();
        let d: Vec<u8> = (0..60).collect();
        line.exec_to_sim(&d, &mut out).unwrap();
        assert_eq!(out, d);
        line.sim_to_exec(&d[..16], &mut out).unwrap();
        assert_eq!(out, &d[..16]);
    }
}
