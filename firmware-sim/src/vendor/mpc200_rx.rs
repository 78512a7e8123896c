//! MPC-200 input framing: raw bytes (no terminator) in, whole command packets out.
//!
//! The MPC-200 protocol has no delimiter: the command byte says how many bytes follow
//! (`I D`, `L m`: 1; `M x y z`: 12; `S V x y z`: 13; every other command: none). The 'S'
//! packet also needs a pause of [`S_PAUSE_US`] inside it, after `53` (acq4) or after V
//! (the manual, pyIVLS); a packet whose position bytes start without either pause is
//! reported as [`Packet::Unpaced`] (the controller's crash). Positions are i32 LE µsteps.

/// The pause an 'S' packet needs inside it, µs (the manual's 30 ms).
pub const S_PAUSE_US: u64 = 30_000;

/// A complete command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Packet {
    /// A one-byte command (`C`, `U`, `K`, `03`, `F`, `O`, `N`, `H`, `Y`, or unknown).
    Simple(u8),
    /// `I D`: select drive D.
    Select(u8),
    /// `L m`: ROE mode.
    Roe(u8),
    /// `M x y z`: fast move.
    Fast([i64; 3]),
    /// `S V x y z`: straight-line move at speed byte V.
    Straight {
        /// Speed byte (0..15 documented).
        v: u8,
        /// Target, µsteps.
        xyz: [i64; 3],
    },
    /// An 'S' packet sent without its pause.
    Unpaced,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Idle,
    Drive,
    Roe,
    Fast { buf: [u8; 12], len: usize },
    SlowV { t_cmd: u64 },
    Slow { v: u8, t_cmd: u64, t_v: u64, buf: [u8; 12], len: usize },
}

/// The packet assembler.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Mpc200Rx {
    state: State,
}

impl Default for Mpc200Rx {
    fn default() -> Self {
        Self { state: State::Idle }
    }
}

fn decode(buf: &[u8; 12]) -> [i64; 3] {
    core::array::from_fn(|i| {
        i64::from(i32::from_le_bytes([buf[4 * i], buf[4 * i + 1], buf[4 * i + 2], buf[4 * i + 3]]))
    })
}

impl Mpc200Rx {
    /// Forgets a partial packet.
    pub fn reset(&mut self) {
        self.state = State::Idle;
    }

    /// Takes byte `b` arriving at `now_us`; returns the packet it completes, if any.
    pub fn push(&mut self, now_us: u64, b: u8) -> Option<Packet> {
        let (next, out) = match self.state {
            State::Idle => match b {
                b'I' => (State::Drive, None),
                b'L' => (State::Roe, None),
                b'M' => (State::Fast { buf: [0; 12], len: 0 }, None),
                b'S' => (State::SlowV { t_cmd: now_us }, None),
                _ => (State::Idle, Some(Packet::Simple(b))),
            },
            State::Drive => (State::Idle, Some(Packet::Select(b))),
            State::Roe => (State::Idle, Some(Packet::Roe(b))),
            State::Fast { mut buf, len } => {
                buf[len] = b;
                match len + 1 {
                    12 => (State::Idle, Some(Packet::Fast(decode(&buf)))),
                    n => (State::Fast { buf, len: n }, None),
                }
            }
            State::SlowV { t_cmd } => {
                (State::Slow { v: b, t_cmd, t_v: now_us, buf: [0; 12], len: 0 }, None)
            }
            State::Slow { v, t_cmd, t_v, mut buf, len } => {
                let paced = t_v - t_cmd >= S_PAUSE_US || now_us - t_v >= S_PAUSE_US;
                buf[len] = b;
                match len + 1 {
                    _ if len == 0 && !paced => (State::Idle, Some(Packet::Unpaced)),
                    12 => (State::Idle, Some(Packet::Straight { v, xyz: decode(&buf) })),
                    n => (State::Slow { v, t_cmd, t_v, buf, len: n }, None),
                }
            }
        };
        self.state = next;
        out
    }
}
