//! Which controller the executor drives, and its line: the project's streaming controller
//! (`native`) or a point-to-point one (`mpc200`, …), on a serial port at the controller's
//! documented baud rate or, for controllers on the network, a UDP socket (`udp:HOST:PORT`).
//! The byte links are the shell's [`ByteRead`] / [`ByteWrite`]; a UDP read returns one
//! datagram, so the adapter sees datagram boundaries.

use super::port::{ByteRead, ByteWrite, split_tty};
use std::io::{self, ErrorKind};
use std::net::UdpSocket;
use std::string::{String, ToString};
use std::time::Duration;

/// A controller the executor can drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControllerKind {
    /// The project's streaming controller (firmware simulator or compatible firmware).
    Native,
    /// Sutter MPC-200 / MPC-325 (binary serial, 128000 Bd).
    Mpc200,
    /// Sutter MP-285 (binary serial with CR, 9600 Bd).
    Mp285,
    /// Scientifica LinLab / PatchStar motion cards (ASCII serial, 9600 Bd by default).
    Scientifica,
    /// Sensapex uMp (SMCP1 datagrams over UDP, port 55555).
    Sensapex,
}

impl ControllerKind {
    /// Every kind, by its command-line name.
    pub const ALL: [(&'static str, Self); 5] = [
        ("native", Self::Native),
        ("mpc200", Self::Mpc200),
        ("mp285", Self::Mp285),
        ("scientifica", Self::Scientifica),
        ("sensapex", Self::Sensapex),
    ];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        Self::ALL.iter().find(|(_, k)| *k == self).map_or("native", |(n, _)| n)
    }

    /// The kind named `name`, or a message listing the names allowed.
    pub fn parse(name: &str) -> Result<Self, String> {
        Self::ALL.iter().find(|(n, _)| *n == name).map(|(_, k)| *k).ok_or_else(|| {
            let names: std::vec::Vec<&str> = Self::ALL.iter().map(|(n, _)| *n).collect();
            std::format!("unknown controller {name:?}: allowed are {}", names.join(", "))
        })
    }

    /// The controller's serial baud rate (its documentation's default).
    pub fn default_baud(self) -> u32 {
        match self {
            Self::Native => 1_000_000,
            Self::Mpc200 => 128_000,
            Self::Mp285 | Self::Scientifica => 9_600,
            Self::Sensapex => 0, // a UDP socket: no baud rate
        }
    }

    /// Whether the controller takes whole plan steps (a point-to-point controller) rather
    /// than setpoint segments.
    pub fn point_to_point(self) -> bool {
        !matches!(self, Self::Native)
    }
}

/// A controller line's two ends.
pub type Line = (std::boxed::Box<dyn ByteRead>, std::boxed::Box<dyn ByteWrite>);

/// Opens the controller line `addr`: `udp:HOST:PORT`, or a serial device at `baud`.
pub fn open_line(addr: &str, baud: u32) -> io::Result<Line> {
    if let Some(peer) = addr.strip_prefix("udp:") {
        let socket = UdpSocket::bind(("0.0.0.0", 0))?;
        socket.connect(peer)?;
        socket.set_read_timeout(Some(Duration::from_millis(10)))?;
        let reader = socket.try_clone()?;
        return Ok((
            std::boxed::Box::new(Datagrams(reader)),
            std::boxed::Box::new(Datagrams(socket)),
        ));
    }
    let port = serialport::new(addr, baud)
        .open_native()
        .map_err(|e| io::Error::other(std::format!("opening serial port {addr}: {e}")))?;
    let (r, w) = split_tty(port).map_err(|e| io::Error::other(e.to_string()))?;
    Ok((std::boxed::Box::new(r), std::boxed::Box::new(w)))
}

/// A connected UDP socket: one read, one datagram.
struct Datagrams(UdpSocket);

impl ByteRead for Datagrams {
    fn read_bytes(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self.0.recv(buf) {
            Err(e) if e.kind() == ErrorKind::WouldBlock || e.kind() == ErrorKind::TimedOut => Ok(0),
            // The peer's port not open yet (ICMP port unreachable): nothing arrived.
            Err(e) if e.kind() == ErrorKind::ConnectionRefused => Ok(0),
            other => other,
        }
    }
}

impl ByteWrite for Datagrams {
    fn write_bytes(&mut self, bytes: &[u8]) -> io::Result<()> {
        match self.0.send(bytes) {
            Err(e) if e.kind() == ErrorKind::ConnectionRefused => Ok(()), // resent by the adapter
            other => other.map(|_| ()),
        }
    }
}

impl ByteRead for std::boxed::Box<dyn ByteRead> {
    fn read_bytes(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        (**self).read_bytes(buf)
    }
}

impl ByteWrite for std::boxed::Box<dyn ByteWrite> {
    fn write_bytes(&mut self, bytes: &[u8]) -> io::Result<()> {
        (**self).write_bytes(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_and_unknown_ones_list_the_allowed() {
        assert_eq!(ControllerKind::parse("mpc200"), Ok(ControllerKind::Mpc200));
        let e = ControllerKind::parse("mc2000").unwrap_err();
        assert!(e.contains("\"mc2000\"") && e.contains("native, mpc200, mp285"), "{e}");
    }

    #[test]
    fn a_udp_line_carries_datagrams_whole() {
        let peer = UdpSocket::bind("127.0.0.1:0").unwrap();
        let addr = std::format!("udp:{}", peer.local_addr().unwrap());
        let (mut r, mut w) = open_line(&addr, 0).unwrap();
        w.write_bytes(&[1, 2, 3]).unwrap();
        let mut buf = [0u8; 64];
        let (n, from) = peer.recv_from(&mut buf).unwrap();
        assert_eq!(&buf[..n], &[1, 2, 3]);
        peer.send_to(&[9; 20], from).unwrap();
        peer.send_to(&[8; 5], from).unwrap();
        let mut got = std::vec::Vec::new();
        for _ in 0..100 {
            let n = r.read_bytes(&mut buf).unwrap();
            if n > 0 {
                got.push(buf[..n].to_vec());
            }
            if got.len() == 2 {
                break;
            }
        }
        assert_eq!(got, std::vec![std::vec![9u8; 20], std::vec![8u8; 5]]);
    }
}
