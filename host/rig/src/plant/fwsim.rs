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
//! Threads: the controller loop (line, controller node, world physics, camera schedule)
//! never renders. At each delivered frame it hands the frame's header and ground truth to
//! the renderer thread through a bounded `rt_queue` (`RENDER_QUEUE`; it never spins on the renderer
//! when the loop runs at `--rt-priority`) with `try_send`: when the
//! renderer falls behind, the frame is dropped and counted (`frames_render_dropped`; the
//! executor sees the counter gap as a dropped frame), the controller never waits. The
//! renderer draws the synthetic microscope image (its own noise stream, seed stream
//! `1000 + noise_stream`), writes the truth row and queues the frame for the camera socket's
//! writer thread (`CAMERA_QUEUE`, again never waited for). Rendering a 928 × 480 frame takes
//! milliseconds; on the controller's loop it delayed clock-sync replies past the executor's
//! limit under load (docs/hil.md).
//!
//! Files in the run directory: `camera.sock`, `background.png` (the empty fixture, as a user
//! records one), `fwsim-world.json` (the seed and the world's description, which
//! `mesopush run --sim-world` records as trial.json's `world`), and `fwsim-truth.csv`: for every frame sent, the true exposure and the stamp
//! (both `CLOCK_MONOTONIC` µs) and the true peg and probe tip, flushed per row — the ground
//! truth `mesopush run --truth` compares with; never read by identification or diagnosis.

use super::assemble::{Assembled, CameraTiming, assemble};
use super::controller::{applied_segments, controller};
use super::ctrl_serve::{LineState, ServedController, ServedLine};
use super::frame_png::encode_png;
use super::truth::TruthSample;
use super::vendor::{EmulatorBox, Plant, emulator};
use super::world::RigWorld;
use super::world_file::{WorldFile, realtime_faults};
use crate::Error;
use crossbeam_channel::bounded;
use mesopush_core::geom::Vec2;
use mesopush_executor::clock::{Clock, MonotonicClock};
use mesopush_executor::shell::controller::ControllerKind;
use mesopush_executor::shell::rt_queue;
use mesopush_firmware_sim::SimRng;
use mesopush_firmware_sim::camera::{SimCamera, SimFrame};
use mesopush_protocol::camera::CameraFrameHeader;
use mesopush_protocol::units::um_to_nm;
use mesopush_sim::{Fixture, Plan};
use mesopush_vision::Renderer;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serialport::{SerialPort, TTYPort};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;

/// Frames queued for the camera socket's writer thread.
const CAMERA_QUEUE: usize = 4;
/// Frames queued for the renderer thread (≈ 2 frame periods).
const RENDER_QUEUE: usize = 2;

mod render;
use super::painter::{Deferred, Painter};
use render::{RenderJob, bind_camera, render_frames, serve_camera};

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
    /// The controller to serve (the project's, or an emulated commercial one).
    pub controller: ControllerKind,
}

/// Where to reach a running simulator.
#[derive(Debug, Clone, PartialEq)]
pub struct FwsimAddrs {
    /// The controller's line: a serial device (pty slave), or `udp:HOST:PORT`.
    pub controller: String,
    /// The camera socket.
    pub camera: PathBuf,
    /// The empty fixture's frame.
    pub background: PathBuf,
    /// The truth file.
    pub truth: PathBuf,
    /// The world's description and seed (`fwsim-world.json`, for trial.json's `world`).
    pub world: PathBuf,
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
    /// Frames dropped because the renderer had fallen behind (its queue full).
    pub frames_render_dropped: u64,
    /// Segments the controller applied.
    pub segments_applied: u64,
    /// Jam episodes: the needle deflected beyond the limit (`RigWorld::jam_events`).
    pub jams: u64,
    /// Controller frames dropped because the executor did not read the line for a while
    /// (the send buffer was full; the link resent them).
    pub line_frames_dropped: u64,
}

/// A simulator ready to serve.
#[derive(Debug)]
pub struct Fwsim {
    addrs: FwsimAddrs,
    ctrl: ServedController,
    world: RigWorld,
    clock: MonotonicClock,
    render_tx: rt_queue::Sender<RenderJob>,
    renderer: JoinHandle<Result<(), Error>>,
    render_dropped: u64,
    unsent: Arc<AtomicU64>,
    size_px: [u32; 2],
}

/// The world, its camera timing and the stage's start for `opts` (the same seed streams
/// as the in-process loop: camera noise 12 + stream, start perturbation 13).
fn build_world(
    opts: &FwsimOptions,
    rng: &SimRng,
) -> Result<(RigWorld, CameraTiming, Painter), Error> {
    let ws = &opts.world.spec;
    let Assembled { world, camera, render, .. } = assemble(&opts.world, &opts.plan, None, rng)?;
    let walls = Fixture::paper().walls;
    let painter = Painter {
        renderer: Renderer::new(render, &walls)?,
        walls,
        peg: opts.world.model.part.polygon().clone(),
        rng: ChaCha8Rng::seed_from_u64(rng.fork(1000 + ws.camera.noise_stream).next_u64()),
    };
    Ok((world, camera, painter))
}

fn io_err(what: impl AsRef<Path>, e: impl std::fmt::Display) -> Error {
    Error::io(what.as_ref(), std::io::Error::other(e.to_string()))
}

/// The controller served on a new pseudo-terminal (the slave's path returned: the executor
/// opens it) — or, for a network controller, on a loopback UDP socket (`udp:127.0.0.1:PORT`
/// returned) — the stage at the plan's start, with the camera, on `clock`.
fn serve_controller(
    opts: &FwsimOptions,
    rng: &SimRng,
    cam: CameraTiming,
    clock: &MonotonicClock,
) -> Result<(ServedController, String), Error> {
    let faults = realtime_faults(&opts.world.spec.faults)?;
    let [ox, oy] = opts.world.spec.stage.offset_um;
    let p = opts.plan.probe_start() + Vec2::new(ox, oy);
    let start_nm = (um_to_nm("stage start x", p.x)?, um_to_nm("stage start y", p.y)?);
    let limit_um = opts.world.model.probe_deflection_limit_um;
    let node = match opts.controller {
        ControllerKind::Native => {
            let node = controller(faults, rng.fork(1), clock.now_us(), start_nm, limit_um)?;
            Plant::Native(Box::new(node))
        }
        kind => {
            let seed = rng.fork(1).below(u64::MAX);
            Plant::Vendor(EmulatorBox(emulator(kind, start_nm, clock.now_us(), seed)?))
        }
    };
    let (line, path) = if opts.controller == ControllerKind::Sensapex {
        let socket = UdpSocket::bind("127.0.0.1:0").map_err(|e| io_err("udp", e))?;
        let addr = socket.local_addr().map_err(|e| io_err("udp", e))?;
        (ServedLine::Udp(socket), format!("udp:{addr}"))
    } else {
        let (master, slave) = TTYPort::pair().map_err(|e| io_err("pty", e))?;
        let path = slave.name().ok_or_else(|| io_err("pty", "the pty slave has no path"))?;
        drop(slave); // the executor opens it by path; until then the master reads EIO
        (ServedLine::Pty(master), path)
    };
    let camera = SimCamera::new(cam.period_us, cam.readout_us, cam.start_us, rng.fork(6), faults);
    let ctrl = ServedController::new(line, node, camera).map_err(|e| io_err(&path, e))?;
    Ok((ctrl, path))
}

/// Creates the truth file and writes its header.
fn open_truth(path: &Path) -> Result<BufWriter<File>, Error> {
    let mut truth = BufWriter::new(File::create(path).map_err(|e| Error::io(path, e))?);
    writeln!(
        truth,
        "frame_seq,exposure_mono_us,stamp_mono_us,x_um,y_um,theta_rad,probe_x_um,probe_y_um"
    )
    .map_err(|e| Error::io(path, e))?;
    Ok(truth)
}

/// Writes `fwsim-world.json` (the seed and the world's description); returns its path.
fn write_world(opts: &FwsimOptions) -> Result<PathBuf, Error> {
    let path = opts.run_dir.join("fwsim-world.json");
    let description = serde_json::json!({ "seed": opts.seed, "world": opts.world.description() });
    let text = serde_json::to_string_pretty(&description)
        .map_err(|e| Error::invalid("fwsim-world.json", e.to_string()))?;
    mesopush_core::fsx::write_atomic(&path, text.as_bytes())?;
    Ok(path)
}

impl Fwsim {
    /// Builds the world, opens the pseudo-terminal and the camera socket, writes the
    /// background and the truth file's header.
    pub fn start(opts: &FwsimOptions) -> Result<Self, Error> {
        opts.plan.validate()?;
        std::fs::create_dir_all(&opts.run_dir).map_err(|e| Error::io(&opts.run_dir, e))?;
        let rng = SimRng::new(opts.seed);
        let (mut world, cam, painter) = build_world(opts, &rng)?;
        let background = opts.run_dir.join("background.png");
        mesopush_core::fsx::write_atomic(&background, &encode_png(&world.background())?)?;
        let clock = MonotonicClock::new();
        let (ctrl, controller) = serve_controller(opts, &rng, cam, &clock)?;
        let sock = opts.run_dir.join("camera.sock");
        let listener = bind_camera(&sock)?;
        let truth_path = opts.run_dir.join("fwsim-truth.csv");
        let truth = open_truth(&truth_path)?;
        let (camera_tx, camera_rx) = bounded(CAMERA_QUEUE);
        let unsent = Arc::new(AtomicU64::new(0));
        let u = unsent.clone();
        std::thread::spawn(move || serve_camera(&listener, &camera_rx, &u));
        let (render_tx, render_rx) = rt_queue::bounded(RENDER_QUEUE);
        let (u, tp) = (unsent.clone(), truth_path.clone());
        let renderer = std::thread::spawn(move || {
            render_frames(painter, &render_rx, &camera_tx, &u, (truth, &tp))
        });
        let world_path = write_world(opts)?;
        let [ox, oy] = opts.world.spec.stage.offset_um;
        let addrs = FwsimAddrs {
            controller,
            camera: sock,
            background,
            truth: truth_path,
            world: world_path,
            fixture_origin_um: Vec2::new(ox, oy),
        };
        let size_px = opts.world.spec.camera.size_px;
        let render_dropped = 0;
        Ok(Self { addrs, ctrl, world, clock, render_tx, renderer, render_dropped, unsent, size_px })
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
            let mut world = Deferred { world: &mut self.world };
            let (line, frame) = self
                .ctrl
                .step(now, &mut world)
                .map_err(|e| Error::io(&self.addrs.controller, e))?;
            match line {
                LineState::Connected => seen_peer = true,
                LineState::NoPeer if seen_peer => break,
                LineState::NoPeer => {}
            }
            if let Some(f) = frame {
                frames += 1;
                self.queue_frame(f);
            }
        }
        drop(self.render_tx); // the renderer drains its queue and ends
        self.renderer.join().map_err(|_| io_err("renderer", "the renderer thread panicked"))??;
        Ok(FwsimSummary {
            frames,
            frames_unsent: self.unsent.load(Ordering::Relaxed),
            frames_render_dropped: self.render_dropped,
            segments_applied: applied_segments(self.ctrl.node.events()).0,
            jams: u64::try_from(self.world.jam_events().len()).unwrap_or(u64::MAX),
            line_frames_dropped: self.ctrl.tx_dropped_frames(),
        })
    }

    /// Hands a delivered frame to the renderer; never waits (a full queue drops it).
    fn queue_frame(&mut self, f: SimFrame<TruthSample>) {
        let stamp_mono = self.clock.to_mono_us(self.world.driver_stamp_us(f.exposure_sim_us));
        let [w, h] = self.size_px;
        let header = CameraFrameHeader {
            frame_seq: f.frame_seq,
            capture_mono_us: Some(stamp_mono),
            black: f.black,
            width_px: w,
            height_px: h,
        };
        let exposure_mono_us = self.clock.to_mono_us(f.exposure_sim_us);
        let job = RenderJob { header, exposure_mono_us, truth: f.image };
        if self.render_tx.try_send(job).is_err() {
            self.render_dropped += 1;
        }
    }
}
