//! Point-to-point controllers: the ones that only know "move to here at this speed", "where
//! are you", "are you moving" and "stop" (Sutter, Scientifica, Sensapex…).
//!
//! Each controller's wire protocol is a [`Protocol`]: it encodes a [`Request`] into the
//! bytes the device expects ([`Script`]: chunks with the pauses some devices need between
//! them) and decodes the device's answer into a [`Reply`]. Everything else — taking the
//! core's segments, one move per plan step at the step's speed, quantising to the device's
//! resolution, polling, estimating the probe between polls, detecting a stall, a silent
//! controller and an ignored move — is the same for all of them and lives in
//! [`driver::PointToPointAdapter`].
//!
//! Units: the device's own (`units_per_um` of [`Protocol`], per axis the same); every
//! conversion between them and the core's nm is in [`scale`].

pub mod axes;
pub mod driver;
pub mod estimate;
pub mod mp285;
pub mod mpc200;
pub mod scale;
pub mod scientifica;
pub mod sensapex;

use heapless::Vec;

/// Longest chunk of bytes one request writes at once (a Sensapex move with per-axis speeds
/// is one 60-byte datagram).
pub const CHUNK_LEN: usize = 64;
/// Most chunks one request writes.
pub const SCRIPT_CHUNKS: usize = 3;

/// One request to a point-to-point controller. Positions are device units on the
/// device's three axes (x and y are the plan's; z is held where it was found).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Request {
    /// Step `n` of the protocol's start-up (identify, read the resolution, set modes):
    /// `0..Protocol::setup_steps()`.
    Setup(u8),
    /// Where is the stage.
    Position,
    /// Is a move in progress (protocols whose moves answer at once).
    Busy,
    /// Move in a straight line from `from` to `target` at `speed_nm_s` along the line (the
    /// protocol picks the device's speed setting for it: [`Protocol::achieved_speed_nm_s`]).
    MoveTo {
        /// Where the stage is, device units, axes x, y, z.
        from: [i32; 3],
        /// Target, device units, axes x, y, z.
        target: [i32; 3],
        /// Wanted speed along the line, nm/s.
        speed_nm_s: u32,
    },
    /// Stop now (interrupting a move in progress when the protocol can).
    Stop,
}

/// What the device answered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reply {
    /// A set-up step is done.
    SetupDone,
    /// The stage's position, device units, axes x, y, z.
    Position([i32; 3]),
    /// Whether a move is in progress.
    Busy(bool),
    /// The command was accepted (a move that answers at once: it is now running).
    Accepted,
    /// A move that answers at its end has ended.
    Arrived,
    /// The device reported an error (its code, protocol-specific).
    DeviceError(u32),
    /// The answer could not be read (wrong length or terminator): the request is retried.
    Garbled,
}

/// When a move's reply comes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MoveReply {
    /// At the end of the move; the device takes no other command meanwhile (Sutter).
    AtEnd,
    /// At once; the move runs on and is polled (Scientifica, Sensapex).
    AtOnce,
}

/// One write: `bytes`, then wait `pause_after_us` before the next chunk.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Chunk {
    /// Bytes to write.
    pub bytes: Vec<u8, CHUNK_LEN>,
    /// Pause before the next chunk, µs.
    pub pause_after_us: u64,
}

/// The writes of one request.
pub type Script = Vec<Chunk, SCRIPT_CHUNKS>;

/// Appends a chunk to `script` (requests are a few bytes: a chunk that does not fit is a
/// bug in the protocol's encoder, caught by its tests).
pub fn push_chunk(script: &mut Script, bytes: &[u8], pause_after_us: u64) {
    let chunk = Chunk { bytes: Vec::from_slice(bytes).unwrap_or_default(), pause_after_us };
    debug_assert!(chunk.bytes.len() == bytes.len(), "protocol chunk longer than CHUNK_LEN");
    let pushed = script.push(chunk);
    debug_assert!(pushed.is_ok(), "protocol script longer than SCRIPT_CHUNKS");
}

/// A decoded answer: how many bytes were used, and the reply if one is complete.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Decoded {
    /// Bytes consumed.
    pub consumed: usize,
    /// The reply, once complete.
    pub reply: Option<Reply>,
}

/// A point-to-point controller's wire protocol.
pub trait Protocol {
    /// The controller's name, for messages.
    const NAME: &'static str;

    /// Set-up requests before the first move (`Request::Setup(0..n)`).
    fn setup_steps(&self) -> u8;

    /// Device units per µm (valid once set-up is done: some devices are asked).
    fn units_per_um(&self) -> u32;

    /// Shortest move the device executes, device units (shorter ones are not sent).
    fn min_move_units(&self) -> i32;

    /// When a move's reply comes.
    fn move_reply(&self) -> MoveReply;

    /// Whether the device may be asked for its position while it moves (some give stale
    /// positions, some lock up).
    fn poll_while_moving(&self) -> bool;

    /// The speed along the line the device will actually move at when asked for
    /// `speed_nm_s` from `from` to `target` (device units), nm/s.
    fn achieved_speed_nm_s(&self, from: [i32; 3], target: [i32; 3], speed_nm_s: u32) -> u32;

    /// The device's travel on every axis, device units, bounds inclusive.
    fn travel_units(&self) -> (i32, i32);

    /// Longest a non-move request may wait for its reply, µs (the line's transfer time and
    /// the device's latency, with margin).
    fn reply_timeout_us(&self) -> u64;

    /// Encodes `request`.
    fn encode(&mut self, request: &Request, script: &mut Script);

    /// Decodes bytes answering `request` (a serial chunk, or one whole datagram).
    fn decode(&mut self, request: &Request, bytes: &[u8]) -> Decoded;

    /// Forgets a partly received reply (after a timeout).
    fn reset_receiver(&mut self);

    /// Whether the position may be polled while the stage rests (`idle_poll_us`). An MP-285
    /// asked for its position while its knob is turned may hang, so its adapter reads the
    /// position only when it needs it (start-up, the end of each move). Default true.
    fn idle_polls_safe(&self) -> bool {
        true
    }

    /// Decodes bytes that answer no request (a notification a device pushes, such as a
    /// Sensapex's position or move-completed datagram): [`Reply::Position`], or
    /// [`Reply::Busy`]`(false)` for a move that ended. Default: none (the bytes are counted
    /// as unreadable).
    fn unsolicited(&mut self, bytes: &[u8]) -> Option<Reply> {
        let _ = bytes;
        None
    }
}
