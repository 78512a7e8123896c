//! The firmware simulator as its own process (`mesopush-fwsim`), as on a rig: the
//! controller served on a real pseudo-terminal in real time (the executor opens the printed
//! `/dev/pts/N` like any serial device), the world moved by the stage, and a 30 Hz camera
//! streaming rendered frames on a Unix socket (`mesopush_protocol::camera`).
//!
//! Time domain: the loop's clock is the executor crate's [`MonotonicClock`] (on
//! `CLOCK_MONOTONIC`); each frame's header carries the driver's exposure stamp as
//! `CLOCK_MONOTONIC` µs, which the executor, another process on the same machine, converts
//! exactly into its own clock. The world's undeclared camera latency (if any) makes the stamp
//! late, as in one process.
//!
//! Files in the run directory: `camera.sock`, `background.png` (the empty fixture, as a user
//! records one), and `fwsim-truth.csv`: for every frame sent, the true exposure and the stamp
//! (both `CLOCK_MONOTONIC` µs) and the true peg and probe tip, flushed per row — the ground
//! truth `mesopush run --truth` compares with; never read by identification or diagnosis.

use super::ctrl_serve::{LineState, ServedController};
use super::recorder::encode_png;
use super::simloop::CameraTiming;
use super::world::{RigWorld, WorldFrame, WorldSetup};
use super::world_file::WorldFile;
use crate::Error;
use crate::geom::{Pose, Vec2};
use crate::sim::Plan;
use crate::vision::RenderSettings;
use crossbeam_channel::{Receiver, Sender, bounded};
use mesopush_executor::clock::{Clock, MonotonicClock};
use mesopush_firmware_sim::camera::{SimCamera, SimFrame};
use mesopush_firmware_sim::{ControllerNode, CtrlConfig, FaultConfig, SimRng};
use mesopush_protocol::LinkConfig;
use mesopush_protocol::camera::CameraFrameHeader;
use rand::SeedableRng;
use serialport::{SerialPort, TTYPort};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

/// Frames queued for the camera socket's writer thread.
const CAMERA_QUEUE: usize = 4;

/// What the simulator serves.
#[derive(Debug, Clone)]
pub struct FwsimOptions {
    /// The world.
    pub world: WorldFile,
    /// The plan whose start the peg and probe are placed at (as an operator would).
    pub plan: Plan,
    /// The one seed.
    pub seed: u64,
    /// Where the camera socket, background and truth go.
    pub run_dir: PathBuf,
}

/// Where to reach a running simulator.
#[derive(Debug, Clone, PartialEq)]
pub struct FwsimAddrs {
    /// The controller's serial device (pty slave).
    pub controller: String,
    /// The camera socket.
    pub camera: PathBuf,
    /// The empty fixture's frame.
    pub background: PathBuf,
    /// The truth file.
    pub truth: PathBuf,
    /// Fixture origin in stage coordinates, µm (the executor's `--fixture-origin-um`).
    pub fixture_origin_um: Vec2,
}

/// How serving ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FwsimSummary {
    /// Frames the camera exposed and delivered.
    pub frames: u64,
    /// Frames not sent (no camera client, or its queue full).
    pub frames_unsent: u64,
    /// Segments the controller applied.
    pub segments_applied: u64,
}

/// A simulator ready to serve.
#[derive(Debug)]
pub struct Fwsim {
    addrs: FwsimAddrs,
    ctrl: ServedController,
    world: RigWorld,
    clock: MonotonicClock,
    truth: BufWriter<File>,
    camera_tx: Sender<(CameraFrameHeader, Vec<u8>)>,
    unsent: Arc<AtomicU64>,
    size_px: [u32; 2],
}

/// The world, its camera timing and the stage's start for `opts` (the same seed streams
/// as the in-process loop: camera noise 12 + stream, start perturbation 13).
fn build_world(opts: &FwsimOptions, rng: &SimRng) -> Result<(RigWorld, CameraTiming), Error> {
    let ws = &opts.world.spec;
    let render = RenderSettings {
        width_px: ws.camera.size_px[0],
        height_px: ws.camera.size_px[1],
        calibration: opts.world.render_calibration()?,
        ..RenderSettings::default()
    };
    let camera = CameraTiming {
        period_us: ws.camera.period_us,
        readout_us: ws.camera.readout_us,
        start_us: ws.camera.period_us,
    };
    let nominal = ws.peg.start.map_or_else(
        || opts.plan.peg_start_pose(),
        |s| Pose::new(s.x_um, s.y_um, s.theta_deg.to_radians()),
    );
    let peg_start = match ws.peg.perturb {
        Some([dx, dy, dth]) => {
            let mut r = rng.fork(13);
            let mut u = |a: f64| (2.0 * r.unit() - 1.0) * a;
            let (x, y) = (nominal.x_um + u(dx), nominal.y_um + u(dy));
            Pose::new(x, y, nominal.theta_rad + u(dth).to_radians())
        }
        None => nominal,
    };
    let setup = WorldSetup {
        model: opts.world.model.clone(),
        peg_start,
        stage_offset_um: Vec2::new(ws.stage.offset_um[0], ws.stage.offset_um[1]),
        render,
        camera_start_us: camera.start_us,
        camera_period_us: camera.period_us,
        effects: ws.effects.clone(),
    };
    let noise =
        rand_chacha::ChaCha8Rng::seed_from_u64(rng.fork(12 + ws.camera.noise_stream).next_u64());
    Ok((RigWorld::new(setup, opts.plan.probe_start(), noise)?, camera))
}

fn io_err(what: impl AsRef<Path>, e: impl std::fmt::Display) -> Error {
    Error::io(what.as_ref(), std::io::Error::other(e.to_string()))
}

impl Fwsim {
    /// Builds the world, opens the pseudo-terminal and the camera socket, writes the
    /// background and the truth file's header.
    pub fn start(opts: &FwsimOptions) -> Result<Self, Error> {
        opts.plan.validate()?;
        std::fs::create_dir_all(&opts.run_dir).map_err(|e| Error::io(&opts.run_dir, e))?;
        let rng = SimRng::new(opts.seed);
        let (mut world, cam) = build_world(opts, &rng)?;
        let background = opts.run_dir.join("background.png");
        crate::trial::writer::write_atomic(&background, &encode_png(&world.background())?)?;
        let faults = FaultConfig {
            link_drop: 0.0,
            link_corrupt: 0.0,
            link_duplicate: 0.0,
            link_delay: 0.0,
            ..opts.world.spec.faults.to_config()?
        };
        let (master, slave) = TTYPort::pair().map_err(|e| io_err("pty", e))?;
        let controller = slave.name().ok_or_else(|| io_err("pty", "the pty slave has no path"))?;
        drop(slave); // the executor opens it by path; until then the master reads EIO
        let clock = MonotonicClock::new();
        let [ox, oy] = opts.world.spec.stage.offset_um;
        let p = opts.plan.probe_start() + Vec2::new(ox, oy);
        let start_nm = ((p.x * 1000.0).round(), (p.y * 1000.0).round());
        let node = ControllerNode::new(
            CtrlConfig::DEFAULT,
            faults,
            LinkConfig::DEFAULT,
            rng.fork(1),
            clock.now_us(),
            start_nm,
        );
        let camera =
            SimCamera::new(cam.period_us, cam.readout_us, cam.start_us, rng.fork(6), faults);
        let ctrl =
            ServedController::new(master, node, camera).map_err(|e| io_err(&controller, e))?;
        let sock = opts.run_dir.join("camera.sock");
        let listener = bind_camera(&sock)?;
        let truth_path = opts.run_dir.join("fwsim-truth.csv");
        let mut truth =
            BufWriter::new(File::create(&truth_path).map_err(|e| Error::io(&truth_path, e))?);
        writeln!(
            truth,
            "frame_seq,exposure_mono_us,stamp_mono_us,x_um,y_um,theta_rad,probe_x_um,probe_y_um"
        )
        .map_err(|e| Error::io(&truth_path, e))?;
        let (camera_tx, camera_rx) = bounded(CAMERA_QUEUE);
        let unsent = Arc::new(AtomicU64::new(0));
        let u = unsent.clone();
        std::thread::spawn(move || serve_camera(&listener, &camera_rx, &u));
        let addrs = FwsimAddrs {
            controller,
            camera: sock,
            background,
            truth: truth_path,
            fixture_origin_um: Vec2::new(ox, oy),
        };
        let size_px = opts.world.spec.camera.size_px;
        Ok(Self { addrs, ctrl, world, clock, truth, camera_tx, unsent, size_px })
    }

    /// Where to reach it.
    pub fn addrs(&self) -> &FwsimAddrs {
        &self.addrs
    }

    /// Serves in real time until the executor closes the line (after having opened it) or
    /// `stop` is set.
    pub fn serve(mut self, stop: &AtomicBool) -> Result<FwsimSummary, Error> {
        let mut seen_peer = false;
        let mut frames = 0u64;
        while !stop.load(Ordering::Relaxed) {
            let now = self.clock.now_us();
            let (line, frame) = self
                .ctrl
                .step(now, &mut self.world)
                .map_err(|e| Error::io(&self.addrs.controller, e))?;
            match line {
                LineState::Connected => seen_peer = true,
                LineState::NoPeer if seen_peer => break,
                LineState::NoPeer => {}
            }
            if let Some(f) = frame {
                frames += 1;
                self.send_frame(f)?;
            }
        }
        self.truth.flush().map_err(|e| Error::io(&self.addrs.truth, e))?;
        Ok(FwsimSummary {
            frames,
            frames_unsent: self.unsent.load(Ordering::Relaxed),
            segments_applied: super::simloop::applied_segments(&self.ctrl.node.events).0,
        })
    }

    fn send_frame(&mut self, f: SimFrame<WorldFrame>) -> Result<(), Error> {
        let exposure_mono = self.clock.to_mono_us(f.exposure_sim_us);
        let stamp_mono = self.clock.to_mono_us(self.world.driver_stamp_us(f.exposure_sim_us));
        let [w, h] = self.size_px;
        let header = CameraFrameHeader {
            frame_seq: f.frame_seq,
            capture_mono_us: Some(stamp_mono),
            black: f.black,
            width_px: w,
            height_px: h,
        };
        let truth = f.image.as_ref().map(|i| i.truth);
        let pixels = f.image.map(|i| i.image.into_raw()).unwrap_or_default();
        if self.camera_tx.try_send((header, pixels)).is_err() {
            self.unsent.fetch_add(1, Ordering::Relaxed);
        }
        if let Some(t) = truth {
            writeln!(
                self.truth,
                "{},{exposure_mono},{stamp_mono},{},{},{},{},{}",
                f.frame_seq, t.peg.x_um, t.peg.y_um, t.peg.theta_rad, t.probe_um.x, t.probe_um.y
            )
            .and_then(|()| self.truth.flush())
            .map_err(|e| Error::io(&self.addrs.truth, e))?;
        }
        Ok(())
    }
}

fn bind_camera(path: &Path) -> Result<UnixListener, Error> {
    mesopush_executor::shell::unix_line::remove_stale_socket(path)
        .map_err(|e| Error::io(path, e))?;
    let l = UnixListener::bind(path).map_err(|e| Error::io(path, e))?;
    l.set_nonblocking(true).map_err(|e| Error::io(path, e))?;
    Ok(l)
}

/// The camera socket's writer: one client at a time; frames with no client are discarded
/// (counted), a client that hangs up is replaced by the next.
fn serve_camera(
    listener: &UnixListener,
    rx: &Receiver<(CameraFrameHeader, Vec<u8>)>,
    unsent: &AtomicU64,
) {
    let mut client: Option<UnixStream> = None;
    loop {
        let msg = match rx.recv_timeout(Duration::from_millis(20)) {
            Ok(m) => Some(m),
            Err(crossbeam_channel::RecvTimeoutError::Timeout) => None,
            Err(crossbeam_channel::RecvTimeoutError::Disconnected) => return,
        };
        if client.is_none()
            && let Ok((s, _)) = listener.accept()
            && s.set_nonblocking(false).is_ok()
        {
            client = Some(s);
        }
        let Some((header, pixels)) = msg else { continue };
        let sent = client.as_mut().is_some_and(|s| {
            s.write_all(&header.encode()).and_then(|()| s.write_all(&pixels)).is_ok()
        });
        if !sent {
            client = None;
            unsent.fetch_add(1, Ordering::Relaxed);
        }
    }
}
