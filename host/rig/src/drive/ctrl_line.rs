//! The controller's line in simulated time: a pseudo-terminal for serial controllers
//! ([`PtyLine`]), a loopback UDP socket pair for network ones ([`UdpLine`]).

use super::pty::PtyLine;
use super::udp::UdpLine;
use crate::Error;

/// A controller line, lock-stepped.
#[derive(Debug)]
pub enum CtrlLine {
    /// A serial line through a real pseudo-terminal.
    Pty(PtyLine),
    /// Datagrams through real loopback sockets.
    Udp(UdpLine),
}

impl CtrlLine {
    /// The executor's bytes as the controller receives them.
    pub fn exec_to_sim(&mut self, bytes: &[u8], out: &mut Vec<u8>) -> Result<(), Error> {
        match self {
            Self::Pty(l) => l.exec_to_sim(bytes, out),
            Self::Udp(l) => l.exec_to_sim(bytes, out),
        }
    }

    /// The controller's bytes as the executor receives them.
    pub fn sim_to_exec(&mut self, bytes: &[u8], out: &mut Vec<u8>) -> Result<(), Error> {
        match self {
            Self::Pty(l) => l.sim_to_exec(bytes, out),
            Self::Udp(l) => l.sim_to_exec(bytes, out),
        }
    }
}
