//! The firmware simulator's controller served on a pseudo-terminal's master in real time:
//! one [`ServedController::step`] reads what the executor wrote, runs the controller node,
//! writes its frames back, moves the world to the stage's position and polls the camera.
//! Used by the in-process real-time loop (the drive module's) and by the `mesopush-fwsim`
//! process (`Fwsim`).

use super::controller::Controller;
use mesopush_firmware_sim::World;
use mesopush_firmware_sim::camera::{SimCamera, SimFrame};
use mesopush_protocol::FRAME_BUF_LEN;
use serialport::{SerialPort, TTYPort};
use std::io::{self, Read, Write};
use std::time::Duration;

/// What the executor's end of the line looks like.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineState {
    /// Nobody has the slave open (reads of the master fail with `EIO`).
    NoPeer,
    /// The executor has it open.
    Connected,
}

/// The controller node, its pty master and the camera.
#[derive(Debug)]
pub struct ServedController {
    master: TTYPort,
    /// The controller node (firmware core, its link and drifting clock).
    pub node: Controller,
    /// The camera.
    pub camera: SimCamera,
    buf: [u8; 512],
    out: Box<[u8; FRAME_BUF_LEN]>,
}

/// `EIO`: the pty master's read when no process has the slave open.
const EIO: i32 = 5;

/// Whether `e` says that nobody has the slave open: `EIO` from the read itself, or the
/// hang-up (`POLLHUP`) that `serialport` reports as a broken pipe.
fn no_peer(e: &io::Error) -> bool {
    e.raw_os_error() == Some(EIO) || e.kind() == io::ErrorKind::BrokenPipe
}

impl ServedController {
    /// Serves `node` on `master` (reads wait at most 1 ms) with `camera`.
    pub fn new(mut master: TTYPort, node: Controller, camera: SimCamera) -> io::Result<Self> {
        master
            .set_timeout(Duration::from_millis(1))
            .map_err(|e| io::Error::other(e.to_string()))?;
        Ok(Self { master, node, camera, buf: [0; 512], out: Box::new([0; FRAME_BUF_LEN]) })
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
        let (state, n) = match self.master.read(&mut self.buf) {
            Ok(n) => (LineState::Connected, n),
            Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock) => {
                (LineState::Connected, 0)
            }
            Err(e) if no_peer(&e) => {
                std::thread::sleep(Duration::from_millis(1));
                (LineState::NoPeer, 0)
            }
            Err(e) => return Err(e),
        };
        self.node.on_bytes(now_us, &self.buf[..n]);
        self.node.tick(now_us);
        if state == LineState::Connected {
            while let Some(f) = self.node.transmit(now_us, &mut self.out[..]) {
                match self.master.write_all(f) {
                    Ok(()) => {}
                    Err(e) if no_peer(&e) => return Ok((LineState::NoPeer, None)),
                    Err(e) => return Err(e),
                }
            }
        }
        world.step(now_us, self.node.probe_nm());
        Ok((state, self.camera.poll(now_us, world)))
    }
}
