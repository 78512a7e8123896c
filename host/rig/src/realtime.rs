//! The loop in real time: the executor's std shell ([`Shell::run`], the same allocation-free
//! core) on its own thread with its controller line on the pseudo-terminal's slave (opened by
//! path like a serial device) and its host line on in-memory pipes; this thread serves the
//! pty's master as the firmware simulator's controller node in real time (monotonic clock),
//! moves the world, runs the camera (driver stamps in the shared clock) and the host session,
//! and forwards log records and frames to the recorder without ever blocking: a full
//! recorder queue drops the frame and counts it.
//!
//! Line faults of the world file are not injected in real time (the lines are real); stage
//! faults (stall, limit switch, reboot) and camera drops are.

use super::ctrl_serve::ServedController;
use super::painter::{Deferred, Painter};
use super::pty::PtyLine;
use super::recorder::RecMsg;
use super::session::{HostSession, SessionGoal};
use super::simloop::{CAP, EW, LA, Q};
use super::trial::{Finished, Progress, TAIL_US, TrialReport, TrialSpec, finish, prepare};
use super::world::{RigWorld, TruthSample};
use crate::Error;
use crossbeam_channel::{Receiver, Sender, bounded};
use image::GrayImage;
use mesopush_executor::clock::{Clock, MonotonicClock};
use mesopush_executor::endpoint::Endpoint;
use mesopush_executor::shell::port::{CHUNK_BYTES, Chunk, PipeReader, PipeWriter, split_tty};
use mesopush_executor::shell::runner::ShellEnd;
use mesopush_executor::shell::{Shell, ShellStats};
use mesopush_executor::{CameraFrame, Executor, ExecutorConfig, LogEvent, MemStore, StampedFrame};
use mesopush_firmware_sim::camera::{SimCamera, SimFrame};
use mesopush_firmware_sim::{ControllerNode, CtrlConfig, FaultConfig};
use mesopush_protocol::{FRAME_BUF_LEN, LinkConfig};
use serialport::TTYPort;
use std::io;
use std::path::Path;
use std::sync::Arc;
use std::thread::JoinHandle;

/// Frames queued for the painter thread (more: the frame is counted lost).
const PAINT_QUEUE: usize = 4;
/// How long a stamped frame waits for its image before it is given up, µs.
const STAMP_WAIT_US: u64 = 500_000;

/// The executor's std shell on its own thread, and this thread's ends of its lines.
struct ShellThread {
    handle: JoinHandle<(ShellEnd, ShellStats)>,
    to_exec: Sender<Chunk>,
    to_host: Receiver<Chunk>,
    frames: Sender<CameraFrame>,
    log: Receiver<LogEvent>,
    stop: Sender<()>,
}

impl ShellThread {
    /// Starts the shell with `config`, its controller line on `ctrl_port` (the pty's slave).
    fn spawn(
        config: ExecutorConfig,
        ctrl_port: TTYPort,
        ctrl_path: &str,
        clock: Arc<MonotonicClock>,
    ) -> Result<Self, Error> {
        let ctrl = split_tty(ctrl_port)
            .map_err(|e| Error::io(ctrl_path, io::Error::other(e.to_string())))?;
        let (to_exec, to_exec_rx) = bounded(1024);
        let (to_host_tx, to_host) = bounded::<Chunk>(1024);
        let (frames, frame_rx) = bounded::<CameraFrame>(64);
        let (log_tx, log) = bounded::<LogEvent>(4096);
        let (stop, stop_rx) = bounded::<()>(1);
        let core = Executor::<_, CAP, LA>::new(config, MemStore::<CAP>::new())
            .map_err(|e| Error::invalid("executor config", format!("{e:?}")))?;
        let mut endpoint = Endpoint::<_, CAP, LA, EW>::new(core, LinkConfig::DEFAULT, 1);
        let handle = std::thread::spawn(move || {
            let mut stats = ShellStats::default();
            let host = (PipeReader::from(to_exec_rx), PipeWriter::from(to_host_tx));
            let end = Shell::run(
                &mut endpoint,
                &*clock,
                host,
                ctrl,
                Some(frame_rx),
                log_tx,
                stop_rx,
                &mut stats,
            );
            (end, stats)
        });
        Ok(Self { handle, to_exec, to_host, frames, log, stop })
    }

    fn join(self) {
        let _ = self.stop.send(());
        let _ = self.handle.join();
    }
}

/// The painter thread: truth in, image out (the controller's loop never renders).
struct PainterThread {
    truth: Sender<(u32, TruthSample)>,
    images: Receiver<(u32, GrayImage)>,
    handle: JoinHandle<()>,
}

impl PainterThread {
    fn spawn(mut painter: Painter) -> Self {
        Self::spawn_with(move |t| painter.paint_image(t))
    }

    fn spawn_with(mut paint: impl FnMut(&TruthSample) -> GrayImage + Send + 'static) -> Self {
        let (truth, truth_rx) = bounded::<(u32, TruthSample)>(PAINT_QUEUE);
        let (image_tx, images) = bounded::<(u32, GrayImage)>(PAINT_QUEUE);
        let handle = std::thread::spawn(move || {
            for (seq, t) in truth_rx {
                if image_tx.send((seq, paint(&t))).is_err() {
                    break;
                }
            }
        });
        Self { truth, images, handle }
    }

    /// Stops the painter: both queues are dropped first, so a painter blocked on a full
    /// image queue (the loop ended with frames still in the painter's hands) gets an error
    /// and ends instead of waiting forever on a receiver nobody reads.
    fn join(self) {
        let Self { truth, images, handle } = self;
        drop(truth);
        drop(images);
        let _ = handle.join();
    }
}

/// What goes to the recorder: never blocks (a full queue counts the record lost), and pairs
/// each stamped frame with its image once the painter has drawn it.
struct Relay {
    rec: Sender<RecMsg>,
    lost: u64,
    images: Vec<(u32, Option<GrayImage>)>,
    stamped_waiting: Vec<(StampedFrame, u64)>,
}

impl Relay {
    fn forward(&mut self, msg: RecMsg) {
        if self.rec.try_send(msg).is_err() {
            self.lost += 1;
        }
    }

    /// A frame the camera delivered: its stamp to the executor, its truth to the painter (a
    /// full queue skips it: its stamp then waits in vain and is counted lost); a black frame
    /// (no truth) has no image.
    fn on_camera_frame(
        &mut self,
        frame: SimFrame<TruthSample>,
        stamp_us: u64,
        shell: &ShellThread,
        painter: &PainterThread,
    ) {
        let cam = CameraFrame {
            frame_seq: frame.frame_seq,
            driver_stamp_us: Some(stamp_us),
            black: frame.black,
        };
        if shell.frames.try_send(cam).is_err() {
            self.lost += 1;
        }
        match frame.image {
            Some(t) => drop(painter.truth.try_send((frame.frame_seq, t))),
            None => self.images.push((frame.frame_seq, None)),
        }
    }

    /// The executor's log records to the recorder; frames it stamped wait for their image.
    fn on_log(&mut self, now: u64, e: LogEvent) {
        if let LogEvent::Frame(stamped) = e {
            self.stamped_waiting.push((stamped, now));
        }
        self.forward(RecMsg::Log(now, e));
    }

    /// Sends each stamped frame whose image the painter has drawn; gives up on one after
    /// [`STAMP_WAIT_US`].
    fn release_frames(&mut self, now: u64, painter: &PainterThread) {
        while let Ok((seq, image)) = painter.images.try_recv() {
            self.images.push((seq, Some(image)));
        }
        if self.images.len() > 8 {
            self.images.drain(..self.images.len() - 8);
        }
        let mut waiting = std::mem::take(&mut self.stamped_waiting);
        waiting.retain(|(stamped, arrival_us)| {
            let seq = stamped.stamp.frame_seq;
            let Some(i) = self.images.iter().position(|(s, _)| *s == seq) else {
                let still = now < arrival_us + STAMP_WAIT_US;
                self.lost += u64::from(!still);
                return still;
            };
            let image = self.images.remove(i).1;
            self.forward(RecMsg::Frame { stamped: *stamped, arrival_us: *arrival_us, image });
            false
        });
        self.stamped_waiting = waiting;
    }
}

/// Runs `spec` in real time.
pub fn run_realtime(
    spec: &TrialSpec,
    out_dir: &Path,
    progress: &mut dyn FnMut(Progress),
) -> Result<TrialReport, Error> {
    let prep = prepare(spec, out_dir)?;
    let faults = FaultConfig {
        link_drop: 0.0,
        link_corrupt: 0.0,
        link_duplicate: 0.0,
        link_delay: 0.0,
        ..super::world_file::validated_faults(&spec.world.spec.faults)?
    };
    let clock = Arc::new(MonotonicClock::new());
    let pty = PtyLine::open()?;
    let path = pty.path().to_string();
    let (master, ctrl_port, _slave) = pty.into_parts();
    let shell = ShellThread::spawn(prep.config, ctrl_port, &path, clock.clone())?;
    let (rec_tx, rec_rx) = bounded(256);
    let recorder = prep.recorder;
    let rec = std::thread::spawn(move || recorder.run(rec_rx));
    let node: ControllerNode<Q, EW> = ControllerNode::new(
        CtrlConfig::DEFAULT,
        faults,
        LinkConfig::DEFAULT,
        prep.rng.fork(1),
        clock.now_us(),
        prep.probe_start_nm,
    );
    let c = prep.camera;
    let camera = SimCamera::new(c.period_us, c.readout_us, c.start_us, prep.rng.fork(6), faults);
    let mut ctrl =
        ServedController::new(master, node, camera).map_err(|e| Error::io("pty master", e))?;
    let mut world = prep.world;
    let painter = PainterThread::spawn(world.painter());
    let mut host = HostSession::new(&spec.plan, SessionGoal::FlashAndRun, 7_001)?;
    let mut relay = Relay { rec: rec_tx, lost: 0, images: Vec::new(), stamped_waiting: Vec::new() };
    let limits = Limits {
        total_s: prep.plan_duration_s + 2.0,
        max_us: ((prep.plan_duration_s + 30.0) * 1e6) as u64,
    };
    let mut lp = Loop { ctrl: &mut ctrl, world: &mut world, host: &mut host, relay: &mut relay };
    let result = lp.run(&clock, &shell, &painter, limits, progress);
    shell.join();
    painter.join();
    let lost = relay.lost;
    drop(relay);
    let recorded =
        rec.join().map_err(|_| Error::invalid("recorder", "the recorder panicked"))??;
    result?;
    let done = Finished {
        end: host.end().cloned(),
        applied: super::simloop::applied_segments(&ctrl.node.events),
        segments_expected: prep.segments_expected,
        faults_injected: ctrl.camera.dropped + ctrl.camera.black,
        records_lost: lost,
        sim_time_s: clock.now_us() as f64 * 1e-6,
        camera_latency_us: world.camera_latency_us(),
    };
    finish(out_dir, recorded, world.truth(), world.fixture(), done)
}

/// How long the loop may run.
#[derive(Debug, Clone, Copy)]
struct Limits {
    /// The trial's expected length for the progress bar, s.
    total_s: f64,
    /// Give up at this clock time, µs.
    max_us: u64,
}

/// This thread's loop: the controller on the pty master, the world, the host session.
struct Loop<'a> {
    ctrl: &'a mut ServedController,
    world: &'a mut RigWorld,
    host: &'a mut HostSession,
    relay: &'a mut Relay,
}

impl Loop<'_> {
    fn run(
        &mut self,
        clock: &MonotonicClock,
        shell: &ShellThread,
        painter: &PainterThread,
        limits: Limits,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<(), Error> {
        let mut out = [0u8; FRAME_BUF_LEN];
        let (mut ended_at, mut next_progress) = (None, 0);
        loop {
            let now = clock.now_us();
            self.serve_controller(now, shell, painter)?;
            self.relay.release_frames(now, painter);
            self.serve_host(now, shell, &mut out)?;
            while let Ok(e) = shell.log.try_recv() {
                self.relay.on_log(now, e);
            }
            if now >= next_progress {
                next_progress = now + 100_000;
                progress(Progress { t_s: now as f64 * 1e-6, total_s: limits.total_s });
            }
            if self.host.end().is_some() && ended_at.is_none() {
                ended_at = Some(now);
            }
            if ended_at.is_some_and(|t| now >= t + TAIL_US) || now > limits.max_us {
                return Ok(());
            }
        }
    }

    fn serve_controller(
        &mut self,
        now: u64,
        shell: &ShellThread,
        painter: &PainterThread,
    ) -> Result<(), Error> {
        let (_, frame) = self
            .ctrl
            .step(now, &mut Deferred { world: self.world })
            .map_err(|e| Error::io("pty master", e))?;
        if let Some(frame) = frame {
            let stamp_us = self.world.driver_stamp_us(frame.exposure_sim_us);
            self.relay.on_camera_frame(frame, stamp_us, shell, painter);
        }
        Ok(())
    }

    fn serve_host(
        &mut self,
        now: u64,
        shell: &ShellThread,
        out: &mut [u8; FRAME_BUF_LEN],
    ) -> Result<(), Error> {
        while let Ok(c) = shell.to_host.try_recv() {
            self.host.on_bytes(now, c.bytes());
        }
        self.host.poll(now)?;
        while let Some(f) = self.host.transmit(now, out) {
            for piece in f.chunks(CHUNK_BYTES) {
                let _ = shell.to_exec.send(Chunk::new(piece));
            }
        }
        for (t, msg) in std::mem::take(&mut self.host.inbox) {
            self.relay.forward(RecMsg::Host(t, msg));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mesopush_core::geom::{Pose, Vec2};

    /// Caught by `hil_processes` under load: `demo --realtime` hung for good after its loop
    /// ended, the main thread joining a painter blocked on a full image queue whose receiver
    /// the join kept alive. The join must return; a hang fails the wait below.
    #[test]
    fn the_painter_stops_when_its_image_queue_is_full_and_unread() {
        let painter = PainterThread::spawn_with(|_| GrayImage::new(4, 4));
        let t = TruthSample {
            t_us: 0,
            peg: Pose::new(0.0, 0.0, 0.0),
            probe_um: Vec2::zeros(),
            deflection_um: 0.0,
            jams: 0,
        };
        for seq in 0..(2 * PAINT_QUEUE as u32 + 2) {
            if painter.truth.send_timeout((seq, t), std::time::Duration::from_secs(5)).is_err() {
                break; // the painter is blocked and its truth queue is full too
            }
        }
        let (done_tx, done_rx) = bounded(1);
        std::thread::spawn(move || {
            painter.join();
            let _ = done_tx.send(());
        });
        let joined = done_rx.recv_timeout(std::time::Duration::from_secs(60));
        assert!(joined.is_ok(), "the painter thread did not stop");
    }
}
