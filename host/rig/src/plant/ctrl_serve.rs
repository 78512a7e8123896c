//! The firmware simulator's controller served on a pseudo-terminal's master in real time:
//! one [`ServedController::step`] reads what the executor wrote, runs the controller node,
//! writes its frames back, moves the world to the stage's position and polls the camera.
//! Used by the in-process real-time loop (the drive module's) and by the `mesopush-fwsim`
//! process (`Fwsim`). The controller is the project's node or an emulated commercial one
//! ([`Plant`]); a network controller (the Sensapex) is served on a UDP socket instead,
//! one datagram per read and per reply, to whichever address last wrote to it.
//!
//! Writes never hold the loop up: frames go to a writer thread through a bounded queue
//! ([`TX_QUEUE_FRAMES`]), like a UART's transmit FIFO; the writer waits for the line as long
//! as it takes. When the executor does not read for a while (a starved reader thread),
//! frames that find the queue full are dropped and counted
//! ([`ServedController::tx_dropped_frames`]); the reliable link resends them. Regression
//! (issue 19): the loop wrote itself, with the master's 1 ms timeout, and a write that
//! timed out ended `mesopush-fwsim` (`Operation timed out`), so the executor then saw a
//! silent controller; a write that found some room but not enough could block the loop.

use super::vendor::Plant;
use mesopush_executor::shell::rt_queue::{Receiver, Sender, TrySendError, bounded};
use mesopush_firmware_sim::World;
use mesopush_firmware_sim::camera::{SimCamera, SimFrame};
use mesopush_protocol::FRAME_BUF_LEN;
use serialport::{SerialPort, TTYPort};
use std::io::{self, Read, Write};
use std::net::{SocketAddr, UdpSocket};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Frames the writer thread's queue holds (≈ 0.5 s of the controller's reports).
pub const TX_QUEUE_FRAMES: usize = 128;

/// What the executor's end of the line looks like.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineState {
    /// Nobody has the slave open (reads of the master fail with `EIO`).
    NoPeer,
    /// The executor has it open.
    Connected,
}

/// The line the controller is served on.
#[derive(Debug)]
pub enum ServedLine {
    /// A pseudo-terminal's master (serial controllers).
    Pty(TTYPort),
    /// A UDP socket (network controllers); replies go to the last sender.
    Udp(UdpSocket),
}

/// The controller node, its line and the camera.
#[derive(Debug)]
pub struct ServedController {
    master: Option<TTYPort>,
    udp: Option<(UdpSocket, Option<SocketAddr>)>,
    /// The controller (the project's node, or an emulated commercial controller).
    pub node: Plant,
    /// The camera.
    pub camera: SimCamera,
    buf: [u8; 512],
    out: Box<[u8; FRAME_BUF_LEN]>,
    tx: Sender<Vec<u8>>,
    writer_failed: Arc<AtomicBool>,
    tx_dropped_frames: u64,
}

/// The writer thread: writes each queued frame whole, waiting for the line; a frame the
/// line cannot take because nobody has the slave open is dropped (the node resends).
/// Ends when the queue's sender is dropped, or on another write error (`failed` set).
fn write_frames(mut port: TTYPort, rx: &Receiver<Vec<u8>>, failed: &AtomicBool) {
    while let Some(frame) = rx.recv() {
        let mut off = 0;
        while off < frame.len() {
            match port.write(&frame[off..]) {
                Ok(n) => off += n,
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::TimedOut
                            | io::ErrorKind::WouldBlock
                            | io::ErrorKind::Interrupted
                    ) => {}
                Err(e) if no_peer(&e) => {
                    std::thread::sleep(Duration::from_millis(1));
                    break;
                }
                Err(_) => {
                    failed.store(true, Ordering::Relaxed);
                    return;
                }
            }
        }
    }
}

/// `EIO`: the pty master's read when no process has the slave open.
const EIO: i32 = 5;

/// Whether `e` says that nobody has the slave open: `EIO` from the read itself, or the
/// hang-up (`POLLHUP`) that `serialport` reports as a broken pipe.
fn no_peer(e: &io::Error) -> bool {
    e.raw_os_error() == Some(EIO) || e.kind() == io::ErrorKind::BrokenPipe
}

impl ServedController {
    /// Serves `node` on `line` (reads wait at most 1 ms) with `camera`.
    pub fn new(line: ServedLine, node: Plant, camera: SimCamera) -> io::Result<Self> {
        let (tx, rx) = bounded(TX_QUEUE_FRAMES);
        let writer_failed = Arc::new(AtomicBool::new(false));
        let (master, udp) = match line {
            ServedLine::Pty(mut master) => {
                master
                    .set_timeout(Duration::from_millis(1))
                    .map_err(|e| io::Error::other(e.to_string()))?;
                let writer =
                    master.try_clone_native().map_err(|e| io::Error::other(e.to_string()))?;
                let failed = writer_failed.clone();
                std::thread::Builder::new()
                    .name("fwsim-ctrl-tx".into())
                    .spawn(move || write_frames(writer, &rx, &failed))?;
                (Some(master), None)
            }
            ServedLine::Udp(socket) => {
                socket.set_read_timeout(Some(Duration::from_millis(1)))?;
                (None, Some((socket, None)))
            }
        };
        Ok(Self {
            master,
            udp,
            node,
            camera,
            buf: [0; 512],
            out: Box::new([0; FRAME_BUF_LEN]),
            tx,
            writer_failed,
            tx_dropped_frames: 0,
        })
    }

    /// Frames dropped because the writer's queue was full (the executor did not read).
    pub fn tx_dropped_frames(&self) -> u64 {
        self.tx_dropped_frames
    }

    /// Frames waiting for the writer.
    pub fn tx_queued_frames(&self) -> usize {
        self.tx.len()
    }

    /// One round at `now_us`: line, controller, world, camera. Returns the line's state and
    /// the frame the camera delivered, if any (what `world.render` returns: a rendered image,
    /// or only what to render when the caller renders elsewhere). With no peer the
    /// controller runs but sends nothing (a write into an unread pty would block once its
    /// buffer fills).
    pub fn step<W: World>(
        &mut self,
        now_us: u64,
        world: &mut W,
    ) -> io::Result<(LineState, Option<SimFrame<W::Frame>>)> {
        let (state, n) = self.read()?;
        if n > 0 || self.master.is_some() {
            self.node.on_bytes(now_us, &self.buf[..n]);
        }
        self.node.tick(now_us);
        if self.writer_failed.load(Ordering::Relaxed) {
            return Err(io::Error::other("writing to the pty master failed"));
        }
        if let Some((socket, Some(peer))) = &self.udp {
            while let Some(d) = self.node.transmit(now_us, &mut self.out[..]) {
                match socket.send_to(d, peer) {
                    Ok(_) => {}
                    Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => {}
                    Err(e) => return Err(e),
                }
            }
        } else if state == LineState::Connected && self.master.is_some() {
            while let Some(f) = self.node.transmit(now_us, &mut self.out[..]) {
                match self.tx.try_send(f.to_vec()) {
                    Ok(()) => {}
                    Err(TrySendError::Full(_)) => self.tx_dropped_frames += 1,
                    Err(TrySendError::Disconnected(_)) => {
                        return Err(io::Error::other("the pty writer thread ended"));
                    }
                }
            }
        }
        self.node.step_world(now_us, world);
        Ok((state, self.camera.poll(now_us, world)))
    }

    /// Reads what arrived: a chunk of the pty, or one datagram (whose sender becomes the
    /// peer replies go to).
    fn read(&mut self) -> io::Result<(LineState, usize)> {
        let quiet = |e: &io::Error| {
            matches!(
                e.kind(),
                io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
            )
        };
        if let Some((socket, peer)) = self.udp.as_mut() {
            return match socket.recv_from(&mut self.buf) {
                Ok((n, from)) => {
                    *peer = Some(from);
                    Ok((LineState::Connected, n))
                }
                Err(e) if quiet(&e) || e.kind() == io::ErrorKind::ConnectionRefused => {
                    let state =
                        if peer.is_some() { LineState::Connected } else { LineState::NoPeer };
                    Ok((state, 0))
                }
                Err(e) => Err(e),
            };
        }
        let Some(master) = self.master.as_mut() else { return Ok((LineState::NoPeer, 0)) };
        match master.read(&mut self.buf) {
            Ok(n) => Ok((LineState::Connected, n)),
            Err(e) if quiet(&e) => Ok((LineState::Connected, 0)),
            Err(e) if no_peer(&e) => {
                std::thread::sleep(Duration::from_millis(1));
                Ok((LineState::NoPeer, 0))
            }
            Err(e) => Err(e),
        }
    }
}
